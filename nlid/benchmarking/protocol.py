"""Benchmarks declared as data: the protocol of each measured benchmark, read from a TOML file.

A benchmark file (the built-in ones are ``nlid/benchmarking/protocols/*.toml``, shipped as package data)
says, for one benchmark:

``[benchmark]``
    its name, title, citation, the :mod:`nlid.data.datasets` name whose files (and SHA-256
    checksums, ``nlid data``) hold it, whether the split is the benchmark's own (``official``)
    or nlid's, the figure of merit (``metric = "rmse"`` of the displacement channel, reported
    in ``unit`` = the record's unit times ``scale``), the sampling frequency, whether the means
    of the estimation part are removed from every part, and ``[benchmark.package]``: where the
    optional ``nonlinear-benchmarks`` package has it.
``[estimation]``
    the estimation part: a part of the dataset (:func:`nlid.data.datasets.load`), optionally a
    ``range = [start, stop]`` of it, and where the package has it (``package = "train"``); or,
    for a benchmark of your own, an ``[estimation.file]`` the user supplies (like a test set's).
``[[tests]]``
    each test set: a dataset part (and range), or a ``[tests.file]`` the user supplies (not in
    ``$NLID_DATA_DIR``), its transient rule (``rule = "window:50"``, ``"periodic:8192"``,
    ``"first-sample"``: the spelling of :func:`nlid.scoring.rule_from_spec`), and optionally a
    ``[tests.noise_floor]``: the output noise estimated from the periods of the estimation part.
``[pipelines]``
    what the pipelines are given on this benchmark: the model an identifier run by name fits
    (``terms``, ``without``), the model ``discover`` starts from (``declared``), the mass
    (``"estimate"`` or kg), the hold-out fraction of the estimation part for structure
    selection, and the pysindy peer's library.
``[[published]]``
    published figures on a test set, each with its method, paper, year, value and unit, the
    transient rule it was scored with, whether that is the declared rule (``same_rule``), its
    source and how it was verified (``status``: ``"verified"`` or ``"verified-secondary"``;
    nothing else is accepted, so no unverified figure reaches a leaderboard).
``[[not_comparable]]``
    published figures that are *not* shown, and why (another test set, in-sample, no source).
``[truth]`` (optional)
    for a simulated benchmark, the system that generated its data: ``coefficients`` (a table
    ``{term = value}`` of the terms of ``R = f - m z''``), ``mass`` (kg) and ``source``; the bench
    scores it on every test set beside the fitted models (:mod:`nlid.benchmarking.truth`).

:func:`load_protocol` reads a file or a built-in name; :func:`builtin_benchmarks` lists the
built-in ones. What they return is a frozen dataclass (:mod:`nlid.benchmarking.declarations`, whose
names this module re-exports): a protocol crosses process boundaries as its TOML text
(:attr:`Protocol.text`).
"""

from __future__ import annotations

import math
import re
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ..base.validate import did_you_mean
from ..data.io import TEXT_LIMIT, check_path, read_text_file
from ..data.names import canonical_name
from ..errors import DataError, InputError, brief
from .declarations import (
    STATUSES,
    UNITS,
    NoiseFloor,
    NotComparable,
    Part,
    PeerSettings,
    PipelineSettings,
    Protocol,
    Published,
    TestSet,
    Truth,
    UserFile,
)

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - exercised on 3.10 only
    import tomli as tomllib

__all__ = [
    "load_protocol",
    "parse_protocol",
    "builtin_benchmarks",
    "PACKAGE_FUNCTIONS",
]

