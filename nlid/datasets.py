"""Loaders for measured benchmark records (nonlinearbenchmark.org).

The files are not shipped with nlid: they are read from the folder named by
the environment variable ``NLID_DATA_DIR`` (holding ``emps/`` and
``silverbox/``). Cite the original authors in any report that uses them.

``emps`` (Janot, Gautier, Brunot 2019)
    Electro-mechanical positioning system in closed loop, 1 kHz, 24 841
    samples. ``f = gtau * vir`` (N, motor force), ``z = qm`` (m). Velocity and
    acceleration are not measured. Reference (IDIM-LS): M = 95.1 kg,
    Fv = 203.5 N s/m, Fc = 20.4 N, offset -3.16 N, residual about 4 %.
``silverbox`` (Wigren & Schoukens 2013)
    Electronic Duffing oscillator ``m y'' + d y' + (a + b y^2) y = u``;
    ``f = V1``, ``z = V2`` in volts (means removed, as the benchmark notes
    prescribe), fs = 10^7 / 2^14 = 610.35 Hz, 131 072 samples. The first
    40 000 samples are the "arrow head" (Gaussian noise of growing amplitude,
    customarily the test set); the rest are odd random-phase multisines.
"""

from __future__ import annotations

import os
from difflib import get_close_matches
from pathlib import Path

import numpy as np

from .errors import DataError, InputError
from .io import read_table
from .record import Record

__all__ = ["DATA_ENV", "data_dir", "load", "DATASETS", "SILVERBOX_FS", "SILVERBOX_ARROW", "BOUC_WEN_REFERENCE", "EMPS_REFERENCE"]

#: Environment variable naming the data folder.
DATA_ENV = "NLID_DATA_DIR"
#: Silverbox sampling frequency (Hz).
SILVERBOX_FS = 1e7 / 2**14
#: Number of samples of the Silverbox "arrow head" (test) section.
SILVERBOX_ARROW = 40_000

DATASETS = {
    "emps": "EMPS positioning stage, Coulomb friction (emps/DATA_EMPS.mat)",
    "silverbox": "Silverbox electronic Duffing oscillator (silverbox/SNLS80mV.mat)",
    "bouc-wen": "Bouc-Wen hysteretic oscillator (boucwen/train_multisine.mat; part 'sinesweep': the validation set)",
}

#: The Bouc-Wen benchmark's own model (Noel & Schoukens 2016): m y'' + c y' + k y + z = u,
#: z' = alpha y' - beta (gamma |y'| z + delta y' |z|) with m = 2 kg, c = 10 N s/m, k = 5e4 N/m,
#: alpha = 5e4 N/m, beta = 1e3 1/m, gamma = 0.8, delta = -1.1, nu = 1: in nlid's terms
#: alpha * bouc_wen(beta gamma, beta delta) with w = z / alpha (see nlid.terms.memory).
BOUC_WEN_REFERENCE = {
    "mass": 2.0,
    "coefficients": {"z": 5e4, "v": 10.0, "bouc_wen(800, -1100)": 5e4},
    "published_rms_error_m": {"pnlss_multisine": 1.2e-5, "neural_block_oriented_multisine": 4.5e-5, "linear": 2e-4},
}

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
        raise DataError(f"set {DATA_ENV} to the folder that holds the measured data (emps/, silverbox/)")
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
        ``"emps"``, ``"silverbox"`` or ``"bouc-wen"``.
    part
        For ``silverbox``: ``"all"``, ``"arrow"`` (first 40 000 samples, the
        customary test set) or ``"multisine"`` (the rest, the customary
        estimation set). For ``bouc-wen``: ``"train"`` (= ``"all"``, the
        5-period multisine, 40 960 samples) or ``"sinesweep"`` (the
        validation set, 153 000 samples). Only ``"all"`` for ``emps``.

    Returns
    -------
    Record
        With ``meta["source"]``, ``meta["citation"]`` and, for ``emps``, the
        benchmark's reference values in ``meta["reference"]``.
    """
    if name == "emps":
        if part != "all":
            raise InputError("the emps record has no parts; use part='all'")
        path = _file("emps/DATA_EMPS.mat")
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
    if name in ("bouc-wen", "boucwen"):
        citation = (
            "J.P. Noel, M. Schoukens, Hysteretic benchmark with a dynamic nonlinearity, "
            "Nonlinear System Identification Benchmarks, 2016"
        )
        if part in ("all", "train", "multisine"):
            path = _file("boucwen/train_multisine.mat")
            table = read_table(path)
            u, y = table["u"], table["y"]
            fs = float(np.asarray(table["fs"]).ravel()[0])
        elif part in ("sinesweep", "validation"):
            path = _file("boucwen/uval_sinesweep.mat")
            u = read_table(path)["uval_sinesweep"]
            y = read_table(_file("boucwen/yval_sinesweep.mat"))["yval_sinesweep"]
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
                "mass": BOUC_WEN_REFERENCE["mass"],
                "reference": BOUC_WEN_REFERENCE,
            },
        )
    if name == "silverbox":
        path = _file("silverbox/SNLS80mV.mat")
        table = read_table(path)
        u = np.asarray(table["V1"], dtype=float).ravel()
        y = np.asarray(table["V2"], dtype=float).ravel()
        record = Record(
            f=u - u.mean(),
            z=y - y.mean(),
            fs=SILVERBOX_FS,
            units={"f": "V", "z": "V", "v": "V/s", "a": "V/s^2"},
            meta={
                "source": str(path),
                "citation": "T. Wigren, J. Schoukens, Three free data sets for development and benchmarking "
                "in nonlinear system identification, ECC 2013",
                "arrow_samples": SILVERBOX_ARROW,
            },
        )
        if part == "all":
            return record
        if part == "arrow":
            return record[:SILVERBOX_ARROW]
        if part == "multisine":
            return record[SILVERBOX_ARROW:]
        raise InputError(f"unknown silverbox part {part!r}; use all, arrow or multisine")
    hint = get_close_matches(name, list(DATASETS), n=1)
    raise InputError(
        f"unknown dataset {name!r}"
        + (f" (did you mean {hint[0]!r}?)" if hint else "")
        + f"; available: {', '.join(DATASETS)}"
    )
