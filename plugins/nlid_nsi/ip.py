"""``nsi-ip``: NSI with a virtual input perturbation (paper Sec. 2.2 and 3.2).

Equations implemented (paper numbering)
---------------------------------------
* Eq. 12-13: the perturbed input ``fbar = f + k~1 z`` (the static load ``m g``
  is not subtracted: every channel is centred, and the constant term ``1`` is
  recovered from the static balance, see below);
* Eq. 14-15: the restoring force split into the underlying-linear system
  ``m z'' + c_v z' + kbar z`` (``kbar = k~1 + theta_z``) and the internal
  feedback forces ``-theta_j g_j(z, v)`` of every other model term;
* Eq. 16-17: the extended-input state-space model ``[fbar, -g_1, ...] -> z``
  identified by PO-MOESP (:mod:`nlid_nsi.subspace`) with the inputs as
  interval means (:mod:`nlid_nsi.intersample`) and the exact ZOH inverse;
* Eq. 18: ``A_c = psi Lambda_c psi^-1``; a trial k~1 fails when the
  eigenvalues are real or unstable (and, as a margin, when the damping ratio
  exceeds ``zeta_max``);
* Eq. 19-20: ``H_E(w) = D + C (i w I - A_c)^-1 B_c = [Hbar, Hbar theta_1,
  ...]``: each nonlinear coefficient is ``Re(H_E,j / Hbar)`` averaged over the
  band, with ``E[Re/Im]`` as its quality;
* ``theta_z = kbar - k~1`` (NOTES.md sign convention: the ``z`` coefficient of
  R is -500 N/m on the paper's example), ``c_v`` and ``m`` from
  ``1 / Hbar = kbar - m w^2 + i c_v w`` fitted over the band;
* Eq. 8 and Eq. 22: natural frequency ``sqrt(K'(z*) / m)`` and damping ratio
  ``zeta = zeta_bar wbar / w_n = c_v / (2 m w_n)`` at every stable equilibrium
  of the identified ``K(z)`` (through :func:`nlid.model.physics.modal`, which uses
  every term linear in v at rest; with ``v`` alone that is exactly Eq. 22).

The constant term ``1`` (``m g`` on the paper's example) comes from the static
balance ``theta_1 = mean(f - m a - theta_z z - c_v v - sum theta_j g_j)``.

Choosing k~1 (``k_tilde = auto``)
    From ``k_start`` in steps of ``k_step`` (the paper steps by 100 N/m). One
    base Gram serves every trial (``fbar`` is a linear map of the base
    channels), and its subspace step is prepared once for every k~1
    (:class:`nlid_nsi.subspace.PerturbedMOESP`: the rows that do not depend on
    k~1 are eliminated once): a trial on the ``search_block_rows`` sub-Gram
    then costs ~0.5 ms, the subspace step of a full fit ~2 ms
    (docs/performance.md). The first
    accepted value is re-checked with the full model, and the search goes on
    if it fails there: on paper-numerical k~1 = 500 = -theta_z makes the true
    ULS ``m s^2 + c s`` (eigenvalues 0 and -5 rad/s), which noise can make
    look barely complex on the small Gram. Every trial is reported with its
    eigenvalues. Measured (prototype): 600-1500 N/m all meet the targets, so
    the first accepted value is kept.

Two passes
    Pass 1 uses the raw samples (trapezoid interval means): the k~1 search
    and a first ULS that drives the clean-force surrogate of
    :mod:`nlid_nsi.reconstruction`. Pass 2 uses the de-noised ``z``, the
    completed ``v``, the Gauss-Hermite interval means and the
    errors-in-variables correction (:mod:`nlid_nsi.noise`), and gives the
    reported model. With a measured acceleration and ``v`` derived from ``z``
    (``acceleration = fuse``, the default), pass 2's ``z`` and ``v`` come
    from ``z`` below a crossover and ``a`` above it
    (:func:`nlid_nsi.reconstruction.fuse_motion`), with both noises in the
    errors-in-variables model; ``acceleration = ignore`` leaves ``a`` out.
    An indefinite noise-corrected Gram is projected onto the positive
    semi-definite matrices once (:func:`nlid_nsi.gram.clip_indefinite`),
    before any k~1 is fitted on it.

k~1 ensemble (``k_tilde_ensemble``, ``k_tilde_spread``)
    Pass 2 is fitted at ``k_tilde_ensemble`` values of k~1 evenly spread from
    the accepted one to ``k_tilde_spread`` times it (one data Gram, one
    congruence each, :func:`ensemble_values`); the coefficients,
    ``theta_z = kbar - k~1``, ``c_v`` and ``m`` are their means
    (:func:`combine_fits`). A value whose ULS fails Eq. 18 is left out and
    listed. The order, singular values, band, ULS, ``E[Re/Im]`` and the
    spectra reported are those of the accepted k~1 (``diagnostics
    ["reported_fit"]``); each member's coefficients and ``E[Re/Im]`` are in
    ``diagnostics["k_tilde_ensemble"]``.

Mass
    Estimated by the ULS fit ``1 / Hbar = kbar - m w^2 + i c_v w`` (the mean
    over the ensemble) unless given. A given mass is used in the surrogate of
    pass 2, the static balance and Eq. 8/22; it is not forced into the ULS
    fit (``mass_in_uls_fit = false``, the default): kbar and ``c_v`` come from
    the fit with its own ``m``, whose small error (from noise) compensates
    theirs over the band; fixing ``m`` there moves that error into ``kbar``
    and so into ``theta_z`` and the natural frequencies (measured in
    ``docs/nsi.md``).
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
    Identifier,
    Model,
    Option,
    Record,
    StructureEstimate,
    equilibria,
    modal,
)

from .common import (
    COMMON_OPTIONS,
    HOLD_ASSUMED,
    blas_threads,
    check_length,
    eigen_list,
    figure_arrays,
    fit_arrays,
    fit_summary,
    force_hold,
    reconstruction,
    reconstruction_diagnostics,
    velocity_diagnostics,
    velocity_estimate,
)

if TYPE_CHECKING:
    from .channels import Channels
    from .fit import NSIFit
    from .subspace import PerturbedMOESP

# The numerical modules (scipy) are imported where they are used, not here: loading the plugin's entry point
# (the registry, `nlid methods`) costs no scipy import.

__all__ = ["NSIInputPerturbation", "search_k_tilde", "ensemble_values", "combine_fits"]

#: Values of k~1 accepted by the cheap search but rejected by the full model
#: before the search gives up (on paper-numerical one such value, 500 N/m, is seen).
MAX_RECHECKS = 10


def search_k_tilde(
    gram: np.ndarray,
    ch: Channels,
    dt: float,
    start: float,
    step: float,
    k_max: float,
    order: int,
    max_order: int,
    zeta_max: float,
    trials: list[dict[str, Any]],
    subspace: PerturbedMOESP | None = None,
) -> float:
    """Smallest ``k~1`` on the grid ``start + j step`` whose ULS passes the test of Eq. 18.

    Each trial (PO-MOESP of the perturbed channels on ``gram``; through
    ``subspace``, the same step prepared once for every k~1, when given) is
    appended to ``trials``.

    Raises
    ------
    UnstableULSError
        If no value up to ``k_max`` passes.
    """
    from .channels import perturbation_map
    from .continuous import continuous_eigenvalues, uls_ok
    from .fit import UnstableULSError
    from .gram import transform_gram
    from .subspace import po_moesp

    k = float(start)
    rows = gram.shape[0] // 2
    while k <= k_max:
        t = perturbation_map(ch, k)
        if subspace is not None:
            a = subspace.estimate(t, order, max_order)[0]
        else:
            a = po_moesp(transform_gram(gram, t), t.shape[0] - 1, order, max_order)[0]
        lc = continuous_eigenvalues(a, dt)
        ok = uls_ok(lc, zeta_max)
        trials.append({"k_tilde": k, "block_rows": rows, "accepted": ok, "eigenvalues": eigen_list(lc)})
        if ok:
            return k
        k += step
    raise UnstableULSError(
        f"no k~1 from {start:g} to {k_max:g} N/m (step {step:g}) gives a stable underlying-linear system; "
        "raise k_max or check the model"
    )


def ensemble_values(k0: float, count: int, spread: float) -> list[float]:
    """The k~1 values of the ensemble: ``count`` values evenly spread over ``[k0, spread * k0]``.

    Parameters
    ----------
    k0
        The accepted (or given) k~1 in N/m; it is always the first value.
    count
        Number of values (option ``k_tilde_ensemble``).
    spread
        Ratio of the largest value to ``k0`` (option ``k_tilde_spread``).

    Returns
    -------
    list of float
        ``[k0]`` alone when ``count`` is 1, ``spread`` is 1 or ``k0 <= 0``
        (a ULS stable without perturbation: there is nothing to spread).
    """
    if count <= 1 or spread <= 1.0 or k0 <= 0.0:
        return [float(k0)]
    return [float(k0 * (1.0 + (spread - 1.0) * j / (count - 1))) for j in range(count)]


def combine_fits(fits: list[tuple[float, NSIFit]]) -> tuple[dict[str, float], float, float, float]:
    """Average the fits of several k~1: nonlinear coefficients, ``theta_z = kbar - k~1``, ``c_v`` and ``m``.

    Every k~1 gives a consistent estimate of the same coefficients: Eq. 13-15
    only move ``k~1 z`` between the input ``fbar`` and the ULS stiffness
    ``kbar = k~1 + theta_z``, and Eq. 19-20 give the same ``theta_j`` for
    any stable ULS. Their errors from the noise differ (the perturbed input
    ``fbar = f + k~1 z`` weights the noisy ``z`` differently), so the mean
    has a smaller spread than any one of them (measured in ``docs/nsi.md``).

    Parameters
    ----------
    fits
        ``(k~1, fit)`` pairs, each fitted on the same data Gram.

    Returns
    -------
    coefficients
        Mean of the nonlinear coefficients (Eq. 20), by basis name.
    theta_z
        Mean of ``kbar - k~1`` (the ``z`` coefficient of R).
    c_v
        Mean viscous coefficient of the ULS fits.
    m
        Mean mass of the ULS fits.
    """
    names = list(fits[0][1].coefficients)
    coefs = {n: float(np.mean([f.coefficients[n] for _, f in fits])) for n in names}
    theta_z = float(np.mean([f.uls.k - k for k, f in fits]))
    c_v = float(np.mean([f.uls.c for _, f in fits]))
    m = float(np.mean([f.uls.m for _, f in fits]))
    return coefs, theta_z, c_v, m


class NSIInputPerturbation(Identifier):
    """NSI with the virtual input perturbation ``fbar = f + k~1 z`` (Sec. 2.2, 3.2).

    Implements Eq. 12-13 (perturbed input), 14-17 (underlying-linear system
    plus extended inputs, state-space form), 18 (eigenvalue test of each k~1),
    19-20 (extended FRF, coefficients as band-averaged ``Re(H_E,j / Hbar)``),
    8 and 22 (natural frequency and damping ratio per stable equilibrium);
    details and measured design decisions in the module docstring and
    ``docs/nsi.md``. The mass is estimated unless given.
    """

    name = "nsi-ip"
    summary = "nonlinear subspace identification with a virtual input perturbation f + k~1 z (Sec. 2.2)"
    needs_mass = False
    preference = 20
    advice = (
        "accurate damping ratios and natural frequencies from a noisy z, several wells, an unstable "
        "linear part (paper Sec. 3.2); 4-10x slower than rfs"
    )
    advice_order = 30
    docs = "docs/nsi.md"
    dofs = "multi"
    options = (
        Option(
            "k_tilde",
            "float",
            None,
            "virtual stiffness k~1 in N/m (auto: search from k_start in steps of k_step)",
            nullable=True,
        ),
        Option("k_start", "float", 0.0, "first k~1 of the automatic search (N/m)"),
        Option("k_step", "float", 100.0, "step of the automatic search (N/m)", minimum=1e-12),
        Option("k_max", "float", 1e5, "give up the search above this k~1 (N/m)"),
        Option(
            "k_tilde_ensemble",
            "int",
            5,
            "number of k~1 values whose identifications are averaged (1: the accepted k~1 alone)",
            minimum=1,
        ),
        Option(
            "k_tilde_spread",
            "float",
            2.5,
            "the averaged k~1 values are evenly spread from the accepted k~1 to this multiple of it",
            minimum=1.0,
        ),
        Option(
            "mass_in_uls_fit",
            "bool",
            False,
            "a given mass also fixes m in the ULS fit 1/Hbar = kbar - m w^2 + i c w (else it is used in the "
            "surrogate, the static balance and Eq. 8/22 only)",
        ),
        Option(
            "search_block_rows",
            "int",
            40,
            "block rows of the cheap search trials (re-checked at block_rows)",
            minimum=2,
        ),
        *COMMON_OPTIONS,
    )

    @classmethod
    def figure_arrays(cls, arrays: Mapping[str, Any]) -> tuple[FigureArray, ...]:
        """What study reports draw from this method's arrays (one FRF, its coefficient spectra)."""
        return figure_arrays(arrays, wells=False)

    def identify(self, record: Record, model: Model, *, mass: float | None = None) -> Estimate:
        """Every coefficient of ``model`` (and the mass unless given); structures: :mod:`nlid_nsi.structure`."""
        with blas_threads(self.settings["blas_threads"]):
            return self._identify(record, model, mass)

    def identify_structure(
        self, record: Record, elements: ElementSet, *, mass: np.ndarray | None = None
    ) -> StructureEstimate:
        """Every element and the linear system of a structure (:mod:`nlid_nsi.structure`)."""
        from .structure import identify_structure_ip

        with blas_threads(self.settings["blas_threads"]):
            return identify_structure_ip(self, record, elements, mass)

    def _identify(self, record: Record, model: Model, mass: float | None) -> Estimate:
        from .basis import split_model
        from .channels import perturbation_map, perturbation_subspace, prepare_channels, static_constant
        from .fit import UnstableULSError, fit_extended
        from .gram import block_hankel_gram, clip_indefinite, sub_gram
        from .intersample import force_interval_mean
        from .noise import subtract_noise

        opt = self.settings
        t0 = time.perf_counter()
        timings: dict[str, float] = {}
        dt = record.dt
        split = split_model(model)
        basis = split.basis
        block_rows = opt["block_rows"]
        check_length(record.n, block_rows, len(basis) + 3)
        vel = velocity_estimate(record, opt["velocity"], opt["velocity_cutoff"])
        z, v = np.asarray(record.z), vel.v
        hold, hold_assumed = force_hold(record, opt["force_hold"])
        f_held = force_interval_mean(record.f, hold)
        band = tuple(opt["band_hz"]) if opt["band_hz"] else opt["band"]
        order, max_order, zeta_max = opt["order"], opt["max_order"], opt["zeta_max"]
        s = 2 * block_rows

        uls_mass = mass if opt["mass_in_uls_fit"] else None

        subspaces: dict[int, PerturbedMOESP] = {}

        def prepared(ch: Channels, gram: np.ndarray) -> PerturbedMOESP:
            """The subspace step of ``gram`` for every k~1, prepared on first use (one per Gram)."""
            if id(gram) not in subspaces:
                subspaces[id(gram)] = perturbation_subspace(ch, gram)
            return subspaces[id(gram)]

        def fit(ch: Channels, gram: np.ndarray, k: float) -> NSIFit:
            return fit_extended(
                ch,
                perturbation_map(ch, k),
                gram,
                dt,
                band,
                order,
                max_order,
                zeta_max,
                k,
                uls_mass,
                prepared(ch, gram),
            )

        def first_pass() -> Channels:
            """Pass 1's channels; their samples are dropped while pass 2 runs and rebuilt if needed again."""
            nonlocal ch1
            if ch1 is None or ch1.base is None:
                ch1 = prepare_channels(z, v, f_held, dt, basis, 0.0, None, True, False, opt["noise_max_lag"])
            return ch1

        ch1: Channels | None = None
        g1 = block_hankel_gram(first_pass().base, s)
        g_search = sub_gram(g1, min(opt["search_block_rows"], block_rows))
        timings["gram"] = time.perf_counter() - t0
        trials: list[dict[str, Any]] = []
        explicit = opt["k_tilde"] is not None
        k_use = float(opt["k_tilde"] if explicit else opt["k_start"])
        ch2 = g2 = None
        denoise_fc = None
        rec_diagnostics = reconstruction_diagnostics(None)
        gram_clipped = False
        rechecks = 0
        while True:
            if not explicit:
                k_use = search_k_tilde(
                    g_search,
                    ch1,
                    dt,
                    k_use,
                    opt["k_step"],
                    opt["k_max"],
                    order or 2,
                    max_order,
                    zeta_max,
                    trials,
                    prepared(ch1, g_search),
                )
            try:
                result = fit(first_pass(), g1, k_use)
                trials.append(
                    {
                        "k_tilde": k_use,
                        "block_rows": block_rows,
                        "accepted": True,
                        "eigenvalues": eigen_list(result.uls.eigenvalues),
                    }
                )
                timings["search"] = time.perf_counter() - t0
                ch, gram = ch1, g1
                if opt["reconstruct"]:
                    if ch2 is None:
                        m_surrogate = float(mass) if mass is not None else result.uls.m
                        ch1.base = None  # memory: one set of channels at a time (rebuilt if a retry needs it)
                        rec, denoise_fc = reconstruction(
                            record, vel, f_held, (m_surrogate, result.uls.c, result.uls.k), opt
                        )
                        ch2 = prepare_channels(
                            z,
                            v,
                            f_held,
                            dt,
                            basis,
                            0.0,
                            rec,
                            True,
                            opt["noise_correction"],
                            opt["noise_max_lag"],
                            opt["intersample"],
                            opt["sign_calibration"],
                        )
                        rec_diagnostics = reconstruction_diagnostics(rec)
                        del rec
                        g2 = block_hankel_gram(ch2.base, s)
                        if ch2.noise is not None:
                            g2 = subtract_noise(g2, ch2.noise, output=ch2.base.shape[1] - 1)
                            g2, gram_clipped = clip_indefinite(g2)
                        timings["second_gram"] = time.perf_counter() - t0
                    ch, gram = ch2, g2
                    result = fit(ch, gram, k_use)
                break
            except UnstableULSError as exc:
                lc = exc.eigenvalues
                rechecks += 1
                trials.append(
                    {"k_tilde": k_use, "block_rows": block_rows, "accepted": False, "eigenvalues": eigen_list(lc)}
                )
                if explicit:
                    raise UnstableULSError(
                        self._explicit_failure(k_use, lc, g1, ch1, dt, prepared(ch1, g1)), lc
                    ) from None
                if rechecks >= MAX_RECHECKS:
                    raise UnstableULSError(
                        f"nsi-ip: {rechecks} values of k~1 accepted by the search failed with the full model "
                        f"(last: k~1 = {k_use:g} N/m, {exc}); check the model order and the data",
                        lc,
                    ) from None
                k_use += opt["k_step"]

        fits = [(k_use, result)]
        rejected: list[dict[str, Any]] = []
        for k in ensemble_values(k_use, opt["k_tilde_ensemble"], opt["k_tilde_spread"])[1:]:
            try:
                fits.append((k, fit(ch, gram, k)))
            except UnstableULSError as exc:
                rejected.append({"k_tilde": k, "accepted": False, "eigenvalues": eigen_list(exc.eigenvalues)})
        timings["ensemble"] = time.perf_counter() - t0
        coefs, theta_z, c_v, m_fit = combine_fits(fits)
        mass_out = float(mass) if mass is not None else m_fit
        coefs["z"] = theta_z
        coefs["v"] = c_v
        theta_1 = static_constant(ch, mass_out, theta_z, c_v, coefs, basis, v, dt)
        coefs["1"] = theta_1
        warnings = [HOLD_ASSUMED] if hold_assumed else []
        unmodelled = {}
        for name, present, value in (
            ("1", split.constant, theta_1),
            ("z", split.linear, theta_z),
            ("v", split.viscous, c_v),
        ):
            if not present:
                unmodelled[name] = value
                if name != "1":
                    warnings.append(
                        f"the model has no '{name}' term but NSI always identifies the underlying-linear "
                        f"{'stiffness' if name == 'z' else 'damping'}: {value:.6g} was left out "
                        "(diagnostics 'unmodelled')"
                    )
        coefficients = {name: float(coefs[name]) for name in model.names}
        z_range = (float(z.min()), float(z.max()))
        full_model = model.with_terms(add=[n for n in ("1", "z", "v") if n not in model])
        full = {n: coefs[n] for n in full_model.names}
        try:
            eq = equilibria(full_model, full, z_range)
            modes = modal(full_model, full, mass_out, eq.stable, z_range)
        except Exception:  # noqa: BLE001 - modal left to the core if the stiffness is odd
            modes = None
        modal_out = None
        if modes is not None:
            modal_out = []
            for mo in modes:
                d = mo.to_dict()
                d["zeta_from_uls"] = c_v / (2 * mass_out * 2 * np.pi * d["fn_hz"])
                d["source"] = "Eq. 8 (identified K'(z*), estimated m), Eq. 22 (c(z*) / 2 m w_n)"
                modal_out.append(d)
        timings["total"] = time.perf_counter() - t0
        diagnostics: dict[str, Any] = {
            "k_tilde": k_use,
            "k_tilde_search": "explicit" if explicit else "automatic",
            "k_tilde_trials": trials,
            "k_tilde_ensemble": [
                {
                    "k_tilde": k,
                    "accepted": True,
                    "coefficients": {**f.coefficients, "z": f.uls.k - k, "v": f.uls.c},
                    "mass": f.uls.m,
                    "quality": {sp.name: sp.quality for sp in f.spectra},
                }
                for k, f in fits
            ]
            + rejected,
            "reported_fit": f"k~1 = {k_use:g} N/m (order, singular values, band, ULS, quality and the arrays); "
            f"the coefficients and the mass are the mean over the {len(fits)} k~1 of 'k_tilde_ensemble'",
            **fit_summary(result),
            "block_rows": block_rows,
            **velocity_diagnostics(vel),
            "denoise_cutoff_hz": denoise_fc,
            **rec_diagnostics,
            "force_hold": hold,
            "force_model": "held over each sample (exact ZOH)"
            if hold == "zoh"
            else "interval mean of the cubic through 4 samples",
            "gram_clipped": gram_clipped,
            "errors_in_variables_correction": bool(
                opt["reconstruct"] and opt["noise_correction"] and ch.noise is not None
            ),
            "mass_source": "given" if mass is not None else "estimated (ULS fit)",
            "timings_s": timings,
        }
        if unmodelled:
            diagnostics["unmodelled"] = unmodelled
        return Estimate(
            coefficients=coefficients,
            mass=None if mass is not None else mass_out,
            modal=modal_out,
            diagnostics=diagnostics,
            warnings=warnings,
            arrays=fit_arrays(result),
        )

    def _explicit_failure(
        self,
        k: float,
        lc: np.ndarray,
        gram: np.ndarray,
        ch: Channels,
        dt: float,
        subspace: PerturbedMOESP | None = None,
    ) -> str:
        """The message for an explicit k~1 that fails, with the value the search would accept."""
        from .fit import UnstableULSError, format_eigenvalues

        opt = self.settings
        msg = (
            f"nsi-ip: k~1 = {k:g} N/m gives an underlying-linear system with eigenvalues "
            f"[{format_eigenvalues(lc)}] rad/s"
        )
        real = bool(np.all(np.abs(lc.imag) <= 1e-6 * np.abs(lc)))
        msg += (
            " (real: the perturbed stiffness k~1 + theta_z is not positive)" if real else " (not a stable oscillator)"
        )
        try:
            k_ok = search_k_tilde(
                gram,
                ch,
                dt,
                k + opt["k_step"],
                opt["k_step"],
                opt["k_max"],
                opt["order"] or 2,
                opt["max_order"],
                opt["zeta_max"],
                [],
                subspace,
            )
            hint = f"; use a larger k~1 (the automatic search from {k + opt['k_step']:g} N/m accepts {k_ok:g} N/m)"
        except UnstableULSError:
            hint = "; use a larger k~1"
        return msg + hint
