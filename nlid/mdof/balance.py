"""The force balance of a structure on a record, DOF by DOF: ``f - M a = R(z, v)``.

:func:`balance` gives the samples the balance is formed on: the record's own
channels when velocity and acceleration were measured, else every channel
through the one shared zero-phase filter (:mod:`nlid.derivatives`: the
missing ones differentiated, the others low-passed at the same cut-off, one
cut-off for every DOF), with the ``EDGE_PERIODS * fs / fc`` samples at each
end dropped where the filters have not settled (as
:func:`nlid.balance.regression_data` does for one DOF).

:func:`residual` is the residual ``f - M a - R_hat(z, v)`` of a structure per
DOF, and its two scores per DOF, as for one DOF (:mod:`nlid.scoring`):
``eps_percent`` = ``100 RMS(R_e - R_hat) / RMS(R_e)`` with ``R_e = f - M a``
(Eq. 26 for each DOF) and ``force_residual_percent`` relative to the RMS of
the force on the driven DOFs (``nan`` on a DOF no force acts on).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .. import derivatives
from ..balance import EDGE_PERIODS
from ..validate import check_cutoff

if TYPE_CHECKING:  # pragma: no cover
    from .model import StructuralModel
    from .record import StructureRecord

__all__ = ["Balance", "balance", "StructureResidual", "residual"]


@dataclass(frozen=True)
class Balance:
    """The samples of a structure's force balance, each ``(N, n)``.

    Attributes
    ----------
    z, v, a, f
        Displacement, velocity, acceleration and force per DOF.
    cutoff
        The shared filter's cut-off (Hz), ``None`` when every channel was measured.
    trimmed
        Samples dropped at each end.
    """

    z: np.ndarray
    v: np.ndarray
    a: np.ndarray
    f: np.ndarray
    cutoff: float | None
    trimmed: int


def balance(record: StructureRecord, *, cutoff: float | None = None) -> Balance:
    """The force-balance samples of a record (module docstring).

    Parameters
    ----------
    record
        The data.
    cutoff
        The shared filter's cut-off (Hz) when a channel is estimated; default
        :meth:`StructureRecord.suggest_cutoff`.
    """
    check_cutoff(cutoff, record.fs)
    if record.v is not None and record.a is not None and cutoff is None:
        return Balance(record.z, record.v, record.a, record.f, None, 0)
    fc = record.suggest_cutoff() if cutoff is None else float(cutoff)
    fs = record.fs
    full = record.with_derivatives(cutoff=fc)
    measured = {g: [k for k in range(record.n_dofs) if full.is_measured(f"{g}{k + 1}")] for g in ("v", "a")}
    out = {"z": derivatives.lowpass(record.z, fs, fc), "f": derivatives.lowpass(record.f, fs, fc)}
    for g in ("v", "a"):
        arr = np.array(getattr(full, g))
        if measured[g]:
            arr[:, measured[g]] = derivatives.lowpass(arr[:, measured[g]], fs, fc)
        out[g] = arr
    trim = min(int(math.ceil(EDGE_PERIODS * fs / fc)), (record.n - 2) // 4)
    cut = slice(trim, record.n - trim)
    return Balance(out["z"][cut], out["v"][cut], out["a"][cut], out["f"][cut], fc, trim)


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

    data: Balance
    measured: np.ndarray
    fitted: np.ndarray
    eps_percent: tuple[float, ...]
    force_residual_percent: tuple[float, ...]

    @property
    def values(self) -> np.ndarray:
        """``R_e - R_hat`` (N), ``(N, n)``."""
        return self.measured - self.fitted


def residual(model: StructuralModel, record: StructureRecord, *, cutoff: float | None = None) -> StructureResidual:
    """The residual ``f - M a - R_hat(z, v)`` of a structure on a record, per DOF, with its scores."""
    data = balance(record, cutoff=cutoff)
    measured = data.f - data.a @ model.M.T
    fitted = model.restoring(data.z, data.v)
    diff = measured - fitted
    rms = lambda x: np.sqrt(np.mean(x**2, axis=0))  # noqa: E731
    scale, force = rms(measured), rms(data.f)
    eps = np.where(scale > 0, 100.0 * rms(diff) / np.where(scale > 0, scale, 1.0), np.nan)
    rel = np.where(force > 0, 100.0 * rms(diff) / np.where(force > 0, force, 1.0), np.nan)
    return StructureResidual(data, measured, fitted, tuple(map(float, eps)), tuple(map(float, rel)))
