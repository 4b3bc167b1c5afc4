"""Typed values of a study configuration, each parsed once from TOML at the boundary.

A setting that can be "known", "estimate" or a number of kg is three small
types, not a string compared everywhere; where the data come from (a preset,
a bundled benchmark, a file) and what is held out are typed the same way.
Each type parses its own TOML value (:func:`parse_mass`,
:func:`parse_holdout`, the sources' ``from_toml``), raising
:class:`ConfigError` naming the file and the key, and writes back the plain
value it came from (``to_toml``: a value for the mass and the held-out data,
the dataset entry's keys for a source), so that a parsed study can be written
out again (:meth:`nlid.study.config.StudyConfig.to_toml`). A source also gives
its fields in the layout run specs carry in JSON (``to_spec``), which is what
their digests are computed from.

Nothing here touches the disk: checking that files exist and benchmark parts
load is the resolve step of :func:`nlid.study.config.resolve_study`.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..base.frozen import FrozenDict
from ..base.validate import NOISE_FRACTION, check_noise, did_you_mean
from ..errors import InputError, NlidError, brief

__all__ = [
    "ConfigError",
    "Where",
    "KnownMass",
    "EstimatedMass",
    "GivenMass",
    "Mass",
    "parse_mass",
    "NoHoldout",
    "IndependentHoldout",
    "FractionHoldout",
    "PartHoldout",
    "Holdout",
    "parse_holdout",
    "PresetSource",
    "BenchmarkSource",
    "FileSource",
    "DataSource",
    "source_from_spec",
    "SPEC_DEFAULTS",
    "SOURCES",
    "plain",
    "MAX_MASS",
    "MAX_TIMEOUT",
]

#: Largest mass (kg) a study may give.
MAX_MASS = 1e9
#: Longest time limit of a run (s): a week.
MAX_TIMEOUT = 7 * 24 * 3600.0


class ConfigError(InputError):
    """A study configuration is invalid.

    Parameters
    ----------
    source
        The file (or ``"<string>"``).
    key
        Dotted key, e.g. ``datasets[2].terms``.
    message
        What is wrong (with a suggestion where one exists).
    """

    def __init__(self, source: str, key: str, message: str):
        self.source, self.key, self.reason = source, key, message
        where = f"{source}: {key}: " if key else f"{source}: "
        super().__init__(where + message)


@dataclass(frozen=True)
class Where:
    """Where a value sits in a configuration: the file and the dotted key."""

    source: str
    key: str

    def __truediv__(self, child: str) -> Where:
        sep = "" if not self.key or child.startswith("[") else "."
        return Where(self.source, f"{self.key}{sep}{child}")

    def error(self, message: str) -> ConfigError:
        """A :class:`ConfigError` at this place."""
        return ConfigError(self.source, self.key, message)

    def number(
        self,
        value: Any,
        *,
        minimum: float | None = None,
        maximum: float | None = None,
        integer: bool = False,
        positive: bool = False,
    ) -> Any:
        """A finite number (or integer) within bounds, else a :class:`ConfigError` here."""
        ok = isinstance(value, int) if integer else isinstance(value, (int, float))
        if isinstance(value, bool) or not ok:
            raise self.error(f"expected {'an integer' if integer else 'a number'}, got {brief(value)}")
        if not math.isfinite(value):
            raise self.error(f"expected a finite number, got {value!r}")
        if positive and not value > 0:
            raise self.error(f"must be positive, got {value!r}")
        if minimum is not None and value < minimum:
            raise self.error(f"must be >= {minimum:g}, got {value!r}")
        if maximum is not None and value > maximum:
            raise self.error(f"must be <= {maximum:g}, got {value!r}")
        return value

    def check(self, rule: Any, value: Any) -> Any:
        """``value`` checked by a rule of :mod:`nlid.base.validate`, whose complaint becomes a :class:`ConfigError`
        here."""
        why = rule.reason(value)
        if why is not None:
            raise self.error(why)
        return rule.check(value, self.key)

    def string(self, value: Any) -> str:
        """A string, else a :class:`ConfigError` here."""
        if not isinstance(value, str):
            raise self.error(f"expected a string, got {brief(value)}")
        return value

    def table(self, value: Any) -> dict[str, Any]:
        """A table (as a new dict), else a :class:`ConfigError` here."""
        if not isinstance(value, Mapping):
            raise self.error(f"expected a table, got {type(value).__name__} {brief(value)}")
        return dict(value)

    def unknown(self, name: str, known: Iterable[str], what: str = "key") -> ConfigError:
        """The error for an unknown ``name`` here: a suggestion and the known names."""
        known = list(known)
        return self.error(f"unknown {what} {name!r}{did_you_mean(name, known)}; known: {', '.join(known)}")

    def keys(self, table: Mapping[str, Any], known: Iterable[str]) -> None:
        """Every key of ``table`` (which sits here) is one of ``known``."""
        known = tuple(known)
        for key in table:
            if key not in known:
                raise (self / key).unknown(key, known)

    def finite(self, value: Any) -> None:
        """Every number inside ``value`` (tables and arrays too) is finite."""
        if isinstance(value, Mapping):
            for k, v in value.items():
                (self / str(k)).finite(v)
        elif isinstance(value, list):
            for i, v in enumerate(value):
                (self / f"[{i}]").finite(v)
        elif isinstance(value, float) and not math.isfinite(value):
            raise self.error(f"expected a finite number, got {brief(value)}")


# --------------------------------------------------------------------------- the mass
@dataclass(frozen=True)
class KnownMass:
    """The mass is known: the preset's truth or the dataset's reference (TOML ``"known"``)."""

    def value(self, reference: float | None, record: float | None) -> float | None:
        """The mass to give the identifier."""
        return reference if reference is not None else record

    def to_toml(self) -> str:
        """The TOML value."""
        return "known"


@dataclass(frozen=True)
class EstimatedMass:
    """The identifier estimates the mass (TOML ``"estimate"``)."""

    def value(self, reference: float | None, record: float | None) -> float | None:
        """``None``: no mass is given."""
        return None

    def to_toml(self) -> str:
        """The TOML value."""
        return "estimate"


@dataclass(frozen=True)
class GivenMass:
    """A mass in kg given by the study (TOML: a number)."""

    kg: float

    def value(self, reference: float | None, record: float | None) -> float | None:
        """The given mass."""
        return self.kg

    def to_toml(self) -> float:
        """The TOML value."""
        return self.kg


Mass = KnownMass | EstimatedMass | GivenMass


def parse_mass(value: Any, where: Where) -> Mass:
    """``"known"``, ``"estimate"`` or a positive number of kg."""
    if isinstance(value, str):
        if value == "known":
            return KnownMass()
        if value == "estimate":
            return EstimatedMass()
        raise where.error(f'expected "known", "estimate" or a number in kg, got {value!r}')
    return GivenMass(float(where.number(value, positive=True, maximum=MAX_MASS)))


# --------------------------------------------------------------------------- held-out data
@dataclass(frozen=True)
class NoHoldout:
    """No held-out data (TOML ``"none"``)."""

    def to_toml(self) -> str:
        """The TOML value."""
        return "none"


@dataclass(frozen=True)
class IndependentHoldout:
    """Another record simulated with its own seed (presets only; TOML ``"independent"``)."""

    def to_toml(self) -> str:
        """The TOML value."""
        return "independent"


@dataclass(frozen=True)
class FractionHoldout:
    """The last ``fraction`` of the record (TOML: a number between 0 and 1)."""

    fraction: float

    def to_toml(self) -> float:
        """The TOML value."""
        return self.fraction


@dataclass(frozen=True)
class PartHoldout:
    """A named part of a bundled benchmark, e.g. Silverbox's ``"arrow"`` (TOML: the part's name)."""

    part: str

    def to_toml(self) -> str:
        """The TOML value."""
        return self.part


Holdout = NoHoldout | IndependentHoldout | FractionHoldout | PartHoldout


def parse_holdout(value: Any, kind: str, where: Where) -> Holdout:
    """The held-out data of a dataset of ``kind`` (``"preset"``, ``"dataset"``, ``"file"``)."""
    if isinstance(value, str):
        if value == "none":
            return NoHoldout()
        if value == "independent":
            if kind != "preset":
                raise where.error('"independent" needs a preset (a second simulated record)')
            return IndependentHoldout()
        if kind != "dataset":
            raise where.error(f'expected "independent", "none" or a fraction such as 0.25; got {value!r}')
        return PartHoldout(value)
    fraction = float(where.number(value))
    if not 0 < fraction < 1:
        raise where.error(f"a held-out fraction must be between 0 and 1, got {fraction}")
    return FractionHoldout(fraction)


# --------------------------------------------------------------------------- where the data come from
#: The run-spec fields of a source, and their values for a source that has no such field.
SPEC_DEFAULTS: Mapping[str, Any] = FrozenDict(
    {"part": "all", "columns": None, "fs": None, "overrides": FrozenDict(), "noise": 0.0, "channels": ("z",)}
)


def plain(value: Any) -> Any:
    """``value`` with its frozen tables as dicts and its tuples as lists (as TOML and JSON hold them)."""
    if isinstance(value, Mapping):
        return {k: plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    return value


@dataclass(frozen=True)
class PresetSource:
    """Records simulated from a preset (:mod:`nlid.simulation.presets`).

    Attributes
    ----------
    name
        The preset.
    overrides
        Preset fields and coefficients changed.
    noise
        Noise level per channel (fraction of its standard deviation), or one level.
    channels
        Response channels recorded (``z`` first).
    """

    name: str
    overrides: Mapping[str, Any] = field(default_factory=FrozenDict)
    noise: Mapping[str, float] | float = 0.0
    channels: tuple[str, ...] = ("z",)

    kind = "preset"
    #: The keys of a dataset entry that belong to this kind of source.
    keys = ("preset", "overrides", "noise", "channels")

    def __post_init__(self) -> None:
        object.__setattr__(self, "overrides", FrozenDict(self.overrides))
        if isinstance(self.noise, Mapping):
            object.__setattr__(self, "noise", FrozenDict(self.noise))

    @classmethod
    def from_toml(cls, entry: Mapping[str, Any], where: Where, base: str | os.PathLike[str] = ".") -> PresetSource:
        """The source of a dataset entry ``preset = "..."``: the preset exists, its overrides build a model.

        Also checks the noise levels (:data:`nlid.base.validate.NOISE_FRACTION`, each on a recorded channel) and
        the channels (``z`` is always recorded). ``entry`` is the dataset's table, ``where`` its place in the
        file; ``base`` (the study file's folder) is for file sources only.
        """
        from ..simulation.presets import RESPONSE_CHANNELS, get_preset

        value = (where / "preset").string(entry["preset"])
        overrides = (where / "overrides").table(entry.get("overrides", {}))
        (where / "overrides").finite(overrides)
        try:
            preset = get_preset(value)
            over = dict(overrides)
            if isinstance(over.get("band"), list):
                over["band"] = tuple(over["band"])
            preset = preset.with_overrides(**over) if over else preset
            preset.model()
        except NlidError as exc:
            raise (where / ("overrides" if overrides else "preset")).error(str(exc)) from None
        except (TypeError, ValueError) as exc:
            raise (where / "overrides").error(f"invalid preset override: {exc}") from None
        noise: dict[str, float] | float = 0.0
        if "noise" in entry:
            raw_noise = entry["noise"]
            if isinstance(raw_noise, Mapping):
                noise = {}
                for ch, x in raw_noise.items():
                    if ch not in RESPONSE_CHANNELS:
                        raise (where / f"noise.{ch}").unknown(ch, RESPONSE_CHANNELS, "channel")
                    noise[ch] = (where / f"noise.{ch}").check(NOISE_FRACTION, x)
            else:
                noise = (where / "noise").check(NOISE_FRACTION, raw_noise)
        channels_raw = entry.get("channels", list(noise) if isinstance(noise, dict) else ["z"])
        if isinstance(channels_raw, list):  # a structure's z1..zn name z
            try:
                channels_raw = list(preset.response_groups(channels_raw))
            except NlidError as exc:
                raise (where / "channels").error(str(exc)) from None
        if not isinstance(channels_raw, list) or not all(c in RESPONSE_CHANNELS for c in channels_raw):
            raise (where / "channels").error(f"expected a list of z, v, a; got {brief(channels_raw)}")
        channels = tuple(dict.fromkeys(["z", *channels_raw]))
        try:
            check_noise(noise, channels)  # each channel given a level is recorded
        except InputError as exc:
            raise (where / "noise").error(str(exc)) from None
        return cls(value, overrides, noise, channels)

    def to_toml(self) -> dict[str, Any]:
        """The dataset entry's keys this source was read from (``overrides`` only when there are some)."""
        out: dict[str, Any] = {"preset": self.name}
        if self.overrides:
            out["overrides"] = plain(self.overrides)
        out["noise"] = plain(self.noise)
        out["channels"] = list(self.channels)
        return out

    def to_spec(self) -> dict[str, Any]:
        """The run-spec fields (the others are :data:`SPEC_DEFAULTS`)."""
        noise = dict(self.noise) if isinstance(self.noise, Mapping) else self.noise
        return {"kind": self.kind, "source": self.name, "overrides": dict(self.overrides), "noise": noise,
                "channels": list(self.channels)}  # fmt: skip

    @property
    def default_terms(self) -> str:
        """The preset's terms (a dataset's terms when it gives none; a structure preset's elements)."""
        return self.preset().terms

    def preset(self):
        """The :class:`~nlid.simulation.presets.Preset` with the overrides applied."""
        from ..simulation.presets import get_preset

        preset = get_preset(self.name)
        overrides = dict(self.overrides)
        if isinstance(overrides.get("band"), list):
            overrides["band"] = tuple(overrides["band"])
        return preset.with_overrides(**overrides) if overrides else preset


@dataclass(frozen=True)
class BenchmarkSource:
    """A bundled measured benchmark (:mod:`nlid.data.datasets`) and the part of it used."""

    name: str
    part: str = "all"

    kind = "dataset"
    keys = ("dataset", "part")

    @classmethod
    def from_toml(cls, entry: Mapping[str, Any], where: Where, base: str | os.PathLike[str] = ".") -> BenchmarkSource:
        """The source of a dataset entry ``dataset = "..."`` (a benchmark :mod:`nlid.data.datasets` knows)."""
        from ..data import datasets

        value = (where / "dataset").string(entry["dataset"])
        if value not in datasets.DATASETS:
            raise (where / "dataset").unknown(value, datasets.DATASETS, "dataset")
        return cls(value, (where / "part").string(entry.get("part", "all")))

    def to_toml(self) -> dict[str, Any]:
        """The dataset entry's keys this source was read from."""
        return {"dataset": self.name, "part": self.part}

    def to_spec(self) -> dict[str, Any]:
        """The run-spec fields (the others are :data:`SPEC_DEFAULTS`)."""
        return {"kind": self.kind, "source": self.name, "part": self.part}

    @property
    def default_terms(self) -> str:
        """No terms besides the defaults."""
        return ""

    def load(self, part: str | None = None):
        """The record of ``part`` (default: this source's part)."""
        from ..data import datasets

        return datasets.load(self.name, part=self.part if part is None else part)


@dataclass(frozen=True)
class FileSource:
    """A data file read with a column map (:func:`nlid.data.io.read_record`).

    Attributes
    ----------
    path
        Absolute, normalised path (a relative path in the study file is relative to the file's folder).
    """

    path: str
    columns: str | None = None
    fs: float | None = None

    kind = "file"
    keys = ("file", "columns", "fs")

    @classmethod
    def from_toml(cls, entry: Mapping[str, Any], where: Where, base: str | os.PathLike[str] = ".") -> FileSource:
        """The source of a dataset entry ``file = "..."``: ``~`` and environment variables expanded.

        A relative path is relative to ``base`` (the study file's folder). The file is not read here (the
        resolve step reads it); the column map is checked.
        """
        from ..data.columnmap import parse_columns

        value = (where / "file").string(entry["file"])
        expanded = os.path.expandvars(os.path.expanduser(value))
        if "$" in expanded:
            raise (where / "file").error(f"{value!r}: an environment variable in it is not set")
        path = Path(expanded)
        path = path if path.is_absolute() else (Path(base) / path)
        fs = None
        if "fs" in entry:
            fs = float((where / "fs").number(entry["fs"], positive=True, maximum=1e9))
        columns = None if "columns" not in entry else (where / "columns").string(entry["columns"])
        try:
            parse_columns(columns)
        except NlidError as exc:
            raise (where / "columns").error(str(exc)) from None
        return cls(os.path.normpath(os.path.abspath(path)), columns, fs)

    def to_toml(self) -> dict[str, Any]:
        """The dataset entry's keys (the absolute path; ``columns`` and ``fs`` when given)."""
        out: dict[str, Any] = {"file": self.path}
        if self.columns is not None:
            out["columns"] = self.columns
        if self.fs is not None:
            out["fs"] = self.fs
        return out

    def to_spec(self) -> dict[str, Any]:
        """The run-spec fields (the others are :data:`SPEC_DEFAULTS`)."""
        return {"kind": self.kind, "source": self.path, "columns": self.columns, "fs": self.fs}

    @property
    def default_terms(self) -> str:
        """No terms besides the defaults."""
        return ""

    def load(self):
        """The record of the file."""
        from ..data.io import read_record

        return read_record(self.path, self.columns, fs=self.fs)


DataSource = PresetSource | BenchmarkSource | FileSource
#: The kinds of source, by their dataset-entry key (and run-spec ``kind``).
SOURCES: Mapping[str, type] = FrozenDict({"preset": PresetSource, "dataset": BenchmarkSource, "file": FileSource})


def source_from_spec(data: Mapping[str, Any], where: Where) -> DataSource:
    """The source of a run spec's dataset (inverse of the sources' ``to_spec``)."""
    kind = data["kind"]
    if kind == "preset":
        return PresetSource(
            data["source"], data.get("overrides") or {}, data.get("noise", 0.0), tuple(data.get("channels") or ("z",))
        )
    if kind == "dataset":
        return BenchmarkSource(data["source"], data.get("part", "all"))
    if kind == "file":
        return FileSource(data["source"], data.get("columns"), data.get("fs"))
    raise where.error(f"unknown dataset kind {kind!r}")