_RULE = re.compile(r"^(first-sample|window:[1-9][0-9]*|periodic(:[1-9][0-9]*)?)$")
_PACKAGE_PART = re.compile(r"^(train|test|test:[0-9]+|all:[0-9]+)$")
_NAME = re.compile(r"^[a-z0-9][a-z0-9_.+-]*$")
#: The loader functions of the ``nonlinear-benchmarks`` package a benchmark file may name (``[benchmark.package]
#: function``): a benchmark declared as data names one of them, never other code of the package.
PACKAGE_FUNCTIONS = frozenset(
    (
        "EMPS",
        "CED",
        "Cascaded_Tanks",
        "Silverbox",
        "WienerHammerBenchMark",
        "not_splitted_benchmarks.BoucWen",
        "not_splitted_benchmarks.WienerHammerstein_Process_Noise",
        "not_splitted_benchmarks.ParWHF",
        "not_splitted_benchmarks.F16",
        "not_splitted_benchmarks.Industrial_robot",
    )
)


# --------------------------------------------------------------------------- reading
class _Table:
    """A TOML table read with typed accessors; errors name the file and the key."""

    def __init__(self, data: Mapping[str, Any], source: str, where: str) -> None:
        self.data, self.source, self.where = data, source, where
        self.used: set[str] = set()

    def error(self, key: str, message: str) -> InputError:
        at = f"{self.where}.{key}" if self.where else key
        return InputError(f"benchmark file {self.source}: {at}: {message}")

    def _get(self, key: str, default: Any, required: bool) -> Any:
        self.used.add(key)
        if key not in self.data:
            if required:
                raise self.error(key, "is required")
            return default
        return self.data[key]

    def string(self, key: str, default: str | None = "", *, required: bool = False) -> Any:
        value = self._get(key, default, required)
        if value is not None and not isinstance(value, str):
            raise self.error(key, f"must be a string, got {value!r}")
        return value

    def number(self, key: str, default: float | None = None, *, required: bool = False, positive: bool = False) -> Any:
        value = self._get(key, default, required)
        if value is None:
            return None
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise self.error(key, f"must be a finite number, got {value!r}")
        if positive and value <= 0:
            raise self.error(key, f"must be positive, got {value!r}")
        return float(value)

    def integer(self, key: str, default: int | None = None, *, required: bool = False) -> Any:
        value = self._get(key, default, required)
        if value is None:
            return None
        if isinstance(value, bool) or not isinstance(value, int) or value < 0:
            raise self.error(key, f"must be a non-negative integer, got {value!r}")
        return int(value)

    def boolean(self, key: str, default: bool | None = None, *, required: bool = False) -> Any:
        value = self._get(key, default, required)
        if value is not None and not isinstance(value, bool):
            raise self.error(key, f"must be true or false, got {value!r}")
        return value

    def table(self, key: str, *, required: bool = False) -> _Table | None:
        value = self._get(key, None, required)
        if value is None:
            return None
        if not isinstance(value, Mapping):
            raise self.error(key, "must be a table")
        return _Table(value, self.source, f"{self.where}.{key}" if self.where else key)

    def tables(self, key: str) -> list[_Table]:
        value = self._get(key, [], False)
        if not isinstance(value, list) or not all(isinstance(v, Mapping) for v in value):
            raise self.error(key, f"must be an array of tables ([[{key}]])")
        return [_Table(v, self.source, f"{key}[{i}]") for i, v in enumerate(value)]

    def done(self) -> None:
        unknown = [k for k in self.data if k not in self.used]
        if unknown:
            raise self.error(unknown[0], f"unknown key{did_you_mean(unknown[0], self.used)}")


def _range(t: _Table) -> tuple[int, int] | None:
    value = t._get("range", None, False)
    if value is None:
        return None
    ok = (
        isinstance(value, list)
        and len(value) == 2
        and all(isinstance(v, int) and not isinstance(v, bool) for v in value)
    )
    if not ok or not 0 <= value[0] < value[1]:
        raise t.error("range", f"must be [start, stop] with 0 <= start < stop, got {value!r}")
    return int(value[0]), int(value[1])


def _part(t: _Table, *, user_file: bool) -> Part:
    part = t.string("part", None)
    package = t.string("package", None)
    if package is not None and not _PACKAGE_PART.match(package):
        raise t.error("package", f"must be train, test, test:K or all:K, got {package!r}")
    if part is None and package is None and not user_file:
        raise t.error(
            "part", "is required (a part of the dataset), or a package location, or a [file] the user supplies"
        )
    return Part(part, _range(t), package, t.integer("samples"), t.string("description"))


