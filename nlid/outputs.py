"""Where nlid writes: output folders it owns, files the user named, one writer at a time.

Every command that writes goes through this module, so no user file is lost:

Folders (:func:`output_folder`)
    nlid writes only into folders it created, or that were empty: it marks
    them with :data:`MARKER`, a small JSON manifest of the entries (files
    and sub-folders) it wrote there. A folder that holds anything else is
    refused unless ``force=True``, and even then nlid never replaces an
    entry it did not write: each writer declares every entry it writes up
    front (:data:`STUDY_OUTPUTS`, :data:`POSTERIOR_OUTPUTS`,
    :data:`DISCOVERY_OUTPUTS`), and an existing one missing from the
    manifest stops it, naming the file, before anything is written (it is
    not written beside under another name: the report's links and the
    user's scripts expect the declared names). While a writer works, the
    folder is locked (``filelock``: ``flock`` on POSIX, ``msvcrt`` locking on
    Windows, released by the operating system even when the process is
    killed) on :data:`LOCK`; the writer names itself in :data:`WRITER`,
    which it removes when done. A second writer is refused at once, naming
    the process that holds the folder.

Files (:func:`check_new_file`)
    A file the user named (``simulate --out x.csv``) is replaced only with
    ``force=True``; its metadata sidecar (``x.csv.meta.json``) is replaced
    only if nlid wrote it (:func:`check_sidecar`).

Study folders written before the manifest existed are recognised by their
``runs/`` records and adopted, so interrupted studies still resume.
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Iterable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

from .errors import InputError

__all__ = [
    "MARKER",
    "LOCK",
    "WRITER",
    "STUDY_OUTPUTS",
    "POSTERIOR_OUTPUTS",
    "DISCOVERY_OUTPUTS",
    "RESPONSE_OUTPUTS",
    "output_folder",
    "check_new_file",
    "check_sidecar",
    "sidecar_path",
    "META_KEYS",
    "FolderBusyError",
]

#: The manifest nlid writes into every folder it owns.
MARKER = ".nlid-output.json"
#: The lock file of a folder (empty; locked while a writer works in the folder).
LOCK = ".nlid-lock"
#: Names the process writing into the folder (removed when it is done).
WRITER = ".nlid-writer"
#: Entries a study writes at the top of its folder (every one: tests/runtime/test_promises.py checks).
STUDY_OUTPUTS = (
    "study.toml",
    "runs",
    "arrays",
    "results.csv",
    "summary.md",
    "summary.txt",
    "summary.csv",
    "report.html",
    "figures",
)
#: Files :meth:`nlid.bayes.Posterior.save` writes.
POSTERIOR_OUTPUTS = (
    "posterior_table.csv",
    "posterior.json",
    "posterior_samples.npz",
    "posterior_corner.png",
    "posterior_trace.png",
    "posterior_damping.png",
)
#: Entries :func:`nlid.discovery.write_report` writes.
DISCOVERY_OUTPUTS = ("figures", "report.md", "report.html", "result.json", "models.csv")
#: Files :meth:`nlid.response.FrequencyResponse.save` writes.
RESPONSE_OUTPUTS = ("response.json", "response.csv", "response.md", "response.png", "measured.csv")
#: Metadata keys written to and read from the ``.meta.json`` sidecar of a data file (:mod:`nlid.io`).
META_KEYS = (
    "source",
    "force_hold",
    "mass",
    "g",
    "excitation",
    "preset",
    "seed",
    "noise",
    "reference",
    "truth",
    "periodic",
    "signal",
)

_OWN = (MARKER, LOCK, WRITER)


class FolderBusyError(InputError):
    """Another process is writing into the output folder."""


def _read_manifest(folder: Path) -> dict | None:
    path = folder / MARKER
    if not path.is_file():
        return None
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError, RecursionError):
        return None
    if not isinstance(data, dict) or not isinstance(data.get("entries"), list):
        return None
    return data


def _write_manifest(folder: Path, entries: Iterable[str]) -> None:
    data = {
        "written_by": "nlid",
        "note": "nlid owns the entries listed here and may replace them; it never touches anything else",
        "entries": sorted(set(entries)),
        "updated": time.strftime("%Y-%m-%dT%H:%M:%S"),
    }
    tmp = folder / f".{MARKER}.{os.getpid()}.tmp"
    tmp.write_text(json.dumps(data, indent=1) + "\n", encoding="utf-8")
    os.replace(tmp, folder / MARKER)


def _legacy_study(folder: Path) -> bool:
    """A study folder from before the manifest: ``runs/`` holds run records (``run_id`` and ``digest``)."""
    runs = folder / "runs"
    if not runs.is_dir():
        return False
    for path in sorted(runs.glob("*.json"))[:1]:
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError, RecursionError):
            return False
        return isinstance(data, dict) and "run_id" in data and "digest" in data
    return False


def _owned(folder: Path, outputs: Sequence[str], force: bool) -> set[str]:
    """What nlid owns in an existing ``folder`` if it may write ``outputs`` there; raises otherwise.

    Nothing is created or changed.
    """
    manifest = _read_manifest(folder)
    present = sorted(p.name for p in folder.iterdir() if p.name not in _OWN)
    owned: set[str] = set()
    if manifest is not None:
        owned = {str(e) for e in manifest["entries"]}
    elif set(outputs) == set(STUDY_OUTPUTS) and _legacy_study(folder):
        owned = set(present) & set(STUDY_OUTPUTS)
    elif present and not force:
        shown = ", ".join(present[:5]) + (f" and {len(present) - 5} more" if len(present) > 5 else "")
        raise InputError(
            f"the output folder {folder} holds files nlid did not write ({shown}); choose a new or empty "
            "folder, or give force=True to write beside them (nlid never replaces them)"
        )
    foreign = [name for name in outputs if (folder / name).exists() and name not in owned]
    if foreign:
        raise InputError(
            f"the output folder {folder} already holds {', '.join(foreign)}, which nlid did not write and would "
            "replace; move them away or choose another folder"
        )
    return owned


def _record(folder: Path, entries: set[str]) -> None:
    try:
        _write_manifest(folder, entries)
    except OSError as exc:
        raise InputError(f"cannot write into the output folder {folder}: {exc.strerror or exc}") from None


@contextmanager
def _lock(folder: Path) -> Iterator[None]:
    """Hold the folder's lock for the block, naming this process in :data:`WRITER`."""
    import socket

    from filelock import FileLock, Timeout

    lock = FileLock(str(folder / LOCK), timeout=0)
    try:
        lock.acquire()
    except Timeout:
        try:
            holder = (folder / WRITER).read_text(encoding="utf-8").strip()
        except (OSError, UnicodeDecodeError):
            holder = ""
        raise FolderBusyError(
            f"the output folder {folder} is being written by {holder or 'another process'}; wait for it to finish "
            "or choose another folder"
        ) from None
    except OSError as exc:
        raise InputError(f"cannot write into the output folder {folder}: {exc.strerror or exc}") from None
    writer = folder / WRITER
    try:
        try:
            writer.write_text(
                f"nlid process {os.getpid()} on {socket.gethostname()} since {time.strftime('%Y-%m-%d %H:%M:%S')}\n",
                encoding="utf-8",
            )
        except OSError as exc:
            raise InputError(f"cannot write into the output folder {folder}: {exc.strerror or exc}") from None
        yield
    finally:
        try:
            writer.unlink(missing_ok=True)
        except OSError:
            pass
        lock.release()


