"""A benchmark's records: from ``$NLID_DATA_DIR`` (checksummed), the ``nonlinear-benchmarks`` package, or a user file.

Where each part comes from (``source=``):

``"auto"`` (default)
    ``$NLID_DATA_DIR`` when the part is there and its files match the checksums of ``nlid data``
    (no network, reproducible); else the optional ``nonlinear-benchmarks`` package when it is
    installed and the benchmark file says where the package has the part (it downloads into its
    own cache); a test set the user supplied (``files=``) is always read from that file.
``"local"``
    only ``$NLID_DATA_DIR`` (and user files).
``"package"``
    only the ``nonlinear-benchmarks`` package (and user files).

A part is checked after it is read: its number of samples (when the benchmark file gives it) and
its sampling frequency. With ``remove_means`` the *estimation* part's means of ``f`` and ``z``
are subtracted from every part, so nothing computed from a test set reaches the estimation data.
Every test record carries ``meta["protocol"]`` (benchmark, test, rule, metric, unit, scale), from
which :func:`nlid.scoring.default_rule` reads its rule.
"""

from __future__ import annotations

import functools
import importlib
import inspect
import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..data import datasets
from ..data.io import check_path, read_table
from ..data.record import Record
from ..errors import DataError, InputError
from ..estimation.balance import settled_samples, suggested_cutoff
from .declarations import NoiseFloor, Part, Protocol, TestSet, UserFile
from .protocol import PACKAGE_FUNCTIONS

__all__ = ["SOURCES", "Offsets", "load_estimation", "load_test", "noise_floor", "read_user_file", "package_record"]

#: Where parts may come from (see the module docstring).
SOURCES = ("auto", "local", "package")
#: Relative tolerance of a part's sampling frequency against the benchmark file's.
FS_RTOL = 1e-4


@dataclass(frozen=True)
class Offsets:
    """What is subtracted from ``f`` and ``z`` of every part: the estimation part's means (or zeros)."""

    f: float = 0.0
    z: float = 0.0

    def apply(self, record: Record) -> Record:
        """``record`` with the offsets removed (itself when both are zero)."""
        if self.f == 0.0 and self.z == 0.0:
            return record
        return record.replace(f=record.f - self.f, z=record.z - self.z)


def _check_source(source: str) -> str:
    if source not in SOURCES:
        raise InputError(f"source= must be one of {', '.join(SOURCES)}, got {source!r}")
    return source


@functools.lru_cache(maxsize=8)
def _checksums(dataset: str, folder: str) -> tuple[str, ...]:
    """Files of ``dataset`` whose checksum does not match (missing files are not listed)."""
    return tuple(str(s.path) for s in datasets.check(folder, [dataset]) if s.status == "mismatch")


def _local(protocol: Protocol, part: Part) -> Record:
    """A part read from ``$NLID_DATA_DIR`` through :func:`nlid.data.datasets.load`, after the checksum check."""
    folder = datasets.data_dir()
    bad = _checksums(protocol.dataset, str(folder))
    if bad:
        raise DataError(
            f"{', '.join(bad)}: checksum differs from nlid's (nlid data shows the expected SHA-256); "
            "re-download the file"
        )
    record = datasets.load(protocol.dataset, part=part.part or "all")
    return _slice(record, part, protocol)


def _slice(record: Record, part: Part, protocol: Protocol) -> Record:
    if part.range is not None:
        start, stop = part.range
        if stop > record.n:
            raise DataError(
                f"benchmark {protocol.name}: range [{start}:{stop}) exceeds the {record.n} samples of its source"
            )
        record = record[start:stop]
    return record


# --------------------------------------------------------------------------- nonlinear-benchmarks
def _package_function(name: str) -> Any:
    """One of the package's loaders (:data:`~nlid.benchmarking.protocol.PACKAGE_FUNCTIONS`), looked up by name.

    Never a walk of attributes from the benchmark file's text: the name must be in the allow-list, its
    module is imported by its full name, and the object found there under that name must be a function.
    """
    if name not in PACKAGE_FUNCTIONS:
        raise DataError(f"{name!r} is not a loader of the nonlinear-benchmarks package nlid knows")
    module_name, _, function = ("." + name).rpartition(".")
    try:
        module: Any = importlib.import_module("nonlinear_benchmarks" + module_name)
    except ImportError:
        raise DataError(
            "the nonlinear-benchmarks package is not installed (pip install nonlinear-benchmarks)"
        ) from None
    obj = vars(module).get(function)
    if obj is None:
        raise DataError(f"nonlinear_benchmarks has no {name!r} (an older or newer version?)")
    if not inspect.isfunction(obj):
        raise DataError(f"nonlinear_benchmarks.{name} is not a function")
    return obj


