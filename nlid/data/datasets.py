"""Loaders for measured benchmark records (nonlinearbenchmark.org).

The files are not shipped with nlid: they are read from the folder named by
the environment variable ``NLID_DATA_DIR`` (holding ``emps/``,
``silverbox/`` and ``boucwen/``). :data:`BENCHMARKS` lists every known
benchmark with its source, its files and their SHA-256 checksums (the one
place they are kept); :func:`check` tells which files are present and intact
(``nlid data`` prints it). Cite the original authors in any report that uses
them.

``emps`` (Janot, Gautier, Brunot 2019)
    Electro-mechanical positioning system in closed loop, 1 kHz, 24 841
    samples. ``f = gtau * vir`` (N, motor force), ``z = qm`` (m). Velocity and
    acceleration are not measured. Reference (IDIM-LS): M = 95.1 kg,
    Fv = 203.5 N s/m, Fc = 20.4 N, offset -3.16 N, residual about 4 %.
``bouc-wen`` (Noel & Schoukens 2016; ``boucwen`` is accepted too, the folder is ``boucwen/``)
    Bouc-Wen hysteretic oscillator simulated by its authors, 750 Hz: ``dataset:bouc-wen`` is the
    training multisine (``u`` force in N, ``y`` displacement in m, 40 960 samples),
    ``dataset:bouc-wen:sinesweep`` the validation sine sweep; the hysteretic force is the
    ``bouc_wen(a, b)`` term (:mod:`nlid.model.terms.memory`).
``silverbox`` (Wigren & Schoukens 2013)
    Electronic Duffing oscillator ``m y'' + d y' + (a + b y^2) y = u``;
    ``f = V1``, ``z = V2`` in volts, fs = 10^7 / 2^14 = 610.35 Hz, 131 072
    samples. The record holds the "arrow head" (Gaussian noise of growing
    amplitude, samples ~100 to ~40 486), about 100 zeros, then ten odd
    random-phase multisine blocks. The benchmark's parts
    (:data:`SILVERBOX_PARTS`, the split of the ``nonlinear-benchmarks``
    package): ``estimation`` ``[40650:105712)``, and the test sets
    ``arrow-full`` ``[100:40575)``, ``arrow-no-extrapolation``
    ``[100:32100)`` and ``multisine-test`` ``[105712:127400)``; these parts
    have the means of the estimation part removed (a statistic of the
    estimation data only). The older parts ``all``, ``arrow`` (``[0:40000)``)
    and ``multisine`` (``[40000:]``) have the whole record's means removed.
    **``multisine`` is deprecated for estimation**: it starts at sample
    40 000, before the arrow head ends, so it holds the last ~486 samples of
    the test arrow, the largest amplitudes of the record (0.241 V, above the
    0.216 V of the estimation part): a model estimated on it has seen the
    test set's extrapolation region. Use ``estimation``.
"""

from __future__ import annotations

import hashlib
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..base.validate import did_you_mean
from ..errors import DataError, InputError, brief
from .io import read_table
from .names import canonical_name
from .record import Record

__all__ = [
    "DATA_ENV",
    "data_dir",
    "load",
    "DATASETS",
    "BENCHMARKS",
    "Benchmark",
    "DataFile",
    "FileStatus",
    "check",
    "sha256",
    "SILVERBOX_FS",
    "SILVERBOX_ARROW",
    "SILVERBOX_PARTS",
    "BOUC_WEN_REFERENCE",
    "EMPS_REFERENCE",
]

#: Environment variable naming the data folder.
DATA_ENV = "NLID_DATA_DIR"
#: Silverbox sampling frequency (Hz).
SILVERBOX_FS = 1e7 / 2**14
#: Number of samples of nlid's older Silverbox ``arrow`` part (``[0:40000)``; the benchmark's is ``arrow-full``).
SILVERBOX_ARROW = 40_000
#: The Silverbox parts of the benchmark protocol (``nonlinear-benchmarks``' ``Silverbox()`` split):
#: ``[start, stop)`` sample indices into ``SNLS80mV.mat``. Each is returned with the means of the
#: ``estimation`` part removed from the force and the output.
SILVERBOX_PARTS = {
    "estimation": (40_650, 105_712),
    "arrow-full": (100, 40_575),
    "arrow-no-extrapolation": (100, 32_100),
    "multisine-test": (105_712, 127_400),
}