@contextmanager
def output_folder(folder: str | os.PathLike[str], outputs: Sequence[str], *, force: bool = False) -> Iterator[Path]:
    """Claim and lock an output folder for the block (see the module docstring).

    Parameters
    ----------
    folder
        Created (with its parents) if missing.
    outputs
        The top-level files and sub-folders the writer will create or replace.
    force
        Write into a folder that holds files nlid did not write. nlid never
        replaces them: if one has the name of an entry in ``outputs``, it
        stops before writing anything, naming it.

    Yields
    ------
    Path
        The folder.

    Raises
    ------
    InputError
        The folder holds files nlid did not write (without ``force``), one
        of ``outputs`` exists and was not written by nlid, or the folder
        cannot be created or written.
    FolderBusyError
        Another process is writing into it.
    """
    path = Path(folder)
    if path.exists() and not path.is_dir():
        raise InputError(f"the output folder {path} exists and is not a folder")
    if path.exists():
        _owned(path, outputs, force)  # refuse before creating anything in a folder that is not ours
    else:
        try:
            path.mkdir(parents=True)
        except FileExistsError:
            pass  # created meanwhile by another writer: checked under the lock below
        except OSError as exc:
            raise InputError(f"cannot create the output folder {path}: {exc.strerror or exc}") from None
        else:
            _record(path, set(outputs))
    with _lock(path):
        _record(path, _owned(path, outputs, force) | set(outputs))
        yield path


def check_new_file(path: str | os.PathLike[str], *, force: bool = False) -> Path:
    """Check that a file the user named may be written (replaced only with ``force=True``).

    Raises
    ------
    InputError
        The path is a folder, its folder does not exist, or the file exists
        and ``force`` is not given.
    """
    path = Path(path)
    if path.is_dir():
        raise InputError(f"{path} is a folder; give a file name")
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise InputError(f"cannot write {path}: the folder {parent} does not exist")
    if path.exists() and not force:
        raise InputError(f"{path} already exists; give force=True to replace it")
    check_sidecar(path)
    return path


def sidecar_path(path: str | os.PathLike[str]) -> Path:
    """``<file>.meta.json`` beside a data file."""
    path = Path(path)
    return path.with_name(path.name + ".meta.json")


def check_sidecar(path: str | os.PathLike[str]) -> None:
    """Refuse to replace a metadata sidecar ``<file>.meta.json`` that nlid did not write.

    A sidecar is nlid's when it is a JSON object whose keys are all keys
    nlid writes (:data:`META_KEYS`).
    """
    side = sidecar_path(path)
    if not side.exists():
        return
    try:
        data = json.loads(side.read_text(encoding="utf-8"))
    except (OSError, ValueError, RecursionError):
        data = None
    if not (isinstance(data, dict) and set(data) <= set(META_KEYS)):
        raise InputError(f"{side} exists and was not written by nlid; move it away before writing {Path(path).name}")
