"""Identify again from a model's provenance: the same data, terms, method and options.

:func:`identify_again` reads the data a model's ``provenance`` names
(:func:`nlid.identification.provenance.identify_provenance`), checks that they are the
samples identified (their SHA-256, :func:`nlid.data.digest.record_sha256`), and
runs the same identification.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from ..data.digest import record_sha256
from ..data.io import check_path, file_sha256
from ..data.sources import as_record
from ..errors import InputError
from ..identified.fileformat import check_provenance
from ..identified.model import IdentifiedModel
from .pipeline import identify

__all__ = ["identify_again"]


def identify_again(provenance: Mapping[str, Any], source: Any = None) -> IdentifiedModel:
    """Identify again from a provenance (:attr:`IdentifiedModel.provenance`), reading the data it names.

    Parameters
    ----------
    provenance
        A model's provenance, e.g. ``IdentifiedModel.from_dict(json.load(f)).provenance``.
    source
        The data, when the recorded source is not a file (a DataFrame, a
        mapping of arrays); default: the recorded source.

    Returns
    -------
    IdentifiedModel
        The model identified with the recorded column map, units, terms,
        method, options and mass.

    Raises
    ------
    InputError
        A provenance that does not fit its schema (:data:`nlid.identified.fileformat.PROVENANCE_FIELDS`: one line
        naming the field), a structure's provenance, a provenance without the data's source, or data whose
        SHA-256 is not the recorded one (another file, or a record changed after loading).
    DataError
        The recorded file is missing, a folder or not a regular file, or cannot be read.
    """
    if not isinstance(provenance, Mapping) or not provenance.get("data") or not provenance.get("identify"):
        raise InputError("the provenance lacks its 'data' or 'identify' part: it was not written by nlid.identify")
    check_provenance(provenance)
    data, call = dict(provenance["data"]), dict(provenance["identify"])
    if "elements" in call:
        raise InputError("this is a structure's provenance: identify_again replays one-DOF models (nlid.identify)")
    declared = {c: u["unit"] for c, u in (data.get("units") or {}).items() if u.get("factor") != 1.0}
    if source is None:
        source = data.get("source")
        bundled = str(source or "").startswith("dataset:")
        if not source or (data.get("sha256_of") != "file" and not bundled):
            raise InputError(f"the data came from {source or 'Python'}, not a file: give it as source=")
        if data.get("sha256_of") == "file" and not bundled and file_sha256(check_path(source)) != data["sha256"]:
            raise InputError(f"{source} has changed since the model was identified (its SHA-256 differs)")
    if str(source).startswith("dataset:"):
        record = as_record(source)
    else:
        record = as_record(source, columns=data.get("columns"), fs=data.get("fs_given"), units=declared or None)
    record = record.with_meta(force_hold=data.get("force_hold", record.force_hold))
    if record_sha256(record) != data.get("record_sha256"):
        raise InputError(
            "the data read do not give the samples identified (SHA-256 differs)"
            + ("; the record was changed after loading" if data.get("as_loaded") is False else "")
        )
    if not call.get("method"):
        raise InputError("the provenance names no method: it was not written by nlid.identify")
    return identify(
        record,
        list(call.get("terms") or ()),
        call["method"],
        mass=call.get("mass"),
        options=call.get("options") or None,
        without=list(call.get("without") or ()),
        px_roots=call.get("px_roots"),
        px_tol=float(call.get("px_tol", 1e-4)),
        px_max_iter=int(call.get("px_max_iter", 30)),
        cutoff=call.get("cutoff"),
        input_path=call.get("input_path"),
    )
