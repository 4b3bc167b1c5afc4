"""Restoring-force-surface identification by least squares.

The restoring force of Eq. 25, ``R_e = f - m z''``, is regressed on the
model's terms: ``R_e(t_k) = sum_i theta_i g_i(z_k, v_k) + e_k``. With the mass
unknown the inertia column is added and ``f = m a + G theta`` is solved
instead (as the IDIM-LS reference method of the EMPS benchmark does).

Derivatives come from the record when measured, otherwise from nlid's
zero-phase differentiating filter; when a channel is estimated, the force, the
acceleration and every regressor pass through the same zero-phase low-pass and
the unsettled ends are dropped (:func:`nlid.model.physics.regression_data`), so no
phase error enters. ``decimate`` then keeps every q-th equation: the equations
are already band-limited, so this only trades samples for speed.

Standard errors (see :mod:`nlid.estimation.regression`): the reported ones are batch-means
sandwich errors, valid for a stationary equation error that may be coloured
(as it is after the low-pass) and heteroscedastic, with exact regressors. The
classical ``s^2 (X^T X)^-1`` values, valid only for independent identically
distributed errors, are in ``diagnostics["standard_errors_iid"]``. Neither
covers bias from noise on the regressors (errors-in-variables) or from
evaluating a nonlinear damping term on a band-limited velocity; see
``docs/rfs.md`` for what that means on the paper's example.

Near-collinear terms (|correlation| >= 0.99 on the record) are reported as
warnings naming the pair, and non-smooth velocity terms (``sign(v)``...) when
the band-limited velocity misses a noticeable part of the velocity reversals
(:func:`nlid.estimation.regression.nonsmooth_warnings`).

Several degrees of freedom (``dofs = "multi"``): an
indexed :class:`~nlid.plugin.Record` is identified by one joint least squares
of every DOF's force balance, the element coefficients shared between the
DOFs they connect and ``K``, ``C`` estimated with them
(:mod:`nlid_rfs.structure`).
"""

from __future__ import annotations

import numpy as np

from nlid.plugin import (
    CHANNEL_SOURCES,
    ElementSet,
    Estimate,
    IdentificationError,
    Identifier,
    Model,
    Option,
    Record,
    StructureEstimate,
    collinearity_warnings,
    least_squares,
    nonsmooth_warnings,
    regression_data,
    source_entries,
)


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
    dofs = "multi"
    # first as the default: the most accurate measured on the paper's example (2 % noise on z only: z^3 0.03 %,
    # z^2 0.10 %, v*|v| 0.49 %) against the NSI targets of issue 3 (0.5 % and 1.5 %)
    preference = 10
    advice = (
        "first choice: least squares on the force balance, any model, estimates the mass, the fastest "
        "(~1 s per 60 s record); viscous damping biased (+1 to +8 % on paper-numerical) when v is "
        "differentiated from a noisy z"
    )
    advice_order = 10
    docs = "docs/rfs.md"

    def identify_structure(
        self, record: Record, elements: ElementSet, *, mass: np.ndarray | None = None
    ) -> StructureEstimate:
        """Estimate a structure's elements and linear system by one joint least squares (:mod:`nlid_rfs.structure`)."""
        from .structure import identify_structure

        return identify_structure(record, elements, mass, self.settings)

    def identify(self, record: Record, model: Model, *, mass: float | None = None) -> Estimate:
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
        if y.size <= X.shape[1]:
            raise IdentificationError(
                f"rfs: {y.size} equations for {X.shape[1]} unknowns after decimating by {q}; lower 'decimate'"
            )
        # the filtered equation error stays correlated over about fs / fc samples
        corr = 1.0 if data.filtered_at is None else record.fs / data.filtered_at / q
        fit = least_squares(X, y, names, correlation_length=corr, context="rfs: ")
        theta, se, se_iid = fit.coefficients, fit.standard_errors, fit.standard_errors_iid
        est_mass = mass_se = None
        if mass is None:
            est_mass, mass_se = float(theta[0]), float(se[0])
            if not est_mass > 0:
                raise IdentificationError(
                    f"rfs: the estimated mass is not positive ({est_mass:.4g} kg): is the force's sign reversed "
                    "against z (a force pushing z up must be positive)?"
                )
            theta, se, se_iid = theta[1:], se[1:], se_iid[1:]
        sign_fraction, nonsmooth = nonsmooth_warnings(model, data.v, record.fs, data.filtered_at)
        return Estimate(
            coefficients=model.as_dict(theta),
            mass=est_mass,
            standard_errors=model.as_dict(se),
            mass_standard_error=mass_se,
            warnings=collinearity_warnings(X, names) + nonsmooth,
            diagnostics={
                "condition_number": fit.condition_number,
                "samples_used": int(y.size),
                "decimate": q,
                "filtered_at_hz": data.filtered_at,
                "channels": data.provenance,
                CHANNEL_SOURCES: source_entries(data.sources),
                "mass_standard_error": mass_se,
                "standard_errors_iid": model.as_dict(se_iid),
                "standard_error_batches": fit.batches,
                "velocity_sign_disagreement": sign_fraction,
            },
        )