@functools.lru_cache(maxsize=4)
def _package_result(name: str) -> Any:
    function = _package_function(name)
    try:
        return function()
    except Exception as exc:  # noqa: BLE001 - a download or parse failure of an outside package is a data error
        raise DataError(f"nonlinear_benchmarks.{name}() failed: {type(exc).__name__}: {exc}") from None


def _locate(result: Any, where: str, name: str) -> Any:
    """The data set at ``where`` (``train``, ``test``, ``test:K``, ``all:K``) in what a package function returned."""
    kind, _, index = where.partition(":")
    try:
        if kind == "all":
            return result[int(index)]
        train, test = result
        if kind == "train":
            return train
        return test[int(index)] if index else test
    except (TypeError, ValueError, IndexError):
        raise DataError(f"nonlinear_benchmarks.{name}() returned no data set at {where!r}") from None


def package_record(protocol: Protocol, part: Part) -> Record:
    """A part read through the ``nonlinear-benchmarks`` package (its ``u``, ``y`` scaled to ``f``, ``z``).

    Raises
    ------
    DataError
        The package is not installed, fails (no network...), does not have the part, or gives a
        sampling time other than the benchmark file's.
    """
    name = protocol.package_function
    if name is None or part.package is None:
        raise DataError(f"benchmark {protocol.name}: the nonlinear-benchmarks package does not have this part")
    data = _locate(_package_result(name), part.package, name)
    try:
        u = np.asarray(data.u, dtype=float).ravel()
        y = np.asarray(data.y, dtype=float).ravel()
    except (AttributeError, TypeError, ValueError):
        raise DataError(f"nonlinear_benchmarks.{name}() at {part.package!r} is not an input-output data set") from None
    sampling_time = getattr(data, "sampling_time", None)
    if sampling_time is not None and abs(1.0 / float(sampling_time) / protocol.fs - 1.0) > FS_RTOL:
        raise DataError(
            f"nonlinear_benchmarks.{name}() gives a sampling frequency of {1 / float(sampling_time):.6g} Hz, "
            f"the benchmark file {protocol.fs:.6g} Hz"
        )
    record = Record(
        f=u * protocol.force_scale,
        z=y * protocol.output_scale,
        fs=protocol.fs,
        meta={
            "source": f"nonlinear-benchmarks: {name}() {part.package}",
            "citation": protocol.citation,
            "force_hold": protocol.force_hold,
        },
    )
    return _slice(record, part, protocol)


# --------------------------------------------------------------------------- user files
def read_user_file(protocol: Protocol, spec: UserFile | None, path: str | os.PathLike[str]) -> Record:
    """A user-supplied test set: the benchmark's own files (with their column map) or any nlid data file.

    ``path`` may be the folder holding the benchmark's files, one of them (the others are read
    from beside it), or another ``.csv``/``.npz``/``.mat`` file with nlid's columns (``t, f, z``;
    without ``t`` the benchmark's sampling frequency is used).

    Raises
    ------
    DataError
        A missing file or column, or a record whose number of samples or sampling frequency is not
        the benchmark's.
    """
    p = Path(path).expanduser()
    if spec is not None and (p.is_dir() or p.name in spec.names):
        folder = p if p.is_dir() else p.parent
        table: dict[str, Any] = {}
        for name in spec.names:
            table.update(read_table(folder / name))
        columns: str | None = spec.columns
        where = str(folder / spec.names[0]) if len(spec.names) == 1 else f"{folder}/{{{','.join(spec.names)}}}"
    else:
        table = read_table(p)
        columns, where = None, str(p)
    has_time = ("t" in table and np.asarray(table["t"]).size > 1) or (
        columns is not None and "t=" in columns.replace(" ", "")
    )
    has_fs = "fs" in table and np.asarray(table["fs"]).size == 1
    record = Record.from_table(
        table,
        columns,
        fs=None if has_time or has_fs else protocol.fs,
        meta={"source": where, "citation": protocol.citation, "force_hold": protocol.force_hold},
        source=where,
    )
    if abs(record.fs / protocol.fs - 1.0) > FS_RTOL:
        raise DataError(
            f"{where}: sampled at {record.fs:.6g} Hz; the {protocol.name} benchmark's is {protocol.fs:.6g} Hz"
        )
    return record


