"""Where an identified model came from: enough to identify it again from its JSON alone.

:func:`nlid.identify` stores a provenance in the model
(:attr:`IdentifiedModel.provenance <nlid.identified.model.IdentifiedModel.provenance>`,
the ``"provenance"`` key of :meth:`~nlid.identified.model.IdentifiedModel.to_dict`)::

    {
      "nlid_version": "0.1.0",
      "data": {
        "source": "rig.csv",              # a path, "dataset:emps", "DataFrame", "mapping" or meta["source"]
        "sha256": "9f2c...",              # of the file when read from one, else of the record's samples
        "sha256_of": "file",              # "file" or "record"
        "record_sha256": "51ab...",       # of the samples identified (record_sha256 below), always
        "as_loaded": true,                # the samples the file gave (false: sliced, resampled... after loading)
        "columns": "t=time,f=load,z[mm]=disp",   # the column map as given (or null)
        "fs_given": null,                 # fs= as given to the loader (null: from the time column)
        "units": {"z": {"unit": "mm", "si": "m", "factor": 0.001}, "f": {"unit": "N", ...}, ...},
        "samples": 20480, "fs": 2048.0, "t0": 0.0, "channels": ["f", "z"],
        "force_hold": "sampled", "channel_sources": {"f": "measured", "z": "measured"}
      },
      "identify": {
        "method": "rfs", "terms": ["z^2", "z^3", "v*|v|"], "without": [], "mass": 0.2,
        "options": {...}, "px_roots": null, "px_tol": 0.0001, "px_max_iter": 30, "cutoff": null
      }
    }

Identifying again
-----------------
From a file (or ``dataset:NAME``): in Python ``nlid.identify(nlid.load(source,
columns=columns, fs=fs_given, units=...), terms, method, mass=mass,
options=options, without=without, px_roots=px_roots, px_tol=px_tol,
px_max_iter=px_max_iter, cutoff=cutoff)`` with the recorded values
(:func:`nlid.identification.replay.identify_again` does exactly this, after checking the hashes); on the
command line ``nlid identify`` with the same values
(:func:`nlid.cli.common.identify_command` writes that command). ``sha256``
says whether the file is the same; ``as_loaded`` false warns that the record
was changed after loading (a slice, a decimation, estimated channels:
``samples``, ``t0`` and ``channel_sources`` say which), so the file alone
does not give the same samples. The result has the same
coefficients, to the last bits a different CPU's BLAS may change.

The record's SHA-256
--------------------
The SHA-256 of a record (:func:`nlid.data.digest.record_sha256`) hashes a record's samples in a canonical byte order,
so that any language can recompute it: the ASCII text ``nlid.Record/1`` and a
newline; ``fs`` and ``t0`` as two little-endian IEEE-754 float64; then for
each channel present, in the order ``f, z, v, a``, its name in ASCII, a zero
byte, and its samples as little-endian float64 (SI units, after any
conversion). In numpy::

    h = hashlib.sha256(b"nlid.Record/1\\n" + np.array([fs, t0], "<f8").tobytes())
    for name in ("f", "z", "v", "a"):        # those present
        h.update(name.encode() + b"\\0" + np.asarray(x[name], "<f8").tobytes())
"""

from __future__ import annotations

import sys
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from ..data.checks import CHANNELS
from ..data.digest import record_sha256
from ..data.forcehold import force_hold_source
from ..data.record import Record
from ..data.units import SI, VOCABULARY
from ..model.terms import DEFAULT_TERMS, Model

if TYPE_CHECKING:  # pragma: no cover
    from ..model.elements import ElementSet

__all__ = [
    "data_provenance",
    "identify_provenance",
    "structure_provenance",
]


def _units(record: Record) -> dict[str, dict[str, Any]]:
    """Every channel's unit as given, what it became, and the factor applied."""
    given = dict(record.meta.get("input_units") or {})
    out = {}
    for channel in ("t", *CHANNELS):
        if channel in given:
            out[channel] = dict(given[channel])
        else:
            label = record.units.get(channel, SI[channel])
            known = {u.symbol for u in VOCABULARY[channel]}
            out[channel] = {"unit": label if label in known else SI[channel], "si": label, "factor": 1.0}
    return out


def data_provenance(record: Record) -> dict[str, Any]:
    """What identifies a record and how it was read (the ``"data"`` part of a provenance).

    A structure's (an indexed record's, :attr:`Record.indexed <nlid.data.record.Record.indexed>`) has no
    ``units`` and no ``force_hold_source``, and its ``as_loaded`` is true for a record not read from a file
    (one DOF's is null): the layout each has always written.
    """
    loaded = dict(record.meta.get("loaded") or {})
    digest = record_sha256(record)
    file_hash = loaded.get("sha256")
    at_load = loaded.get("record_sha256")
    indexed = record.indexed
    return {
        "source": loaded.get("source") or record.meta.get("source"),
        "sha256": file_hash or digest,
        "sha256_of": "file" if file_hash else "record",
        "record_sha256": digest,
        "as_loaded": (at_load in (None, digest)) if indexed else (None if at_load is None else at_load == digest),
        "columns": loaded.get("columns"),
        "fs_given": loaded.get("fs"),
        **({} if indexed else {"units": _units(record)}),
        "samples": record.n,
        "fs": record.fs,
        "t0": record.t0,
        "channels": list(record.channels),
        "force_hold": record.force_hold,
        **({} if indexed else {"force_hold_source": force_hold_source(record.meta)}),
        "channel_sources": {c: record.source_of(c) for c in record.channels},
    }


def _version() -> str:
    return str(sys.modules["nlid"].__version__)  # the package has initialised before any of its modules runs


def identify_provenance(
    record: Record,
    given: Model,
    *,
    method: str,
    mass: float | None,
    options: Mapping[str, Any],
    px_tol: float,
    px_max_iter: int,
    cutoff: float | None,
) -> dict[str, Any]:
    """The provenance :func:`nlid.identify` stores: the nlid version, the data and the call.

    Parameters
    ----------
    record
        The record identified.
    given
        The model as given (before ``px(z)`` iteration or shape refinement).
    method, mass, options, px_tol, px_max_iter, cutoff
        As passed to :func:`nlid.identify` (``options``: the identifier's
        resolved settings).
    """
    names = list(given.names)
    call = {
        "method": method,
        "terms": [n for n in names if n not in DEFAULT_TERMS],
        "without": [d for d in DEFAULT_TERMS if d not in names],
        "mass": mass,
        "options": dict(options),
        "px_roots": None if given.px_roots is None else list(given.px_roots),
        "px_tol": px_tol,
        "px_max_iter": px_max_iter,
        "cutoff": cutoff,
    }
    return {"nlid_version": _version(), "data": data_provenance(record), "identify": call}


def structure_provenance(
    record: Record, elements: ElementSet, *, method: str, mass: np.ndarray | None, options: Mapping[str, Any]
) -> dict[str, Any]:
    """The provenance :func:`nlid.identify` stores for a structure: the nlid version, the data and the call.

    Parameters
    ----------
    record
        The indexed record identified.
    elements
        The elements as given.
    method, mass, options
        The identifier's name, the mass matrix given (``None``: estimated) and its resolved settings.
    """
    call = {
        "method": method,
        "elements": list(elements.names),
        "static": elements.static,
        "mass": None if mass is None else np.asarray(mass).tolist(),
        "options": dict(options),
    }
    return {"nlid_version": _version(), "data": data_provenance(record), "identify": call}
