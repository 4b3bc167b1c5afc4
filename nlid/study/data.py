"""The records and the reference of one run, rebuilt from its spec in the worker.

Simulated datasets are simulated from the preset with the run's seed (the
held-out record, when ``holdout = "independent"``, with its own seed: an
independent force of the same kind). Measured datasets are read through
:func:`nlid.datasets.load` or :func:`nlid.io.read_record`. The reference
("truth") is the preset's (coefficients, mass, and the equilibria and modal
parameters of the true model, Eq. 8 and 22), else the study's ``reference``
table, else the record's ``meta["reference"]`` (e.g. the EMPS benchmark's
published values).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from .. import physics
from ..record import Record
from ..terms import Model

__all__ = ["RunData", "build_data"]


@dataclass(frozen=True)
class RunData:
    """Estimation record, optional held-out record, and the reference.

    Attributes
    ----------
    reference
        ``{"coefficients", "mass", "equilibria", "modal", "terms", "px_roots"}``;
        any entry may be ``None`` when unknown.
    """

    record: Record
    heldout: Record | None
    reference: dict[str, Any]
    mass: float | None


def _preset(ds: dict[str, Any]):
    from ..presets import get_preset

    preset = get_preset(ds["source"])
    overrides = dict(ds["overrides"])
    if "band" in overrides and isinstance(overrides["band"], list):
        overrides["band"] = tuple(overrides["band"])
    return preset.with_overrides(**overrides) if overrides else preset


def _load(ds: dict[str, Any], part: str) -> Record:
    if ds["kind"] == "dataset":
        from .. import datasets

        return datasets.load(ds["source"], part=part)
    from ..io import read_record

    return read_record(ds["source"], ds["columns"], fs=ds["fs"])


def build_data(spec: dict[str, Any]) -> RunData:
    """Build the records of a run and its reference values."""
    ds = spec["dataset"]
    reference: dict[str, Any] = {
        "coefficients": None,
        "mass": None,
        "equilibria": None,
        "modal": None,
        "terms": None,
        "px_roots": None,
    }
    if ds["kind"] == "preset":
        preset = _preset(ds)
        record = preset.simulate(spec["seed"], noise=ds["noise"], channels=tuple(ds["channels"]))
        heldout = None
        if ds["holdout"] == "independent":
            heldout = preset.simulate(spec["holdout_seed"], noise=ds["noise"], channels=tuple(ds["channels"]))
        truth = record.meta["truth"]
        model = preset.model()
        z_range = (float(record.z.min()), float(record.z.max()))
        eq = physics.equilibria(model, truth["coefficients"], z_range)
        modal = physics.modal(model, truth["coefficients"], truth["mass"], z_range=z_range)
        reference.update(
            coefficients=dict(truth["coefficients"]),
            mass=float(truth["mass"]),
            equilibria=list(eq.stable),
            modal=[{"fn_hz": m.fn_hz, "zeta": m.zeta} for m in modal],
            terms=list(model.names),
            px_roots=truth.get("px_roots"),
        )
    else:
        record = _load(ds, ds["part"])
        heldout = None
        if isinstance(ds["holdout"], float):
            record, heldout = record.split(ds["holdout"])
        elif ds["holdout"] not in ("none", "independent"):
            heldout = _load(ds, ds["holdout"])
        meta_ref = record.meta.get("reference")
        if meta_ref:
            reference.update(
                coefficients=dict(meta_ref.get("coefficients") or {}) or None,
                mass=meta_ref.get("mass"),
            )
    if ds.get("reference"):
        for key, value in ds["reference"].items():
            reference[key] = value
    mass_spec = ds["mass"]
    if mass_spec == "known":
        mass = reference["mass"] if reference["mass"] is not None else record.mass
    elif mass_spec == "estimate":
        mass = None
    else:
        mass = float(mass_spec)
    return RunData(record, heldout, reference, None if mass is None else float(mass))


def reference_model(reference: dict[str, Any]) -> Model | None:
    """The true model of a simulated reference (``None`` for measured data)."""
    if not reference.get("terms"):
        return None
    return Model.from_spec(reference["terms"], defaults=False, px_roots=reference.get("px_roots"))