def _user_file(t: _Table) -> UserFile | None:
    f = t.table("file")
    if f is None:
        return None
    names = f._get("names", [], False)
    if not isinstance(names, list) or not all(isinstance(n, str) and n for n in names):
        raise f.error("names", "must be a list of file names")
    out = UserFile(tuple(names), f.string("columns", required=True), f.string("hint"))
    f.done()
    return out


def _rule(t: _Table, required: bool = True) -> str:
    rule = t.string("rule", required=required)
    if not required and not rule:
        return ""
    if not _RULE.match(rule):
        raise t.error("rule", f"must be first-sample, window:N or periodic[:N], got {rule!r}")
    return rule


def _published(t: _Table, tests: list[str]) -> Published:
    test = t.string("test", required=True)
    if test not in tests:
        raise t.error("test", f"names no test set of this benchmark{did_you_mean(test, tests)}: {', '.join(tests)}")
    status = t.string("status", required=True)
    if status not in STATUSES:
        raise t.error(
            "status", f"must be one of {', '.join(STATUSES)} (unverified figures are not shown), got {status!r}"
        )
    unit = t.string("unit", required=True)
    if unit not in UNITS:
        raise t.error("unit", f"must be one of {', '.join(UNITS)}, got {unit!r}")
    value = t.number("value", required=True)
    rmse = 10.0 ** (value / 20.0) if unit == "dB" else value * UNITS[unit]
    parameters = t.integer("parameters")
    fit = t.number("fit_percent")
    year = t.integer("year", required=True)
    out = Published(
        test=test,
        method=t.string("method", required=True),
        paper=t.string("paper", required=True),
        year=year,
        value=value,
        unit=unit,
        rmse=rmse,  # in the record's SI unit (m or V)
        rule=t.string("rule", required=True),
        same_rule=t.boolean("same_rule", required=True),
        source=t.string("source", required=True),
        status=status,
        fit_percent=fit,
        parameters=parameters,
        note=t.string("note"),
        structure=_structure(t),
    )
    t.done()
    return out


def _structure(t: _Table) -> str:
    from .prior import STRUCTURES

    value = t.string("structure", "black box")
    if value not in STRUCTURES:
        raise t.error("structure", f"must be one of {', '.join(STRUCTURES)}, got {value!r}")
    return value


def _truth(t: _Table | None) -> Truth | None:
    """The ``[truth]`` table: the system that generated a simulated benchmark's data."""
    if t is None:
        return None
    raw = t._get("coefficients", None, True)
    if not isinstance(raw, Mapping) or not raw:
        raise t.error("coefficients", "must be a table {term = value} of the true system's coefficients")
    coefficients = {}
    for term, value in raw.items():
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise t.error("coefficients", f"the coefficient of {term!r} must be a number, got {value!r}")
        coefficients[str(term)] = float(value)
    truth = Truth(coefficients, t.number("mass", required=True, positive=True), t.string("source", required=True))
    t.done()
    try:  # the terms are read once here, so that a misspelled one fails when the file is read
        from ..model.terms import Model

        Model.from_spec(list(coefficients), defaults=False)
    except InputError as exc:
        raise t.error("coefficients", str(exc)) from None
    return truth