#: The Bouc-Wen benchmark's own model (Noel & Schoukens 2016), ``m y'' + c y' + k y + w = u``,
#: ``w' = alpha y' - beta (gamma |y'| w + delta y' |w|)`` with m = 2 kg, c = 10 N s/m,
#: k = 5e4 N/m, alpha = 5e4 N/m, beta = 1e3 1/m, gamma = 0.8, delta = -1.1, nu = 1: in nlid's
#: terms ``alpha * bouc_wen(beta gamma, beta delta)`` with the state ``w / alpha`` (see
#: :mod:`nlid.model.terms.memory`).
BOUC_WEN_REFERENCE = {
    "mass": 2.0,
    "coefficients": {"z": 5e4, "v": 10.0, "bouc_wen(800, -1100)": 5e4},
    # as the leaderboard lists them (nlid/benchmarking/protocols/bouc-wen.toml, each with its rule); dynoNet's under
    # another transient rule. The "linear model about 2e-4 m" of earlier versions has no source and is not here.
    "published_rms_error_m": {"pnlss_multisine": 1.21e-5, "dynonet_multisine_other_rule": 4.52e-5},
}


@dataclass(frozen=True)
class DataFile:
    """One file of a benchmark: its path under ``$NLID_DATA_DIR``, SHA-256 and content."""

    path: str
    sha256: str
    content: str


@dataclass(frozen=True)
class Benchmark:
    """A measured benchmark nlid knows: where it comes from and the files it expects.

    Attributes
    ----------
    name
        Short name (``dataset:NAME`` when :attr:`loader` is true).
    title
        What it is.
    source
        Where to get it.
    citation
        What to cite.
    loader
        Whether :func:`load` reads it.
    files
        The files, relative to ``$NLID_DATA_DIR``, with their checksums.
    """

    name: str
    title: str
    source: str
    citation: str
    loader: bool
    files: tuple[DataFile, ...]


#: Every known benchmark, its files and their SHA-256 checksums (the only copy of them in nlid).
BENCHMARKS: dict[str, Benchmark] = {
    "emps": Benchmark(
        "emps",
        "EMPS electro-mechanical positioning system, closed loop, Coulomb and viscous friction, 1 kHz",
        "nonlinearbenchmark.org, benchmark 'EMPS' (https://www.nonlinearbenchmark.org)",
        "A. Janot, M. Gautier, M. Brunot, Data set and reference models of EMPS, "
        "Nonlinear System Identification Benchmarks, 2019",
        True,
        (
            DataFile(
                "emps/DATA_EMPS.mat",
                "6cf6814ae14618795da0101aae2bb97ff0c6351b0501b5492751b02b07facf7e",
                "t, qm (motor position, m), qg, vir (motor voltage), gtau = 35.15 N/V, kp, kv; 24 841 samples",
            ),
        ),
    ),
    "silverbox": Benchmark(
        "silverbox",
        "Silverbox electronic Duffing oscillator (cubic spring), 610.35 Hz",
        "nonlinearbenchmark.org, benchmark 'Silverbox' (https://www.nonlinearbenchmark.org)",
        "T. Wigren, J. Schoukens, Three free data sets for development and benchmarking in nonlinear system "
        "identification, ECC 2013",
        True,
        (
            DataFile(
                "silverbox/SNLS80mV.mat",
                "5c7413a52255af0cb4e2f93fb6903beb92b08965ba1e6ad0a6ffedfed8477ed4",
                "V1 input, V2 output (V), 131 072 samples: arrow head (first 40 000) then odd multisines",
            ),
            DataFile(
                "silverbox/Schroeder80mV.mat",
                "ec5a9740a4789aa20b9d84f387424c0218e843844807b30b367c218778339fb6",
                "the same layout with one Schroeder-phase multisine section",
            ),
        ),
    ),
    "bouc-wen": Benchmark(
        "bouc-wen",
        "Bouc-Wen hysteretic oscillator (simulated benchmark), 750 Hz; part 'sinesweep': the validation set",
        "nonlinearbenchmark.org, benchmark 'Bouc-Wen' (https://www.nonlinearbenchmark.org)",
        "J.P. Noel, M. Schoukens, Hysteretic benchmark with a dynamic nonlinearity, "
        "Workshop on Nonlinear System Identification Benchmarks, 2016",
        True,
        (
            DataFile(
                "boucwen/train_multisine.mat",
                "2041c7af6bebf47fff5398ba2563e06fc320958c0764f7168b87fcee29a03531",
                "u force (N), y displacement (m), 40 960 samples (5 multisine periods)",
            ),
            DataFile(
                "boucwen/uval_sinesweep.mat",
                "2598fff9cae7e83f745d20ef7dcdb2987a41d38501848f04c95014d5d0a44a62",
                "uval_sinesweep: validation force (N), 153 000 samples",
            ),
            DataFile(
                "boucwen/yval_sinesweep.mat",
                "b05e2370b0b654f223f331706a8ae1c6b5c4f86df67e7a14d8d7f43415bdb20d",
                "yval_sinesweep: validation displacement (m), 153 000 samples",
            ),
        ),
    ),
}

