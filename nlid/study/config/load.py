"""Loading a study: the file read (:func:`load_study`) and what it names checked on the disk (:func:`resolve_study`)."""

from __future__ import annotations

import os
from dataclasses import replace
from pathlib import Path

from ...contract.registry import Registry
from ...data.io import TEXT_LIMIT, check_path
from ...errors import InputError, NlidError
from ..values import BenchmarkSource, ConfigError, FileSource, KnownMass, PresetSource, Where
from .builtin import resolve_study_path
from .parse import parse_study
from .schema import StudyConfig

__all__ = ["load_study", "resolve_study", "TRIAL_SECONDS"]

#: Seconds of a preset simulated by :func:`resolve_study` to check that the overrides give a stable model.
TRIAL_SECONDS = 1.0


def load_study(name_or_path: str | os.PathLike[str], *, registry: Registry | None = None) -> StudyConfig:
    """Read, validate and resolve a study (built-in name or TOML path).

    Parameters
    ----------
    name_or_path
        A built-in study name (``nlid study list``) or a ``.toml`` file.
    registry
        Where identifiers are looked up; default: the installed plugins.

    Raises
    ------
    ConfigError
        For anything invalid, naming the file and key.
    """
    path = resolve_study_path(name_or_path)
    check_path(path, what="study file", max_bytes=TEXT_LIMIT)  # a pipe or a device is refused, not read forever
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise InputError(f"cannot read study file {path}: {exc.strerror}") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ConfigError(str(path), "", f"not UTF-8 text (byte {exc.start}): a TOML file must be UTF-8") from None
    config = parse_study(text, source=str(path), base_dir=path.parent, default_name=path.stem, registry=registry)
    return resolve_study(config)


def resolve_study(config: StudyConfig) -> StudyConfig:
    """Check what a parsed study names: files read, benchmarks load, "known" masses are known, overrides simulate.

    This is the only step of loading a study that touches the disk; it
    returns the config marked ``resolved``.

    Raises
    ------
    ConfigError
        Naming the file and key of the first dataset that cannot be read.
    """
    for i, ds in enumerate(config.datasets):
        where = Where(config.source, f"datasets[{i}]")
        src = ds.source
        if isinstance(src, BenchmarkSource):
            loaded = None
            for key, part in (("part", src.part), ("holdout", getattr(ds.holdout, "part", None))):
                if part is None:
                    continue
                try:
                    record = src.load(part)
                except NlidError as exc:
                    raise (where / key).error(str(exc)) from None
                if key == "part":
                    loaded = record
            known = bool(loaded is not None and (loaded.mass or (loaded.meta.get("reference") or {}).get("mass")))
            if isinstance(ds.mass, KnownMass) and not known and not (ds.reference and "mass" in ds.reference):
                raise (where / "mass").error('the mass is not known for this data: give it in kg or "estimate"')
        elif isinstance(src, PresetSource) and src.overrides:
            # a shipped preset as it is needs no trial (it is simulated by the tests); overrides may be absurd
            _trial_simulation(where, src)
        elif isinstance(src, FileSource):
            if not Path(src.path).is_file():
                raise (where / "file").error(f"file {src.path} not found")
            try:
                src.load()
            except NlidError as exc:
                raise (where / "file").error(str(exc)) from None
    return replace(config, resolved=True)


def _trial_simulation(where: Where, source: PresetSource) -> None:
    """Simulate the first :data:`TRIAL_SECONDS` of a preset dataset: absurd overrides diverge at once."""
    preset = source.preset()
    duration = min(preset.duration, max(TRIAL_SECONDS, 64.0 / preset.fs))
    try:
        preset.with_overrides(duration=duration).simulate(0, channels=source.channels)
    except NlidError as exc:
        key = "overrides" if source.overrides else "preset"
        raise (where / key).error(f"the first {duration:g} s of the simulation fail: {exc}") from None
