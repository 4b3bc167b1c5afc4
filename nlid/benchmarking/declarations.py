"""What a benchmark declares: the frozen dataclasses a benchmark file is read into.

:func:`nlid.benchmarking.protocol.parse_protocol` reads a benchmark file (its layout is in the
docstring of :mod:`nlid.benchmarking.protocol`) into a :class:`Protocol`: the estimation
:class:`Part`, the :class:`TestSet` objects (with their :class:`UserFile` and :class:`NoiseFloor`),
the :class:`PipelineSettings` (and the pysindy :class:`PeerSettings`), and the :class:`Published`
and :class:`NotComparable` figures. They hold data only; every check is made while reading.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from ..base.validate import did_you_mean
from ..errors import InputError

__all__ = [
    "Protocol",
    "Truth",
    "Part",
    "TestSet",
    "UserFile",
    "NoiseFloor",
    "PipelineSettings",
    "PeerSettings",
    "Published",
    "NotComparable",
    "STATUSES",
    "UNITS",
]

#: How a published figure was verified; only these reach a leaderboard.
STATUSES = ("verified", "verified-secondary")
#: Units a figure may be given in, as a factor to the SI unit of the record (m or V); "dB" is 20 log10(x / 1 unit).
UNITS = {"m": 1.0, "mm": 1e-3, "um": 1e-6, "V": 1.0, "mV": 1e-3, "dB": math.nan}


@dataclass(frozen=True)
class Part:
    """Where a record of the benchmark comes from.

    Attributes
    ----------
    part
        The :func:`nlid.data.datasets.load` part (``None`` for a user-supplied file).
    range
        ``(start, stop)`` sample indices into that part, or ``None`` for all of it.
    package
        Where the ``nonlinear-benchmarks`` package has it: ``"train"``, ``"test"``,
        ``"test:K"`` (K-th test set) or ``"all:K"`` (K-th record of an unsplit benchmark);
        ``None``: the package does not have it.
    samples
        The expected number of samples (checked), or ``None``.
    description
        What it is, in words.
    """

    part: str | None
    range: tuple[int, int] | None = None
    package: str | None = None
    samples: int | None = None
    description: str = ""


@dataclass(frozen=True)
class UserFile:
    """A test set the user supplies (``--test-file BENCHMARK:TEST=PATH``): it is not in ``$NLID_DATA_DIR``.

    Attributes
    ----------
    names
        The benchmark's own file names (e.g. ``uval_multisine.mat``, ``yval_multisine.mat``):
        given one of them, or their folder, nlid reads them all with :attr:`columns`.
    columns
        The column map (:mod:`nlid.data.columnmap`) of the benchmark's files. Any other file is
        read with nlid's default columns (``t, f, z``).
    hint
        Where to get it.
    """

    names: tuple[str, ...]
    columns: str
    hint: str = ""


@dataclass(frozen=True)
class NoiseFloor:
    """The output noise of a periodic record, estimated from the estimation part's periods.

    ``sigma = sqrt(mean over pairs (i, j) of mean((y_i - y_j)^2) / 2)`` over the periods listed
    (1-based, of the estimation part): the RMSE a perfect model reaches on a held-out period.
    """

    period: int
    periods: tuple[int, ...]


@dataclass(frozen=True)
class TestSet:
    """One test set of a benchmark and how it is scored.

    Attributes
    ----------
    name
        Short name (``arrow-full``).
    source
        The dataset part, or ``None`` when it is a :attr:`file`.
    file
        The user-supplied file it is read from, or ``None``.
    rule
        The transient rule (:func:`nlid.scoring.rule_from_spec` spelling).
    rule_note
        Why this rule (the benchmark's convention), in words.
    noise_floor
        The noise floor to show beside it, or ``None``.
    """

    name: str
    source: Part
    rule: str
    file: UserFile | None = None
    rule_note: str = ""
    noise_floor: NoiseFloor | None = None

    @property
    def local(self) -> bool:
        """True when the test set is in ``$NLID_DATA_DIR`` (not a user-supplied file)."""
        return self.file is None


@dataclass(frozen=True)
class PeerSettings:
    """The pysindy peer's settings on this benchmark (:mod:`nlid.benchmarking.peer`).

    Attributes
    ----------
    degree
        Degree of the polynomial library in ``(z, v)``.
    friction
        Whether ``sign(v)`` is in the library.
    thresholds
        The STLSQ thresholds tried, as fractions of the largest coefficient of the
        column-normalised least-squares fit (pysindy's ``normalize_columns=True``): the
        threshold pysindy is given is this fraction times that coefficient, so one grid
        means the same on a record in volts and one in metres.
    """

    degree: int = 3
    friction: bool = True
    thresholds: tuple[float, ...] = (0.0, 1e-4, 1e-3, 1e-2)


@dataclass(frozen=True)
class PipelineSettings:
    """What the pipelines are given on a benchmark.

    Attributes
    ----------
    terms, without
        The model an identifier run by name fits (as :func:`nlid.identify` takes them).
    declared
        The complete model ``discover`` starts from.
    mass
        ``None``: estimated; else the known mass in kg.
    holdout
        Fraction of the estimation part (its end) that ``discover`` holds out for its decisions.
    options
        Identifier options by identifier name.
    note
        What knowledge the settings carry (e.g. "the benchmark's model form given").
    peer
        The pysindy peer's settings.
    rule
        The transient rule of ``discover``'s cross-fitted prediction check on blocks of the estimation part
        (``[pipelines] rule``; default: the test sets' window rule when they share one, else each block's own).
    """

    terms: str
    without: str
    declared: str
    mass: float | None
    holdout: float
    options: Mapping[str, Mapping[str, Any]]
    note: str
    peer: PeerSettings
    rule: str | None = None


@dataclass(frozen=True)
class Published:
    """A published figure on one test set (only verified ones are accepted).

    Attributes
    ----------
    test
        The test set's name.
    method, paper, year
        Who and where.
    value, unit
        The figure as published (``unit`` in :data:`UNITS`).
    rmse
        The figure as an RMSE in the record's unit (``value`` converted).
    fit_percent, parameters
        Published fit % and parameter count, when published.
    rule
        The transient rule it was scored with, in words.
    same_rule
        Whether that is the test set's declared rule.
    source, status
        Where it was verified, and how (:data:`STATUSES`).
    note
        Anything that limits the comparison.
    structure
        What the published model knew (:data:`nlid.benchmarking.prior.STRUCTURES`; ``"black box"``
        unless the file says otherwise).
    """

    test: str
    method: str
    paper: str
    year: int
    value: float
    unit: str
    rmse: float
    rule: str
    same_rule: bool
    source: str
    status: str
    fit_percent: float | None = None
    parameters: int | None = None
    note: str = ""
    structure: str = "black box"


@dataclass(frozen=True)
class NotComparable:
    """A published figure deliberately left out of the leaderboard, and why."""

    what: str
    why: str


@dataclass(frozen=True)
class Truth:
    """The system that generated a simulated benchmark's data, declared in its file (``[truth]``).

    Attributes
    ----------
    coefficients
        ``{term: value}``: the coefficients of the terms of ``R = f - m z''`` (SI units).
    mass
        The mass (kg).
    source
        Where the system is published.
    """

    coefficients: Mapping[str, float]
    mass: float
    source: str

    def as_mapping(self) -> dict[str, Any]:
        """``{"coefficients", "mass"}``, as :func:`nlid.identified.reference.true_model` reads it."""
        return {"coefficients": dict(self.coefficients), "mass": self.mass}


@dataclass(frozen=True)
class Protocol:
    """One benchmark's protocol (see the module docstring).

    Attributes
    ----------
    name, title, citation
        What it is.
    dataset
        The :mod:`nlid.data.datasets` name (files and checksums).
    official
        True when the split is the benchmark's own; false for an nlid-internal split.
    protocol
        Whose protocol this is, in words.
    unit, scale
        Reported unit, and the factor from the record's unit of ``z`` to it.
    fs
        Sampling frequency (Hz).
    remove_means
        Subtract the estimation part's means of ``f`` and ``z`` from every part.
    force_hold
        ``"sampled"`` or ``"zoh"`` for records read from files or the package.
    package_function, force_scale, output_scale
        The ``nonlinear-benchmarks`` function and the factors from its ``u``, ``y`` to ``f``, ``z``.
    estimation
        The estimation part.
    estimation_file
        The user-supplied file it is read from (``files={"NAME:estimation": PATH}``), or ``None``.
    tests
        The test sets.
    pipelines
        What the pipelines are given.
    published, not_comparable
        Published figures shown, and those left out with the reason.
    text
        The TOML text it was read from.
    truth
        The system that generated the data, when the benchmark is simulated and declares it (``[truth]``).
    """

    name: str
    title: str
    citation: str
    dataset: str
    official: bool
    protocol: str
    unit: str
    scale: float
    fs: float
    remove_means: bool
    force_hold: str
    package_function: str | None
    force_scale: float
    output_scale: float
    estimation: Part
    estimation_file: UserFile | None
    tests: tuple[TestSet, ...]
    pipelines: PipelineSettings
    published: tuple[Published, ...]
    not_comparable: tuple[NotComparable, ...]
    text: str
    truth: Truth | None = None

    @property
    def mass_unit(self) -> str:
        """The unit of the mass: kg for a displacement in m (and N of force), else s^2 (force and output in V)."""
        return "kg" if self.unit in ("m", "mm", "um") else "s^2"

    def test(self, name: str) -> TestSet:
        """The test set called ``name``."""
        for t in self.tests:
            if t.name == name:
                return t
        names = [t.name for t in self.tests]
        raise InputError(
            f"benchmark {self.name!r} has no test set {name!r}{did_you_mean(name, names)}; "
            f"its test sets: {', '.join(names)}"
        )

    def published_on(self, test: str) -> list[Published]:
        """The published figures on one test set."""
        return [p for p in self.published if p.test == test]