def parse_protocol(text: str, source: str = "<text>") -> Protocol:
    """A :class:`Protocol` from the text of a benchmark file.

    Raises
    ------
    InputError
        Not valid TOML, a missing or unknown key, a value of the wrong kind, a published figure
        that is not verified; the message names the file and the key.
    """
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"benchmark file {source}: not valid TOML: {exc}") from None
    root = _Table(raw, source, "")
    b = root.table("benchmark", required=True)
    assert b is not None
    name = b.string("name", required=True)
    if not _NAME.match(name):
        raise b.error("name", f"must be lower-case letters, digits and -_.+, got {name!r}")
    unit = b.string("unit", required=True)
    if unit not in UNITS or unit == "dB":
        raise b.error("unit", f"must be one of m, mm, um, V, mV, got {unit!r}")
    force_hold = b.string("force_hold", "sampled")
    if force_hold not in ("sampled", "zoh"):
        raise b.error("force_hold", f"must be sampled or zoh, got {force_hold!r}")
    pkg = b.table("package")
    function, force_scale, output_scale = None, 1.0, 1.0
    if pkg is not None:
        function = pkg.string("function", required=True)
        if function not in PACKAGE_FUNCTIONS:
            raise pkg.error(
                "function",
                f"must name one of the nonlinear-benchmarks package's loaders ({', '.join(sorted(PACKAGE_FUNCTIONS))})"
                f", got {brief(function, 60)}{did_you_mean(function, sorted(PACKAGE_FUNCTIONS))}",
            )
        force_scale = pkg.number("force_scale", 1.0, positive=True)
        output_scale = pkg.number("output_scale", 1.0, positive=True)
        pkg.done()
    e = root.table("estimation", required=True)
    assert e is not None
    estimation_file = _user_file(e)
    estimation = _part(e, user_file=estimation_file is not None)
    if estimation_file is not None and estimation.part is not None:
        raise e.error("part", "the estimation part is either a part of the dataset or a [file], not both")
    e.done()
    tests = []
    for t in root.tables("tests"):
        test_name = t.string("name", required=True)
        if not _NAME.match(test_name):
            raise t.error("name", f"must be lower-case letters, digits and -_.+, got {test_name!r}")
        if test_name == "estimation":
            raise t.error("name", "'estimation' names the estimation part; choose another name")
        user = _user_file(t)
        src = _part(t, user_file=user is not None)
        if user is not None and src.part is not None:
            raise t.error("part", "a test set is either a part of the dataset or a [file], not both")
        nf = t.table("noise_floor")
        floor = None
        if nf is not None:
            periods = nf._get("periods", [], False)
            if (
                not isinstance(periods, list)
                or len(periods) < 2
                or not all(isinstance(p, int) and not isinstance(p, bool) and p >= 1 for p in periods)
            ):
                raise nf.error("periods", "must list at least two periods (1-based) of the estimation part")
            period = nf.integer("period", required=True)
            if period < 2:
                raise nf.error("period", f"must be at least 2 samples, got {period}")
            floor = NoiseFloor(period, tuple(periods))
            nf.done()
        tests.append(TestSet(test_name, src, _rule(t), user, t.string("rule_note"), floor))
        t.done()
    if not tests:
        raise root.error("tests", "at least one [[tests]] is required")
    names = [t.name for t in tests]
    if len(set(names)) != len(names):
        raise root.error("tests", f"test set names must be unique, got {names}")
    p = root.table("pipelines", required=True)
    assert p is not None
    mass_raw = p._get("mass", "estimate", False)
    if mass_raw == "estimate":
        mass = None
    elif (
        isinstance(mass_raw, (int, float))
        and not isinstance(mass_raw, bool)
        and math.isfinite(mass_raw)
        and mass_raw > 0
    ):
        mass = float(mass_raw)
    else:
        raise p.error("mass", f'must be "estimate" or a positive number (kg), got {mass_raw!r}')
    holdout = p.number("holdout", 0.25)
    if not 0.0 < holdout < 1.0:
        raise p.error("holdout", f"must lie between 0 and 1, got {holdout}")
    options_raw = p._get("options", {}, False)
    if not isinstance(options_raw, Mapping) or not all(isinstance(v, Mapping) for v in options_raw.values()):
        raise p.error("options", "must be a table of tables: [pipelines.options.NAME]")
    peer_t = p.table("pysindy")
    peer = PeerSettings()
    if peer_t is not None:
        thresholds = peer_t._get("thresholds", list(peer.thresholds), False)
        if (
            not isinstance(thresholds, list)
            or not thresholds
            or not all(isinstance(x, (int, float)) and not isinstance(x, bool) and x >= 0 for x in thresholds)
        ):
            raise peer_t.error("thresholds", "must be a non-empty list of non-negative numbers")
        degree = peer_t.integer("degree", peer.degree)
        if not 1 <= degree <= 5:
            raise peer_t.error("degree", f"must lie between 1 and 5, got {degree}")
        if any(x >= 1 for x in thresholds):
            raise peer_t.error("thresholds", "are fractions of the largest coefficient: each must be below 1")
        peer = PeerSettings(degree, peer_t.boolean("friction", peer.friction), tuple(float(x) for x in thresholds))
        peer_t.done()
    # the rule of discover's prediction check on blocks of the estimation part: the tests' window rule when they
    # share one (a block cut from a record starts in motion, as a test set does); else each block's own
    windows = {t.rule for t in tests if t.rule.startswith("window:")}
    rule = _rule(p, required=False) or (windows.pop() if len(windows) == 1 else None)
    pipelines = PipelineSettings(
        rule=rule or None,
        terms=p.string("terms", required=True),
        without=p.string("without"),
        declared=p.string("declared", required=True),
        mass=mass,
        holdout=holdout,
        options={k: dict(v) for k, v in options_raw.items()},
        note=p.string("note"),
        peer=peer,
    )
    p.done()
    published = tuple(_published(t, names) for t in root.tables("published"))
    left_out = []
    for t in root.tables("not_comparable"):
        left_out.append(NotComparable(t.string("what", required=True), t.string("why", required=True)))
        t.done()
    truth = _truth(root.table("truth"))
    proto = Protocol(
        name=name,
        title=b.string("title", required=True),
        citation=b.string("citation", required=True),
        dataset=b.string("dataset", required=True),
        official=b.boolean("official", required=True),
        protocol=b.string("protocol", required=True),
        unit=unit,
        scale=b.number("scale", required=True, positive=True),
        fs=b.number("fs", required=True, positive=True),
        remove_means=b.boolean("remove_means", False),
        force_hold=force_hold,
        package_function=function,
        force_scale=force_scale,
        output_scale=output_scale,
        estimation=estimation,
        estimation_file=estimation_file,
        tests=tuple(tests),
        pipelines=pipelines,
        published=published,
        not_comparable=tuple(left_out),
        text=text,
        truth=truth,
    )
    b.done()
    root.done()
    return proto


