"""Typed values of a study configuration, each parsed once from TOML at the boundary.

A setting that can be "known", "estimate" or a number of kg is three small
types, not a string compared everywhere; where the data come from (a preset,
a bundled benchmark, a file) and what is held out are typed the same way.
Each type parses its own TOML value (``from_toml``), raising
:class:`ConfigError` naming the file and the key, and writes back the plain
value it came from (``to_toml``), which is what run specs carry in JSON and
what their digests are computed from.

Nothing here touches the disk: checking that files exist and benchmark parts
load is the resolve step of :func:`nlid.study.config.resolve_study`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Union

from .._frozen import FrozenDict
from ..errors import InputError, brief

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
        """``value`` checked by a rule of :mod:`nlid.validate`, whose complaint becomes a :class:`ConfigError` here."""
        why = rule.reason(value)
        if why is not None:
            raise self.error(why)
        return rule.check(value, self.key)

    def string(self, value: Any) -> str:
        """A string, else a :class:`ConfigError` here."""
        if not isinstance(value, str):
            raise self.error(f"expected a string, got {brief(value)}")
        return value


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


Mass = Union[KnownMass, EstimatedMass, GivenMass]


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


Holdout = Union[NoHoldout, IndependentHoldout, FractionHoldout, PartHoldout]


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
@dataclass(frozen=True)
class PresetSource:
    """Records simulated from a preset (:mod:`nlid.presets`).

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

    def __post_init__(self) -> None:
        object.__setattr__(self, "overrides", FrozenDict(self.overrides))
        if isinstance(self.noise, Mapping):
            object.__setattr__(self, "noise", FrozenDict(self.noise))

    def preset(self):
        """The :class:`~nlid.presets.Preset` with the overrides applied."""
        from ..presets import get_preset

        preset = get_preset(self.name)
        overrides = dict(self.overrides)
        if isinstance(overrides.get("band"), list):
            overrides["band"] = tuple(overrides["band"])
        return preset.with_overrides(**overrides) if overrides else preset


@dataclass(frozen=True)
class BenchmarkSource:
    """A bundled measured benchmark (:mod:`nlid.datasets`) and the part of it used."""

    name: str
    part: str = "all"

    kind = "dataset"

    def load(self, part: str | None = None):
        """The record of ``part`` (default: this source's part)."""
        from .. import datasets

        return datasets.load(self.name, part=self.part if part is None else part)


@dataclass(frozen=True)
class FileSource:
    """A data file read with a column map (:func:`nlid.io.read_record`)."""

    path: str
    columns: str | None = None
    fs: float | None = None

    kind = "file"

    def load(self):
        """The record of the file."""
        from ..io import read_record

        return read_record(self.path, self.columns, fs=self.fs)


DataSource = Union[PresetSource, BenchmarkSource, FileSource]
