"""Restoring-force-surface identification by least squares.

The restoring force of Eq. 25, ``R_e = f - m z''``, is regressed on the
model's terms: ``R_e(t_k) = sum_i theta_i g_i(z_k, v_k) + e_k``. With the mass
unknown the inertia column is added and ``f = m a + G theta`` is solved
instead (as the IDIM-LS reference method of the EMPS benchmark does).

Derivatives come from the record when measured, otherwise from nlid's
zero-phase differentiating filter; when the acceleration is estimated, the
force and every regressor pass through the same zero-phase low-pass
(:func:`nlid.physics.regression_data`), so no phase error enters.

Standard errors are ``sqrt(diag(s^2 (X^T X)^-1))`` with ``s^2`` the residual
variance: they hold for independent, identically distributed equation errors
and exact regressors, and are optimistic when the residual is coloured (after
low-pass filtering) or the regressors are noisy.
"""

from __future__ import annotations

import numpy as np

from nlid import IdentificationResult, Identifier, Option, Record
from nlid.errors import IdentificationError
from nlid.physics import regression_data
from nlid.terms import Model


class RestoringForceSurface(Identifier):
    """Least squares on the restoring-force surface (known or estimated mass)."""

    name = "rfs"
    summary = "restoring-force-surface least squares: regress f - m a on the model's terms"
    options = (
        Option(
            "cutoff",
            "float",
            None,
            "low-pass cut-off (Hz) of the differentiating filter for estimated channels",
            nullable=True,
            minimum=0.0,
        ),
        Option("decimate", "int", 1, "keep every q-th sample after the common zero-phase filtering", minimum=1),
    )
    needs_mass = False

    def identify(self, record: Record, model: Model, *, mass: float | None = None) -> IdentificationResult:
        """Estimate the coefficients (and the mass if not given) by least squares."""
        data = regression_data(record, model, cutoff=self.settings["cutoff"])
        q = self.settings["decimate"]
        G = data.G[::q]
        if mass is None:
            X = np.column_stack([data.a[::q], G])
            y = data.f[::q]
            names = ["mass", *model.names]
        else:
            X = G
            y = data.restoring_force(mass)[::q]
            names = list(model.names)
        scale = np.sqrt(np.mean(X**2, axis=0))
        if np.any(scale == 0):
            zero = [names[i] for i in np.flatnonzero(scale == 0)]
            raise IdentificationError(f"rfs: the regressor(s) {', '.join(zero)} are identically zero on this record")
        Xs = X / scale
        sol, _, rank, sv = np.linalg.lstsq(Xs, y, rcond=None)
        if rank < Xs.shape[1]:
            raise IdentificationError(f"rfs: the regressor matrix is rank deficient (rank {rank} of {Xs.shape[1]})")
        theta = sol / scale
        resid = y - X @ theta
        dof = max(y.size - X.shape[1], 1)
        s2 = float(resid @ resid) / dof
        cov = s2 * np.linalg.inv(Xs.T @ Xs) / np.outer(scale, scale)
        se = np.sqrt(np.diag(cov))
        est_mass = None
        if mass is None:
            est_mass = float(theta[0])
            if not est_mass > 0:
                raise IdentificationError(f"rfs: the estimated mass is not positive ({est_mass:.4g} kg)")
            theta, se = theta[1:], se[1:]
        return IdentificationResult(
            method=self.name,
            coefficients=model.as_dict(theta),
            mass=est_mass,
            standard_errors=model.as_dict(se),
            diagnostics={
                "condition_number": float(sv[0] / sv[-1]),
                "samples_used": int(y.size),
                "filtered_at_hz": data.filtered_at,
                "channels": data.provenance,
                "mass_standard_error": None if mass is not None else float(np.sqrt(cov[0, 0])),
            },
        )