# --------------------------------------------------------------------------- parts
def _check_samples(record: Record, part: Part, what: str) -> Record:
    if part.samples is not None and record.n != part.samples:
        raise DataError(f"{what}: {record.n} samples, the benchmark declares {part.samples}")
    return record


def _check_values(record: Record, what: str) -> Record:
    """Refuse a part whose force or displacement squares overflow: no fit or RMSE can be computed from it."""
    for channel in ("f", "z"):
        x = getattr(record, channel)
        with np.errstate(over="ignore"):
            total = float(np.dot(x, x))
        if not np.isfinite(total):
            unit = record.units.get(channel, "")
            raise DataError(
                f"{what}: its {channel} reaches {np.max(np.abs(x)):.3g} {unit}: the sum of its squares overflows a "
                "float64, so no model can be fitted or scored on it (a unit error?)"
            )
    return record


def _check_rule(record: Record, test: TestSet, what: str) -> Record:
    """Refuse a test set too short to be scored: for its transient rule (what :func:`nlid.scoring.rules.start`
    refuses), or for the filtered force balance its residuals are computed on
    (:func:`nlid.estimation.balance.settled_samples`).
    """
    kind, _, value = test.rule.partition(":")
    if kind == "window" and int(value) >= record.n - 1:
        raise DataError(
            f"{what}: {record.n} samples, too few to score after its initialisation window of {value} samples"
        )
    if kind == "periodic" and value and int(value) > record.n:
        raise DataError(f"{what}: {record.n} samples, less than the period of {value} samples its rule scores")
    if record.v is None or record.a is None:  # scored on a filtered force balance (v or a estimated)
        try:
            settled_samples(record.n, record.fs, suggested_cutoff(record), 1)
        except DataError as exc:
            raise DataError(f"{what}: {exc}") from None
    return record


def _read(protocol: Protocol, part: Part, source: str, what: str) -> Record:
    errors = []
    if source in ("auto", "local") and part.part is not None:
        try:
            return _local(protocol, part)
        except DataError as exc:
            if source == "local":
                raise
            errors.append(str(exc))
    if source in ("auto", "package") and part.package is not None and protocol.package_function is not None:
        try:
            return package_record(protocol, part)
        except DataError as exc:
            errors.append(str(exc))
    if not errors:
        raise DataError(f"{what}: not available from source {source!r}")
    raise DataError(f"{what}: {'; '.join(errors)}")


def load_estimation(
    protocol: Protocol, *, source: str = "auto", path: str | os.PathLike[str] | None = None
) -> tuple[Record, Offsets]:
    """The estimation part (means removed when the protocol says so) and the offsets removed from it.

    ``path`` is the user-supplied file of a benchmark whose estimation part is a ``[estimation.file]``.
    """
    what = f"{protocol.name} estimation part"
    if protocol.estimation_file is not None:
        if path is None:
            raise DataError(
                f"{what} is a file the user supplies: give it in files= with the key '{protocol.name}:estimation'"
            )
        record = read_user_file(protocol, protocol.estimation_file, path)
    else:
        record = _read(protocol, protocol.estimation, _check_source(source), what)
    record = _check_samples(
        _slice(record, protocol.estimation, protocol) if path is not None else record, protocol.estimation, what
    )
    _check_values(record, what)
    offsets = Offsets(float(record.f.mean()), float(record.z.mean())) if protocol.remove_means else Offsets()
    record = offsets.apply(record).with_meta(
        part="estimation", benchmark=protocol.name, force_hold=record.meta.get("force_hold", protocol.force_hold)
    )
    if protocol.pipelines.mass is not None:
        record = record.with_meta(mass=protocol.pipelines.mass)
    return record, offsets