#: The benchmarks :func:`load` reads, with the file it reads.
DATASETS = {name: f"{b.title.split(',')[0]} ({b.files[0].path})" for name, b in BENCHMARKS.items() if b.loader}


@dataclass(frozen=True)
class FileStatus:
    """What :func:`check` found for one file: ``"ok"``, ``"missing"`` or ``"mismatch"``."""

    benchmark: str
    file: DataFile
    path: Path | None
    status: str
    found_sha256: str | None = None


def sha256(path: str | os.PathLike[str], chunk: int = 1 << 20) -> str:
    """The SHA-256 hex digest of a file, read in chunks."""
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        while block := fh.read(chunk):
            digest.update(block)
    return digest.hexdigest()


def check(folder: str | os.PathLike[str] | None = None, names: list[str] | None = None) -> list[FileStatus]:
    """Which benchmark files are present under ``folder`` and whether their checksums match.

    Parameters
    ----------
    folder
        The data folder; default ``$NLID_DATA_DIR``. ``None`` with the
        variable unset (or not a folder) reports every file as missing.
    names
        Benchmarks to check (default: all of :data:`BENCHMARKS`).

    Returns
    -------
    list of FileStatus
        One per file, in the order of :data:`BENCHMARKS`.
    """
    names = [canonical_name(n) for n in names] if names else names
    unknown = [n for n in names or [] if n not in BENCHMARKS]
    if unknown:
        raise InputError(f"unknown benchmark {unknown[0]!r}; known: {', '.join(BENCHMARKS)}")
    if folder is None:
        value = os.environ.get(DATA_ENV)
        folder = Path(value).expanduser() if value else None
    root = Path(folder) if folder is not None else None
    if root is not None and not root.is_dir():
        root = None
    out = []
    for name, bench in BENCHMARKS.items():
        if names and name not in names:
            continue
        for f in bench.files:
            path = root / f.path if root is not None else None
            if path is None or not path.is_file():
                out.append(FileStatus(name, f, path, "missing"))
                continue
            found = sha256(path)
            out.append(FileStatus(name, f, path, "ok" if found == f.sha256 else "mismatch", found))
    return out


EMPS_REFERENCE = {"mass": 95.1, "coefficients": {"v": 203.5, "sign(v)": 20.4, "1": -3.16}, "eps_percent": 4.0}


def data_dir() -> Path:
    """The folder named by ``$NLID_DATA_DIR``.

    Raises
    ------
    DataError
        If the variable is unset or does not name a folder.
    """
    value = os.environ.get(DATA_ENV)
    if not value:
        raise DataError(
            f"set {DATA_ENV} to the folder that holds the measured data (emps/, silverbox/, boucwen/; "
            "'nlid data' or nlid.data.datasets.check() lists where to get them and what is there)"
        )
    path = Path(value).expanduser()
    if not path.is_dir():
        raise DataError(f"{DATA_ENV}={value} is not a folder")
    return path


def _file(relative: str) -> Path:
    path = data_dir() / relative
    if not path.is_file():
        raise DataError(f"{path} not found: {DATA_ENV}={os.environ.get(DATA_ENV)} must hold {relative}")
    return path


