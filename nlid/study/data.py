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

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from .. import physics
from ..record import Record
from ..terms import Model
from .plan import RunSpec
from .values import FractionHoldout, IndependentHoldout, PartHoldout, PresetSource

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


def build_data(spec: RunSpec) -> RunData:
    """Build the records of a run and its reference values."""
    ds = spec.dataset
    src = ds.source
    reference: dict[str, Any] = {
        "coefficients": None,
        "mass": None,
        "equilibria": None,
        "modal": None,
        "terms": None,
        "px_roots": None,
    }
    if isinstance(src, PresetSource):
        preset = src.preset()
        record = preset.simulate(spec.seed, noise=dict_or_level(src.noise), channels=src.channels)
        heldout = None
        if isinstance(ds.holdout, IndependentHoldout):
            heldout = preset.simulate(spec.holdout_seed, noise=dict_or_level(src.noise), channels=src.channels)
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
        record = src.load()
        heldout = None
        if isinstance(ds.holdout, FractionHoldout):
            record, heldout = record.split(ds.holdout.fraction)
        elif isinstance(ds.holdout, PartHoldout):
            heldout = src.load(ds.holdout.part)  # type: ignore[call-arg]
        meta_ref = record.meta.get("reference")
        if meta_ref:
            reference.update(
                coefficients=dict(meta_ref.get("coefficients") or {}) or None,
                mass=meta_ref.get("mass"),
            )
    if ds.reference:
        for key, value in ds.reference.items():
            reference[key] = value
    mass = ds.mass.value(reference["mass"], record.mass)
    return RunData(record, heldout, reference, None if mass is None else float(mass))


def dict_or_level(noise: Mapping[str, float] | float) -> dict[str, float] | float:
    """A preset's noise setting as :meth:`nlid.presets.Preset.simulate` takes it."""
    return dict(noise) if isinstance(noise, Mapping) else float(noise)


def reference_model(reference: dict[str, Any]) -> Model | None:
    """The true model of a simulated reference (``None`` for measured data)."""
    if not reference.get("terms"):
        return None
    return Model.from_spec(reference["terms"], defaults=False, px_roots=reference.get("px_roots"))
