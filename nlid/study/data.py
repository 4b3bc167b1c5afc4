"""The records and the reference of one run, rebuilt from its spec in the worker.

Simulated datasets are simulated from the preset with the run's seed (the
held-out record, when ``holdout = "independent"``, with its own seed: an
independent force of the same kind). Measured datasets are read through
:func:`nlid.data.datasets.load` or :func:`nlid.data.io.read_record`. The reference
("truth", :meth:`nlid.identified.reference.Reference.from_truth`) is the preset's
(coefficients, mass, and the equilibria and modal parameters of the true
model, Eq. 8 and 22), else the study's ``reference`` table, else the record's
``meta["reference"]`` (e.g. the EMPS benchmark's published values).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

from ..data.record import Record
from ..identified.reference import Reference
from ..scoring import record_period
from .values import FractionHoldout, IndependentHoldout, PartHoldout, PresetSource

if TYPE_CHECKING:
    from .plan import RunSpec

__all__ = ["RunData", "build_data"]


@dataclass(frozen=True)
class RunData:
    """Estimation record, optional held-out record, and the reference.

    Attributes
    ----------
    reference
        The :class:`~nlid.identified.reference.Reference` (any of its values may be
        unknown); its :meth:`~nlid.identified.reference.Reference.to_dict` is stored
        with the run.
    """

    record: Record
    heldout: Record | None
    reference: Reference
    mass: float | None


def build_data(spec: RunSpec) -> RunData:
    """Build the records of a run and its reference values."""
    ds = spec.dataset
    src = ds.source
    if isinstance(src, PresetSource):
        preset = src.preset()
        record = preset.simulate(spec.seed, noise=dict_or_level(src.noise), channels=src.channels)
        heldout = None
        if isinstance(ds.holdout, IndependentHoldout):
            heldout = preset.simulate(spec.holdout_seed, noise=dict_or_level(src.noise), channels=src.channels)
        z_range = (float(record.z.min()), float(record.z.max()))
        reference = Reference.from_truth(Reference.from_meta(record.meta), model=preset.model(), z_range=z_range)
    else:
        record = src.load()
        heldout = None
        if isinstance(ds.holdout, FractionHoldout):
            period, _ = record_period(record)  # a periodic record's held-out part keeps its period
            marked = record if period is None else record.with_meta(periodic=period)
            record, heldout = marked.split(ds.holdout.fraction)
        elif isinstance(ds.holdout, PartHoldout):
            heldout = src.load(ds.holdout.part)  # type: ignore[call-arg]
        meta_ref = Reference.from_meta(record.meta)
        # a measured benchmark's published coefficients and mass (its published scores are not compared)
        reference = Reference(coefficients=meta_ref.coefficients or None, mass=meta_ref.mass)
    if ds.reference:
        reference = reference.updated(ds.reference)
    mass = ds.mass.value(reference.mass, record.mass)
    return RunData(record, heldout, reference, None if mass is None else float(mass))


def dict_or_level(noise: Mapping[str, float] | float) -> dict[str, float] | float:
    """A preset's noise setting as :meth:`nlid.simulation.presets.Preset.simulate` takes it."""
    return dict(noise) if isinstance(noise, Mapping) else float(noise)
