"""``nsi-shift``: NSI with the zero reference shifted to each stable equilibrium (paper Sec. 3.1).

Equations implemented (paper numbering)
---------------------------------------
* Sec. 3.1 / ref. [28]: ``x = z - z*`` at a stable equilibrium ``z*``; the
  polynomial stiffness is re-expanded in ``x`` so that the underlying-linear
  stiffness is ``K'(z*) > 0`` and NSI applies (Eq. 15 with ``fbar = f``);
* Eq. 16-17: extended inputs ``[f, -x^kmax, ..., -x^2, -g_j(x + z*, v)]`` (every
  power ``x^k``, ``k = 2..kmax``: ``z^3`` alone also needs ``x^2``; other terms
  re-centred), identified by PO-MOESP with interval-mean inputs, exact ZOH
  inverse;
* Eq. 18-20: the ULS eigenvalues (must be a stable pair), the extended FRF
  and the coefficients ``Re(H_E,j / Hbar)`` averaged over the band;
* the ``x`` coefficients map back to ``z`` by the Taylor shift
  ``theta_k = sum_j a_j C(j, k) (-z*)^(j - k)``; the constant from the static
  balance (as in nsi-ip);
* per-well modal parameters directly from that well's ULS eigenvalues (Eq. 18:
  ``f_n = |lambda| / 2 pi``, ``zeta = -Re(lambda) / |lambda|``).

Zero references (``equilibria = auto``)
    The stable equilibria are estimated from the data: first as the modes of
    the displacement histogram, taken as the maxima of a polynomial fit
    (degree ``kmax + 1``, weights ``sqrt(counts)``) to its logarithm - for a
    Boltzmann-like density ``log p = -U / D + const`` these are the minima of
    the potential. (The raw histogram peak of the shallow well of the paper's
    example is at 0.0114 m instead of 0.0173 m, where ``K' = 4 N/m``: the
    identification there fails.) Then each reference is moved to the fixed
    point of its own identified ``K(z)`` (the stable root nearest the
    reference), ``iterate`` identifications per well at most. Measured
    (prototype, 2 % noise, seeds 0-4): with the histogram references alone
    f_n+ is 4.2 % off and zeta+ 2.4 %; after the fixed point 0.14 % and
    1.6 %, the references within 0.1 % of the true equilibria.

Combined estimate (``combine``)
    The mean of the per-well coefficient sets (default): their errors partly
    cancel (prototype: z^3 0.017 % against 0.083 / 0.103 % per well, z^2
    0.147 % against 0.195 / 0.435 %). Both sets are in the diagnostics.

A known mass fixes ``m`` in each well's ULS fit.

With a measured acceleration and ``v`` derived from ``z`` (``acceleration =
fuse``, the default), the basis functions' ``z`` and ``v`` fuse ``z`` below
a crossover and ``a`` above it, as in nsi-ip
(:func:`nlid_nsi.reconstruction.fuse_motion`); an indefinite noise-corrected
Gram is projected onto the positive semi-definite matrices
(:func:`nlid_nsi.gram.clip_indefinite`; without it the fusion made the
damping worse here, docs/nsi.md).
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from nlid.plugin import (
    ElementSet,
    Estimate,
    FigureArray,
    IdentificationError,
    Identifier,
    Model,
    Option,
    Record,
    StructureEstimate,
    equilibria,
)

from .common import (
    COMMON_OPTIONS,
    HOLD_ASSUMED,
    blas_threads,
    check_length,
    figure_arrays,
    fit_arrays,
    fit_summary,
    force_hold,
    reconstruction,
    reconstruction_diagnostics,
    velocity_diagnostics,
    velocity_estimate,
    well_suffix,
)
from .wells import histogram_modes, taylor_shift

if TYPE_CHECKING:
    from .basis import Basis
    from .fit import NSIFit
    from .reconstruction import Reconstruction

# The numerical modules (scipy) are imported where they are used: loading the entry point imports no scipy.

__all__ = ["NSIZeroShift", "histogram_modes", "taylor_shift"]


class NSIZeroShift(Identifier):
    """NSI around each stable equilibrium with a shifted zero reference (Sec. 3.1).

    Implements the zero-reference shift ``x = z - z*`` of Sec. 3.1 with
    Eq. 15-17 (underlying-linear system plus extended inputs in x), 18 (the
    ULS of each well must be a stable pair; its eigenvalues give f_n and zeta
    per well) and 19-20 (coefficients as band-averaged ``Re(H_E,j / Hbar)``),
    then the Taylor shift back to z and the combination of the wells; details
    in the module docstring and ``docs/nsi.md``. The mass is estimated unless
    given.
    """

    name = "nsi-shift"
    summary = "nonlinear subspace identification with the zero reference shifted to each stable well (Sec. 3.1)"
    needs_mass = False
    preference = 40
    advice = "the paper's zero-reference shift (Sec. 3.1): one fit per stable well, combined; the slowest"
    advice_order = 40
    docs = "docs/nsi.md"
    dofs = "multi"
    options = (
        Option(
            "equilibria",
            "floats",
            None,
            "zero references z* in m, e.g. '-0.027,0.017' (auto: modes of the displacement histogram)",
            nullable=True,
        ),
        Option("iterate", "int", 3, "identifications per well at most (fixed point of the reference)", minimum=1),
        Option(
            "combine",
            "str",
            "mean",
            "how the per-well coefficient sets are combined",
            choices=("mean", "median"),
        ),
        *COMMON_OPTIONS,
    )

    @classmethod
    def figure_arrays(cls, arrays: Mapping[str, Any]) -> tuple[FigureArray, ...]:
        """What study reports draw from this method's arrays: each well's FRF and coefficient spectra, by well."""
        return figure_arrays(arrays, wells=True)

    def identify(self, record: Record, model: Model, *, mass: float | None = None) -> Estimate:
        """Every coefficient of ``model`` (and the mass unless given); structures: :mod:`nlid_nsi.structure_shift`."""
        with blas_threads(self.settings["blas_threads"]):
            return self._identify(record, model, mass)

    def identify_structure(
        self, record: Record, elements: ElementSet, *, mass: np.ndarray | None = None
    ) -> StructureEstimate:
        """Every element and the linear system of a structure (:mod:`nlid_nsi.structure_shift`)."""
        from .structure_shift import identify_structure_shift

        with blas_threads(self.settings["blas_threads"]):
            return identify_structure_shift(self, record, elements, mass)

    def _identify(self, record: Record, model: Model, mass: float | None) -> Estimate:
        from .basis import shifted_basis, split_model
        from .channels import prepare_channels
        from .fit import UnstableULSError, fit_extended
        from .gram import block_hankel_gram, clip_indefinite
        from .intersample import force_interval_mean
        from .noise import subtract_noise

        opt = self.settings
        t0 = time.perf_counter()
        dt = record.dt
        split = split_model(model)
        block_rows = opt["block_rows"]
        vel = velocity_estimate(record, opt["velocity"], opt["velocity_cutoff"])
        z, v = np.asarray(record.z), vel.v
        hold, hold_assumed = force_hold(record, opt["force_hold"])
        f_held = force_interval_mean(record.f, hold)
        band = tuple(opt["band_hz"]) if opt["band_hz"] else opt["band"]
        order, max_order, zeta_max = opt["order"], opt["max_order"], opt["zeta_max"]
        s = 2 * block_rows
        powers = [b.power for b in split.basis if b.power is not None]
        kmax = max(powers) if powers else 1
        # the model the shifted coefficients map back to: every power up to kmax, 1, z and v
        full_model = model.with_terms(add=["1", "z", "v"] + [f"z^{k}" for k in range(2, kmax + 1)])
        z_range = (float(z.min()), float(z.max()))
        if opt["equilibria"]:
            refs = [float(x) for x in opt["equilibria"]]
            ref_source = "given"
        else:
            refs = [float(x) for x in histogram_modes(z, degree=max(kmax, 2) + 1)]
            ref_source = "modes of the displacement histogram (polynomial fit to its logarithm), then fixed points"
            if not refs:
                raise IdentificationError("nsi-shift: the displacement histogram has no mode; give 'equilibria'")
        xbasis0, _ = shifted_basis(split.basis, refs[0])
        check_length(record.n, block_rows, len(xbasis0) + 2)

        rec: Reconstruction | None = None
        denoise_fc = None
        if opt["reconstruct"]:
            ch1 = prepare_channels(z, v, f_held, dt, xbasis0, refs[0], None, False, False, opt["noise_max_lag"])
            eye = np.eye(ch1.base.shape[1])
            try:
                fit1 = fit_extended(ch1, eye, block_hankel_gram(ch1.base, s), dt, band, order, max_order, zeta_max)
            except UnstableULSError as exc:
                raise UnstableULSError(f"nsi-shift, zero reference {refs[0]:.6g} m: {exc}", exc.eigenvalues) from None
            rec, denoise_fc = reconstruction(record, vel, f_held, (fit1.uls.m, fit1.uls.c, fit1.uls.k), opt)

        wells: list[dict[str, Any]] = []
        fits: list[NSIFit] = []
        warnings: list[str] = [HOLD_ASSUMED] if hold_assumed else []
        identifications = 0
        for ref in refs:
            zstar = ref
            history = [zstar]
            try:
                for it in range(opt["iterate"]):
                    xbasis, _ = shifted_basis(split.basis, zstar)
                    ch = prepare_channels(
                        z,
                        v,
                        f_held,
                        dt,
                        xbasis,
                        zstar,
                        rec,
                        False,
                        opt["noise_correction"],
                        opt["noise_max_lag"],
                        opt["intersample"],
                        opt["sign_calibration"],
                    )
                    gram = block_hankel_gram(ch.base, s)
                    if ch.noise is not None:
                        gram = subtract_noise(gram, ch.noise, output=ch.base.shape[1] - 1)
                        gram, _ = clip_indefinite(gram)
                    fit = fit_extended(
                        ch, np.eye(ch.base.shape[1]), gram, dt, band, order, max_order, zeta_max, None, mass
                    )
                    identifications += 1
                    cz, cx = self._map_back(fit, ch, xbasis, split.basis, zstar, kmax, v, dt)
                    eq = equilibria(full_model, {n: cz.get(n, 0.0) for n in full_model.names}, z_range)
                    stable = np.array(eq.stable)
                    if stable.size == 0:
                        break
                    znew = float(stable[np.argmin(np.abs(stable - zstar))])
                    done = abs(znew - zstar) <= 1e-7 * max(1e-12, float(np.std(z)))
                    if done or it == opt["iterate"] - 1:
                        break
                    zstar = znew
                    history.append(zstar)
            except UnstableULSError as exc:
                warnings.append(f"zero reference {zstar:.6g} m: {exc}")
                continue
            fits.append(fit)
            wells.append(
                {
                    "reference": zstar,
                    "reference_history": history,
                    "coefficients": cz,
                    "x_coefficients": cx,
                    "mass": fit.uls.m,
                    **fit_summary(fit),
                }
            )
        if not fits:
            raise IdentificationError(
                "nsi-shift: no zero reference gave a stable underlying-linear system: " + "; ".join(warnings)
            )
        agg = np.median if opt["combine"] == "median" else np.mean
        keys = list(wells[0]["coefficients"])
        combined = {k: float(agg([w["coefficients"][k] for w in wells])) for k in keys}
        mass_est = float(agg([w["mass"] for w in wells]))
        coefficients = {n: combined[n] for n in model.names}
        unmodelled = {k: x for k, x in combined.items() if k not in model.names}
        modal = [
            {
                "equilibrium": w["reference"],
                "fn_hz": f.uls.fn,
                "zeta": f.uls.zeta,
                "stiffness": f.uls.k,
                "damping": f.uls.c,
                "source": "ULS of the well (Eq. 18), zero reference shifted to it (Sec. 3.1)",
            }
            for w, f in zip(wells, fits, strict=True)
        ]
        arrays: dict[str, np.ndarray] = {}
        for i, fit in enumerate(fits):
            arrays.update(fit_arrays(fit, well_suffix(i)))
        diagnostics: dict[str, Any] = {
            "wells": wells,
            "combine": opt["combine"],
            "references_source": ref_source,
            "initial_references": refs,
            "identifications": identifications,
            "order": [int(f.order) for f in fits],
            "singular_values": [float(x) for x in fits[0].singular_values[:20]],
            "block_rows": block_rows,
            **velocity_diagnostics(vel),
            "denoise_cutoff_hz": denoise_fc,
            **reconstruction_diagnostics(rec),
            "force_hold": hold,
            "mass_source": "given" if mass is not None else f"estimated ({opt['combine']} of the wells' ULS fits)",
            "arrays_note": "no suffix: first well; '@wellN': well N (spectra of the shifted basis x = z - z*)",
            "seconds": time.perf_counter() - t0,
        }
        if unmodelled:
            diagnostics["unmodelled"] = unmodelled
        return Estimate(
            coefficients=coefficients,
            mass=None if mass is not None else mass_est,
            modal=modal,
            diagnostics=diagnostics,
            warnings=warnings,
            arrays=arrays,
        )

    @staticmethod
    def _map_back(
        fit: NSIFit,
        ch,
        xbasis: tuple[Basis, ...],
        basis: tuple[Basis, ...],
        zstar: float,
        kmax: int,
        v: np.ndarray,
        dt: float,
    ) -> tuple[dict[str, float], dict[str, float]]:
        """Coefficients in ``z`` (all powers, 1, z, v, other terms) and in ``x``."""
        from .channels import static_constant

        cx = dict(fit.coefficients)
        cx["x"] = fit.uls.k
        cx["v"] = fit.uls.c
        cx["1"] = static_constant(ch, fit.uls.m, fit.uls.k, fit.uls.c, cx, xbasis, v, dt)
        a = np.zeros(kmax + 1)
        a[0], a[1] = cx["1"], cx["x"]
        for k in range(2, kmax + 1):
            a[k] = cx[f"x^{k}"]
        th = taylor_shift(a, -zstar)
        cz = {"1": float(th[0]), "z": float(th[1]), "v": float(cx["v"])}
        names = {b.power: b.name for b in basis if b.power is not None}
        for k in range(2, kmax + 1):
            cz[names.get(k, f"z^{k}")] = float(th[k])
        for b in basis:
            if b.power is None:
                cz[b.name] = float(cx[b.name])
        return cz, cx