# --------------------------------------------------------------------------- built-ins
#: Folder of the built-in benchmark files, inside the package.
BUILTIN_PACKAGE_DIR = "benchmarking/protocols"


def builtin_benchmarks() -> dict[str, Path]:
    """``{name: path}`` of the built-in benchmark files (package data, found by every kind of install)."""
    from importlib.resources import files

    folder = Path(str(files("nlid") / BUILTIN_PACKAGE_DIR))
    return {p.stem: p for p in sorted(folder.glob("*.toml"))}


def load_protocol(name_or_path: str | Path) -> Protocol:
    """A benchmark's protocol: a built-in name (``"silverbox"``) or the path of a benchmark file.

    Raises
    ------
    InputError
        An unknown name, an unreadable file, or a file that is not a valid benchmark file.
    """
    text_name = canonical_name(str(name_or_path))  # "boucwen" is "bouc-wen"
    builtins = builtin_benchmarks()
    if text_name in builtins:
        path = builtins[text_name]
    else:
        path = Path(text_name).expanduser()
        if path.suffix == ".toml" and (path.exists() or path.is_symlink()):
            check_path(path, what="benchmark file", max_bytes=TEXT_LIMIT)  # a folder, a pipe, a device: refused
        if not path.suffix == ".toml" or not path.is_file():
            raise InputError(
                f"unknown benchmark {text_name!r}{did_you_mean(text_name, builtins)}; built-in: "
                f"{', '.join(builtins)} (or the path of a benchmark .toml file)"
            )
    try:
        text = read_text_file(path, "benchmark file")
    except DataError as exc:
        raise InputError(str(exc)) from None
    protocol = parse_protocol(text, str(path))
    if text_name in builtins and protocol.name != text_name:
        raise InputError(f"benchmark file {path}: its name {protocol.name!r} differs from the file's")
    return protocol
