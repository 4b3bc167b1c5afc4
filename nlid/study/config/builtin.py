"""The built-in studies: TOML files shipped inside the package (``nlid study list``)."""

from __future__ import annotations

import os
from pathlib import Path

from ...base.validate import did_you_mean
from ...errors import InputError

__all__ = ["BUILTIN_PACKAGE_DIR", "builtin_dirs", "builtin_studies", "resolve_study_path"]

#: Package folder of the built-in studies (package data; copies of the repository's ``studies/``).
BUILTIN_PACKAGE_DIR = "studies"


def builtin_dirs() -> list[Path]:
    """Folders searched for built-in studies: the package data folder ``nlid/studies``.

    The studies ship inside the package (read with :mod:`importlib.resources`),
    so every kind of install finds them: a virtual environment, ``pip install
    --user``, ``pip install --target DIR`` or the source tree.
    """
    from importlib.resources import files

    return [Path(str(files("nlid") / BUILTIN_PACKAGE_DIR))]


def builtin_studies() -> dict[str, Path]:
    """``{name: path}`` of the built-in studies (the first folder that has a name wins)."""
    out: dict[str, Path] = {}
    for folder in builtin_dirs():
        if folder.is_dir():
            for path in sorted(folder.glob("*.toml")):
                out.setdefault(path.stem, path)
    return out


def resolve_study_path(name_or_path: str | os.PathLike[str]) -> Path:
    """A study file from a built-in name or a path.

    Raises
    ------
    InputError
        Naming the built-in studies (with a suggestion) when neither matches.
    """
    text = str(name_or_path)
    path = Path(text).expanduser()
    if path.is_dir():
        raise InputError(f"study file {text} is a folder, not a .toml file")
    if path.suffix == ".toml" or os.sep in text or path.is_file():
        if path.is_dir():
            raise InputError(f"study file {text} is a folder, not a .toml file")
        if not path.is_file():
            if path.exists():  # a pipe, a socket or a device
                raise InputError(f"study file {text} is not a regular file")
            raise InputError(f"study file {text} not found")
        return path
    studies = builtin_studies()
    if text in studies:
        return studies[text]
    raise InputError(
        f"unknown study {text!r}{did_you_mean(text, studies)}"
        f"; built-in studies: {', '.join(studies) or 'none found'} (or give a path to a .toml file)"
    )