def load(name: str, *, part: str = "all") -> Record:
    """Load a measured benchmark record.

    Parameters
    ----------
    name
        ``"emps"``, ``"silverbox"`` or ``"bouc-wen"`` (:data:`nlid.data.names.PARTS`; ``"boucwen"`` is an alias).
    part
        For ``silverbox``: the benchmark's ``"estimation"`` part or one of
        its test sets ``"arrow-full"``, ``"arrow-no-extrapolation"``,
        ``"multisine-test"`` (:data:`SILVERBOX_PARTS`; means of the
        estimation part removed); or the older ``"all"``, ``"arrow"`` (first
        40 000 samples) and ``"multisine"`` (the rest; deprecated for
        estimation: it holds the end of the arrow head, see the module
        docstring). For ``bouc-wen``: ``"train"`` (= ``"all"``, the
        5-period multisine, 40 960 samples) or ``"sinesweep"`` (the
        validation set, 153 000 samples). Only ``"all"`` for ``emps``.

    Returns
    -------
    Record
        With ``meta["source"]``, ``meta["citation"]`` and, for ``emps``, the
        benchmark's reference values in ``meta["reference"]``.
    """
    name = canonical_name(name)
    if name == "emps":
        if part != "all":
            raise InputError("the emps record has no parts; use part='all'")
        path = _file(BENCHMARKS["emps"].files[0].path)
        table = read_table(path)
        gtau = float(np.asarray(table["gtau"]).ravel()[0])
        return Record.from_time(
            table["t"],
            f=gtau * np.asarray(table["vir"], dtype=float).ravel(),
            z=np.asarray(table["qm"], dtype=float).ravel(),
            meta={
                "source": str(path),
                "citation": "A. Janot, M. Gautier, M. Brunot, Data set and reference models of EMPS, "
                "Nonlinear System Identification Benchmarks, 2019",
                "reference": EMPS_REFERENCE,
            },
        )
    if name == "bouc-wen":
        citation = BENCHMARKS["bouc-wen"].citation
        if part in ("all", "train", "multisine"):
            path = _file(BENCHMARKS["bouc-wen"].files[0].path)
            table = read_table(path)
            u, y = table["u"], table["y"]
            fs = float(np.asarray(table["fs"]).ravel()[0])
        elif part in ("sinesweep", "validation"):
            path = _file(BENCHMARKS["bouc-wen"].files[1].path)
            u = read_table(path)["uval_sinesweep"]
            y = read_table(_file(BENCHMARKS["bouc-wen"].files[2].path))["yval_sinesweep"]
            fs = 750.0
        else:
            raise InputError(f"unknown bouc-wen part {part!r}; use train (the multisine) or sinesweep")
        return Record(
            f=np.asarray(u, dtype=float).ravel(),
            z=np.asarray(y, dtype=float).ravel(),
            fs=fs,
            meta={
                "source": str(path),
                "citation": citation,
                "force_hold": "sampled",
                "force_hold_source": "dataset",
                "mass": BOUC_WEN_REFERENCE["mass"],
                "reference": BOUC_WEN_REFERENCE,
            },
        )
    if name == "silverbox":
        path = _file(BENCHMARKS["silverbox"].files[0].path)
        table = read_table(path)
        u = np.asarray(table["V1"], dtype=float).ravel()
        y = np.asarray(table["V2"], dtype=float).ravel()
        if part in SILVERBOX_PARTS:
            start, stop = SILVERBOX_PARTS["estimation"]
            u0, y0 = u[start:stop].mean(), y[start:stop].mean()  # the estimation part's means, for every part
        else:
            u0, y0 = u.mean(), y.mean()
        record = Record(
            f=u - u0,
            z=y - y0,
            fs=SILVERBOX_FS,
            units={"f": "V", "z": "V", "v": "V/s", "a": "V/s^2"},
            meta={
                "source": str(path),
                "citation": "T. Wigren, J. Schoukens, Three free data sets for development and benchmarking "
                "in nonlinear system identification, ECC 2013",
                "arrow_samples": SILVERBOX_ARROW,
            },
        )
        if part in SILVERBOX_PARTS:
            start, stop = SILVERBOX_PARTS[part]
            return record[start:stop].with_meta(part=part, indices=[start, stop])
        if part == "all":
            return record
        if part == "arrow":
            return record[:SILVERBOX_ARROW]
        if part == "multisine":
            return record[SILVERBOX_ARROW:].with_meta(
                note="deprecated for estimation: samples [40000:) hold the end of the arrow head (a test set); "
                "use part 'estimation'"
            )
        hint = did_you_mean(part, [*SILVERBOX_PARTS, "all", "arrow", "multisine"])
        raise InputError(
            f"unknown silverbox part {brief(part)}{hint}; "
            f"use {', '.join(SILVERBOX_PARTS)} (the benchmark's split), or all, arrow, multisine (deprecated)"
        )
    raise InputError(f"unknown dataset {brief(name)}{did_you_mean(name, DATASETS)}; available: {', '.join(DATASETS)}")