def load_test(
    protocol: Protocol,
    test: TestSet,
    offsets: Offsets,
    *,
    source: str = "auto",
    path: str | os.PathLike[str] | None = None,
) -> Record:
    """One test set with ``meta["protocol"]`` set, the estimation offsets removed.

    Raises
    ------
    DataError
        It cannot be read: a user-supplied test set without ``path`` and without the package,
        a missing or altered file...
    """
    what = f"{protocol.name} test set {test.name!r}"
    if path is not None:
        record = _slice(read_user_file(protocol, test.file, path), test.source, protocol)
    elif test.file is not None and (source == "local" or test.source.package is None):
        hint = f" ({test.file.hint})" if test.file.hint else ""
        raise DataError(
            f"{what} is not in $NLID_DATA_DIR: give its file in files= with the key '{protocol.name}:{test.name}'{hint}"
        )
    else:
        try:
            record = _read(protocol, test.source, _check_source(source), what)
        except DataError as exc:
            if test.file is None:
                raise
            raise DataError(
                f"{exc}; give its file in files= with the key '{protocol.name}:{test.name}'"
                + (f" ({test.file.hint})" if test.file.hint else "")
            ) from None
    record = _check_rule(_check_values(_check_samples(record, test.source, what), what), test, what)
    meta: dict[str, Any] = {
        "part": test.name,
        "benchmark": protocol.name,
        "force_hold": record.meta.get("force_hold", protocol.force_hold),
        "protocol": {
            "benchmark": protocol.name,
            "test": test.name,
            "rule": test.rule,
            "metric": "rmse",
            "unit": protocol.unit,
            "scale": protocol.scale,
        },
    }
    if test.rule.startswith("periodic:"):
        meta["periodic"] = int(test.rule.split(":", 1)[1])
    if protocol.pipelines.mass is not None:
        meta["mass"] = protocol.pipelines.mass
    return offsets.apply(record).with_meta(**meta)


def noise_floor(estimation: Record, floor: NoiseFloor) -> float:
    """The output noise ``sigma`` from the differences between periods of the estimation part (unit of ``z``).

    ``sigma^2 = mean over pairs (i, j) of mean((y_i - y_j)^2) / 2``; the periods are 1-based.

    Raises
    ------
    DataError
        The estimation part is shorter than the periods named.
    """
    p = floor.period
    last = max(floor.periods) * p
    if last > estimation.n:
        raise DataError(f"noise floor: period {max(floor.periods)} of {p} samples ends after the estimation part")
    segments = [estimation.z[(k - 1) * p : k * p] for k in floor.periods]
    pairs = [
        float(np.mean((segments[i] - segments[j]) ** 2)) / 2.0
        for i in range(len(segments))
        for j in range(i + 1, len(segments))
    ]
    return float(np.sqrt(np.mean(pairs)))


def check_user_files(protocols: Mapping[str, Protocol], files: Mapping[str, str]) -> dict[str, str]:
    """``files`` checked against the benchmarks, before any job runs: each key names one set of a chosen benchmark.

    Each file is read as its job will read it (:func:`load_estimation`, :func:`load_test`): a file that
    cannot be read, holds a NaN, has another number of samples than the benchmark declares, is too short
    for its test set's transient rule, or whose values overflow is refused here, not reported as a failed
    row after the pipelines have run.

    Raises
    ------
    InputError
        A key that is not ``BENCHMARK:TEST`` of a chosen benchmark, or a path that does not exist.
    DataError
        A file that is not a regular file (a pipe, a device), or that its job could not use.
    """
    out = {}
    for key, path in files.items():
        bench, sep, test = key.partition(":")
        if not sep or bench not in protocols:
            raise InputError(
                f"test file {key!r}: name it BENCHMARK:TEST with a chosen benchmark ({', '.join(protocols)})"
            )
        protocol = protocols[bench]
        declared = (
            protocol.estimation_file is not None if test == "estimation" else protocol.test(test).file is not None
        )
        if not declared:
            user = [t.name for t in protocol.tests if t.file is not None]
            user += ["estimation"] if protocol.estimation_file is not None else []
            raise InputError(
                f"test file {key!r}: {test!r} is read from $NLID_DATA_DIR, not from a file you give; "
                f"{protocol.name}'s user-supplied sets: {', '.join(user) or 'none'}"
            )
        given = Path(path).expanduser()
        if not given.exists():
            raise InputError(f"test file for {key}: {path} does not exist")
        if not given.is_dir():  # a folder holds the benchmark's files; anything else is one regular file
            try:
                check_path(given, what="test file")
            except DataError as exc:
                raise InputError(f"test file for {key}: {exc}") from None
        out[key] = str(given.resolve())
        if test == "estimation":
            load_estimation(protocol, path=out[key])
        else:
            load_test(protocol, protocol.test(test), Offsets(), path=out[key])
    return out
