"""The residual of a structure's force balance, DOF by DOF: ``f - M a - R_hat(z, v)``.

It is formed on the balance samples every structure fit uses
(:func:`nlid.estimation.structure_regression.structure_regression_data`): the record's own
channels when velocity and acceleration were measured, else every channel
through the one shared zero-phase filter at ``fc`` (one cut-off for every
DOF), each element's force evaluated on the motion in the wider regressor band
before the low-pass, a held force given the hold's response, and the unsettled
ends dropped. So the residual of the model that generated a record is the
record's noise, not a filtering mismatch.

:func:`residual` gives the residual of a structure on a record and its two
scores per DOF, as for one DOF (:mod:`nlid.scoring`): ``eps_percent`` =
``100 RMS(R_e - R_hat) / RMS(R_e)`` with ``R_e = f - M a`` (Eq. 26 for each
DOF) and ``force_residual_percent`` relative to the RMS of the force on the
driven DOFs (``nan`` on a DOF no force acts on). :func:`residual_on` is the
same on balance samples already at hand.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .structure_regression import StructureRegressionData, structure_regression_data

if TYPE_CHECKING:  # pragma: no cover
    from ..data.record import Record
    from ..model.structure import StructuralModel

__all__ = ["StructureResidual", "residual", "residual_on", "restoring_on"]


@dataclass(frozen=True)
class StructureResidual:
    """The residual of a structure on a record, per DOF.

    Attributes
    ----------
    data
        The balance samples it was formed on.
    measured
        ``R_e = f - M a`` (N), ``(N, n)``.
    fitted
        ``R_hat(z, v)`` of the model (N), ``(N, n)``.
    eps_percent, force_residual_percent
        The scores per DOF (module docstring).
    """

    data: StructureRegressionData
    measured: np.ndarray
    fitted: np.ndarray
    eps_percent: tuple[float, ...]
    force_residual_percent: tuple[float, ...]

    @property
    def values(self) -> np.ndarray:
        """``R_e - R_hat`` (N), ``(N, n)``."""
        return self.measured - self.fitted


def restoring_on(model: StructuralModel, data: StructureRegressionData) -> np.ndarray:
    """``R_hat = K z + C v + s + sum_e b_e theta_e G_e`` on balance samples, ``(N, n)``.

    ``data.G`` must be the regressors of ``model.elements``
    (:meth:`~nlid.estimation.structure_regression.StructureRegressionData.with_elements`).
    """
    out = data.z @ model.K.T + data.v @ model.C.T + model.static
    if len(model.elements):
        out = out + (data.G * model.theta) @ model.elements.B.T
    return out


def residual_on(model: StructuralModel, data: StructureRegressionData) -> StructureResidual:
    """The residual and its scores (module docstring) on balance samples whose ``G`` are the model's elements'."""
    measured = data.f - data.a @ model.M.T
    fitted = restoring_on(model, data)
    diff = measured - fitted
    rms = lambda x: np.sqrt(np.mean(x**2, axis=0))  # noqa: E731
    scale, force = rms(measured), rms(data.f)
    eps = np.where(scale > 0, 100.0 * rms(diff) / np.where(scale > 0, scale, 1.0), np.nan)
    rel = np.where(force > 0, 100.0 * rms(diff) / np.where(force > 0, force, 1.0), np.nan)
    return StructureResidual(data, measured, fitted, tuple(map(float, eps)), tuple(map(float, rel)))


def residual(model: StructuralModel, record: Record, *, cutoff: float | None = None) -> StructureResidual:
    """The residual ``f - M a - R_hat(z, v)`` of a structure on a record, per DOF, with its scores.

    Parameters
    ----------
    model
        The structure.
    record
        The data.
    cutoff
        The balance filter's cut-off (Hz) when a channel is estimated; default
        :meth:`~nlid.data.record.Record.suggest_cutoff`.
    """
    return residual_on(model, structure_regression_data(record, model.elements, cutoff=cutoff))
