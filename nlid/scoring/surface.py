"""Slices of the identified restoring surface against the data (paper Fig. 21 b-d)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..estimation.balance import RegressionData
from ..model.physics import Coefficients, damping, dict_or_vector
from ..model.terms import Model

__all__ = ["DampingSlice", "damping_slice"]


@dataclass(frozen=True)
class DampingSlice:
    """The damping force near one position (paper Fig. 21 b-d).

    Attributes
    ----------
    z0, half_width
        The slice ``|z - z0| <= half_width`` (m).
    v
        Velocities of the samples in the slice (m/s).
    measured
        Their measured damping force ``R_e - K(z)`` (N): the restoring force
        minus the identified elastic part at each sample's own position,
        formed in the force balance's band (the stiffness columns of ``G``)
        so that a filtered balance does not leak the out-of-band part of
        ``K(z)`` into the damping force.
    v_grid, model
        The identified ``D(z0, v)`` on a velocity grid spanning the slice.
    """

    z0: float
    half_width: float
    v: np.ndarray
    measured: np.ndarray
    v_grid: np.ndarray
    model: np.ndarray


def damping_slice(
    data: RegressionData,
    model: Model,
    coefficients: Coefficients,
    mass: float,
    z0: float,
    half_width: float | None = None,
    grid: int = 200,
) -> DampingSlice:
    """Slice the restoring surface at ``z0`` to compare ``D`` with the data (Fig. 21 b-d).

    Parameters
    ----------
    data
        From :func:`nlid.estimation.balance.regression_data` (needs velocity: the model
        must have velocity terms).
    model, coefficients, mass
        The identified model.
    z0
        Position of the slice (m).
    half_width
        Half width of the slice; default 5 % of the displacement range.
    grid
        Number of velocity points of the model curve.
    """
    if data.v is None:
        raise InputError("a damping slice needs velocity: the model has no velocity-dependent term")
    theta = dict_or_vector(model, coefficients)
    if data.G.shape[1] != len(model):
        raise InputError(f"the force balance has {data.G.shape[1]} regressors but the model has {len(model)} terms")
    if half_width is None:
        half_width = 0.05 * float(np.ptp(data.z))
    near = np.abs(data.z - z0) <= half_width
    if near.sum() < 3:
        raise InputError(f"fewer than 3 samples within {half_width:.3g} m of z0 = {z0:.4g} m")
    v = data.v[near]
    stiff = [i for i, t in enumerate(model.terms) if t.family == "stiffness"]
    # K in the balance's band: the stiffness regressors of G (equal to K(z) when nothing is filtered)
    measured = data.restoring_force(mass)[near] - data.G[near][:, stiff] @ theta[stiff]
    v_grid = np.linspace(v.min(), v.max(), grid)
    curve = damping(model, theta, np.full(grid, float(z0)), v_grid)
    return DampingSlice(float(z0), float(half_width), v, measured, v_grid, curve)
