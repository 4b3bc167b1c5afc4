"""NSI on a structure of several degrees of freedom: channels, one fit, the input perturbation, the estimate.

Both identifiers (``nsi-ip``, ``nsi-shift``) declare ``dofs = "multi"``: on an
indexed :class:`~nlid.plugin.Record` they identify the coefficient of every
element of an :class:`~nlid.plugin.ElementSet` and the underlying linear
system (ULS) ``M``, ``C``, ``K`` by the MIMO subspace step of
:mod:`nlid_nsi.mimo` (Marchesiello & Garibaldi 2008).

Channels (:func:`structure_channels`)
    The force on every driven DOF (its interval mean, as for one DOF), the
    extended input ``-g_e`` of every element as the interval mean over each
    sample (Gauss-Hermite, :mod:`nlid_nsi.intersample`) on the element's
    relative coordinate ``x = z_i - z_j``, ``x' = v_i - v_j`` of the
    de-noised motion (each DOF's ``z`` low-passed at 1.5 x its noise-floor
    cut-off; ``v`` measured and low-passed alike, or differentiated from
    ``z``), and the measured displacement of every DOF as the outputs. The
    interval means are sharpened to the held values a ZOH model of a mass
    needs (:func:`sharpen`). The data Gram and the B step are corrected for
    the noise the basis functions carry (:mod:`nlid_nsi.structure_noise`).
    When a DOF that enters a channel was low-passed below 3 x the highest
    identified mode, the identification is repeated with the cut-offs raised
    there (:func:`band_floor`). No reconstruction pass (one-DOF ``nsi-ip``).

Input perturbation (``nsi-ip``, :func:`identify_perturbed`)
    The virtual stiffness acts at the *inputs*: ``fbar_d = f_d + k~1 z_d``
    on every driven DOF ``d``, a grounded virtual spring there, so the ULS is
    ``K + k~1 sum_d e_d e_d^T`` (symmetric; reciprocity holds). A
    perturbation acting on a DOF that is not driven would be a deterministic
    function of the outputs, which makes the extended model non-unique; so
    it is applied where the force is. ``k~1 = 0`` is tried first (the plain
    NSI of Marchesiello & Garibaldi); if that ULS fails the test of Eq. 18,
    ``k_start + j k_step`` are tried until one passes. ``K`` is the
    identified ``Kbar`` minus the virtual springs. As for one DOF, a
    perturbed fit is repeated at ``k_tilde_ensemble`` values from the
    accepted k~1 to ``k_tilde_spread`` times it and the coefficients, ``M``,
    ``C``, ``K`` averaged (the first accepted k~1 can leave a barely stable
    ULS whose mass matrix is ill-determined: on the double well at 2 % noise,
    k~1 = 600 N/m alone gave ``M22 = 0.33`` kg for 1 kg).

The estimate
    Coefficients from the element spectra (:func:`nlid_nsi.mimo.element_spectra`),
    ``M`` (unless given), ``C``, ``K`` from the ULS modes, the constant force
    per DOF from the static balance ``mean(f) - K mean(z) - sum_e b_e theta_e mean(g_e)``.
    Arrays: the ULS FRF matrix (``frf_matrix``, ``(W, n, n)``), every
    element's coefficient spectrum (``coef_spectrum:<element>``), the
    singular values.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import linalg

from nlid.plugin import (
    CHANNEL_SOURCES,
    DataError,
    Element,
    ElementSet,
    InputError,
    Model,
    Record,
    StructureEstimate,
    source_entries,
)

from .basis import Basis, split_model
from .common import HOLD_ASSUMED, check_length
from .continuous import continuous_eigenvalues, uls_ok
from .fit import UnstableULSError, format_eigenvalues
from .gram import block_hankel_gram, transform_gram
from .intersample import force_interval_mean, interval_means
from .mimo import ULSModes, band_grid, element_spectra, estimate_b, frf_matrix, mimo_moesp, structure_uls
from .noise import NoiseModel, subtract_noise
from .structure_motion import Motion, band_floor, structure_motion
from .structure_noise import structure_noise_model

__all__ = [
    "StructureChannels",
    "StructureFit",
    "structure_motion",
    "element_basis",
    "structure_channels",
    "fit_structure",
    "identify_perturbed",
    "static_forces",
    "structure_arrays",
    "check_structure_options",
    "structure_gram",
    "uls_summary",
    "identify_structure_ip",
]

#: Values of k~1 tried at most (each a full identification).
MAX_TRIALS = 40
#: Points of the plotted FRF matrix and coefficient spectra.
PLOT_POINTS = 512


def check_structure_options(opt: dict[str, Any], n_dofs: int) -> int:
    """The model order of a structure (``2 n``), refusing options that do not apply to one."""
    order = opt.get("order")
    if order is not None and order != 2 * n_dofs:
        raise InputError(
            f"a structure of {n_dofs} DOFs is identified with order {2 * n_dofs} (two states per mode), "
            f"got order={order}"
        )
    if opt.get("velocity") == "integrate":
        raise InputError("velocity=integrate is not available for a structure: use measured or differentiate")
    return 2 * n_dofs


def element_basis(element: Element, elements: ElementSet) -> Basis:
    """The basis function ``g(x, x')`` of an element (the one-DOF term on its relative coordinate).

    Raises
    ------
    InputError
        A linear element (its stiffness or damping belongs to ``K`` or ``C``) or a memory element.
    """
    roots = elements.roots_of(element)
    split = split_model(Model((element.term,), None if roots is None else tuple(roots)))
    if not split.basis:
        raise InputError(
            f"element {element.name} is linear: NSI identifies it as part of the underlying linear K or C; leave it out"
        )
    if element.family == "memory":
        raise InputError(f"NSI on a structure does not take memory elements ({element.name})")
    return split.basis[0]


@dataclass(frozen=True)
class StructureChannels:
    """The base channels of a structure's NSI, normalised: ``[f_d..., zbar_d..., -g_e..., z_1..z_n]``.

    Attributes
    ----------
    base
        ``(N, c)`` channels divided by :attr:`scales`.
    scales
        Standard deviation of each channel (its unit).
    names
        Channel names.
    driven, n_extra, n_elements, n_dofs
        Counts of each group (``n_extra``: the driven DOFs' de-noised displacement, for the perturbation).
    """

    base: np.ndarray
    scales: np.ndarray
    names: tuple[str, ...]
    driven: tuple[int, ...]
    n_extra: int
    n_elements: int
    n_dofs: int


def structure_channels(
    record: Record,
    motion: Motion,
    columns: list[tuple[str, Any]],
    hold: str,
    perturbation: bool,
    intersample: str,
) -> StructureChannels:
    """The base channels (:class:`StructureChannels`).

    ``columns`` are the extended inputs as ``(name, (func, connectivity))``:
    ``g`` evaluated on ``x = z b``, ``x' = v b``.
    """
    n = record.n_dofs
    driven = tuple(record.force_dofs)
    dt = record.dt
    f = np.asarray(record.f, dtype=float)
    parts = [force_interval_mean(f[:, d - 1], hold) for d in driven]
    names = [f"f{d}" for d in driven]
    if perturbation:
        ident = [lambda x, v: x]
        for d in driven:
            parts.append(_mean(ident, motion.z[:, d - 1], motion.v[:, d - 1], dt, intersample)[:, 0])
            names.append(f"<z{d}>")
    for name, (func, b) in columns:
        x, xd = motion.z @ b, motion.v @ b
        parts.append(-_mean([func], x, xd, dt, intersample)[:, 0])
        names.append(f"-{name}")
    z = np.asarray(record.z, dtype=float)
    for k in range(n):
        parts.append(z[:, k])
        names.append(f"z{k + 1}")
    base = np.column_stack(parts)
    base -= base.mean(axis=0)
    scales = base.std(axis=0)
    bad = [names[k] for k in np.flatnonzero(~(scales > 0))]
    if bad:
        raise DataError(f"channel {bad[0]} is constant: NSI cannot use it")
    return StructureChannels(
        base / scales, scales, tuple(names), driven, len(driven) if perturbation else 0, len(columns), n
    )


#: The 3-tap filter ``(-1, 14, -1) / 12`` that turns interval means into the held values of a force-driven mass.
SHARPEN = np.array([-1.0, 14.0, -1.0]) / 12.0


def sharpen(means: np.ndarray) -> np.ndarray:
    """Interval means ``m_k`` to the held values ``m_k - (m_{k+1} - 2 m_k + m_{k-1}) / 12`` (``gauss`` on a structure).

    The ZOH model maps a held input exactly to the displacement samples; a
    continuous input ``u(t) = e^{i w t}`` reaches them as the held sequence
    ``e^{i w (t_k + dt/2)} sinc^2(w dt/2) / cos(w dt/2)`` where the motion is
    mass-dominated within a sample (a double integrator: the position update
    weights the interval by ``dt - s``, the velocity uniformly). The interval
    mean has ``e^{i w (t_k + dt/2)} sinc(w dt/2)``; their ratio is ``1 + (w dt)^2 / 12 + O((w dt)^4)``,
    which this filter applies. Measured on noise-free ``3dof-cubic`` (seed 0): the
    cubic coefficient +0.18 % off with the interval means, -0.00 % with this
    (sample values -0.17 %, trapezoid +0.35 %). The end samples keep their means.
    """
    out = means.copy()
    out[1:-1] = SHARPEN[0] * (means[:-2] + means[2:]) + SHARPEN[1] * means[1:-1]
    return out


def _mean(funcs: list, x: np.ndarray, xd: np.ndarray, dt: float, how: str) -> np.ndarray:
    """Interval means of ``funcs`` (``gauss``), their trapezoid (``trapezoid``) or sample values (``zoh``)."""
    if how == "gauss":
        return sharpen(interval_means(funcs, x, xd, dt))
    values = np.column_stack([func(x, xd) for func in funcs])
    if how == "trapezoid":
        values[:-1] = 0.5 * (values[:-1] + values[1:])
    return values


@dataclass
class StructureFit:
    """One MIMO NSI identification.

    Attributes
    ----------
    uls
        The ULS (:class:`nlid_nsi.mimo.ULSModes`), ``K`` still including the virtual springs.
    coefficients, quality
        ``{input name: value}`` of every element input (band average of its spectrum, ``E[Re/Im]``).
    spectra, w_plot
        The coefficient spectra on the plot grid (rad/s).
    singular_values
        Of the subspace step.
    k_tilde
        The virtual stiffness at the driven DOFs (0: none).
    """

    uls: ULSModes
    coefficients: dict[str, float]
    quality: dict[str, float]
    spectra: np.ndarray
    w_plot: np.ndarray
    singular_values: np.ndarray
    k_tilde: float = 0.0
    extras: dict = field(default_factory=dict)


def _map(ch: StructureChannels, k_tilde: float) -> np.ndarray:
    """The channel map ``T``: ``[f_d + k~1 <z_d>..., -g_e..., z...]`` from the base channels (normalised units)."""
    nd, ne, nx = len(ch.driven), ch.n_elements, ch.n_extra
    c = ch.base.shape[1]
    keep = [*range(nd), *range(nd + nx, c)]
    t = np.zeros((len(keep), c))
    for row, col in enumerate(keep):
        t[row, col] = 1.0
    if nx:
        for d in range(nd):
            t[d, nd + d] = k_tilde * ch.scales[nd + d] / ch.scales[d]
    assert t.shape[0] == nd + ne + ch.n_dofs
    return t


def fit_structure(
    ch: StructureChannels,
    gram: np.ndarray,
    dt: float,
    order: int,
    connectivity: np.ndarray,
    band: str | tuple[float, float],
    zeta_max: float,
    k_tilde: float = 0.0,
    mass: np.ndarray | None = None,
    noise: NoiseModel | None = None,
) -> StructureFit:
    """Identify the extended model of the channels at ``k_tilde`` (module docstring).

    Raises
    ------
    UnstableULSError
        The ULS is not ``n`` stable, clearly oscillatory pairs (Eq. 18).
    """
    t = _map(ch, k_tilde)
    nd, ne, n = len(ch.driven), ch.n_elements, ch.n_dofs
    m = nd + ne
    g = gram if not ch.n_extra else transform_gram(gram, t)
    a, cm, sv = mimo_moesp(g, m, n, order)
    lc = continuous_eigenvalues(a, dt)
    if not uls_ok(lc, zeta_max):
        what = f"k~1 = {k_tilde:g} N/m: the" if k_tilde else "The"
        raise UnstableULSError(
            f"{what} identified underlying linear system has eigenvalues [{format_eigenvalues(lc)}] rad/s, "
            f"not {n} stable complex-conjugate pairs with damping ratio <= {zeta_max:g} (Eq. 18)",
            lc,
        )
    w = ch.base @ t.T
    b = estimate_b(a, cm, w[:, :m], w[:, m:], None if noise is None else noise.transformed(t))
    in_scales = np.r_[ch.scales[:nd], ch.scales[nd + ch.n_extra : nd + ch.n_extra + ne]]
    out_scales = ch.scales[-n:]
    directions = np.zeros((n, nd))
    for k, d in enumerate(ch.driven):
        directions[d - 1, k] = 1.0
    uls = structure_uls(a, b / in_scales[None, :], cm * out_scales[:, None], dt, directions, mass)
    names = [name[1:] for name in ch.names[nd + ch.n_extra : nd + ch.n_extra + ne]]
    cols = list(range(nd, nd + ne))
    wb = band_grid(uls, band)
    forces = [(k, d - 1) for k, d in enumerate(ch.driven)]
    _, est, quality = element_spectra(uls, wb, cols, connectivity, forces)
    top = float(np.max(np.abs(uls.eigenvalues)))
    w_plot = np.linspace(0.0, min(math.pi / dt, 2.0 * top), PLOT_POINTS + 1)[1:]
    spectra = element_spectra(uls, w_plot, cols, connectivity, forces)[0] if ne else np.zeros((PLOT_POINTS, 0))
    return StructureFit(
        uls,
        {k: float(x) for k, x in zip(names, est, strict=True)},
        {k: float(x) for k, x in zip(names, quality, strict=True)},
        spectra,
        w_plot,
        sv,
        k_tilde,
    )


def structure_gram(
    ch: StructureChannels,
    record: Record,
    motion: Motion,
    columns: list[tuple[str, Any]],
    opt: dict[str, Any],
    paths: np.ndarray | None = None,
) -> tuple[np.ndarray, dict[str, Any], NoiseModel | None]:
    """The data Gram of the base channels, noise-corrected unless ``noise_correction`` is off.

    Returns the Gram, a diagnostic (whether it was corrected) and the noise model (``None`` when not
    corrected), which :func:`fit_structure` also removes from the normal equations of the B step.
    ``paths``: the noise paths of the motion (:func:`nlid_nsi.structure_noise.noise_paths`) when several
    Grams share it.
    """
    gram = block_hankel_gram(ch.base, 2 * opt["block_rows"])
    if not opt["noise_correction"]:
        return gram, {"noise_correction": False}, None
    extra = ch.driven if ch.n_extra else ()
    model = structure_noise_model(
        record,
        motion,
        columns,
        ch.scales,
        len(ch.driven),
        extra,
        opt["noise_max_lag"],
        noise_sharpen(opt),
        paths,
    )
    return _definite(subtract_noise(gram, model, output=None)), {"noise_correction": True}, model


def noise_sharpen(opt: dict[str, Any]) -> np.ndarray | None:
    """The filter folded into the noise paths of the state-dependent channels (:func:`sharpen` with ``gauss``)."""
    return SHARPEN if opt["intersample"] == "gauss" else None


def _definite(gram: np.ndarray) -> np.ndarray:
    """The corrected Gram, its eigenvalues clipped once when a small diagonal load does not make it definite.

    Every fit's PO-MOESP factors a principal part of ``T G T^T``, which is
    definite when ``G`` is: so the (slow) clipping is done here once rather
    than by each fit's Cholesky (measured on ``2dof-double-well``, 11 fits:
    2 s each). The cheap Cholesky decides: the Gram is kept when it has a
    factor with a diagonal load of ``1e-6`` of its mean diagonal (a load only
    helps, so one trial at the largest load decides what trials at 0, ``1e-8``
    and ``1e-6`` did). Otherwise the eigenvalues below ``1e-8`` of the mean
    diagonal are raised to it: ``G + V (floor - ev) V^T`` over those
    eigenpairs alone (the nearest matrix with that floor, as the full
    decomposition ``V max(ev, floor) V^T`` gives it to rounding, at a
    fraction of the cost: a few hundred of the 1 200 eigenvectors).
    """
    s, c = gram.shape[0], gram.shape[1]
    flat = gram.reshape(s * c, s * c)
    scale = float(np.trace(flat)) / len(flat)
    try:
        linalg.cholesky(flat + 1e-6 * scale * np.eye(len(flat)), lower=True, check_finite=False)
        return gram
    except linalg.LinAlgError:
        pass
    sym = 0.5 * (flat + flat.T)
    floor = 1e-8 * scale
    ev, vec = linalg.eigh(sym, subset_by_value=(-np.inf, floor), driver="evx", check_finite=False)
    root = vec * np.sqrt(np.maximum(floor - ev, 0.0))
    return (sym + root @ root.T).reshape(gram.shape)


def identify_perturbed(
    ch: StructureChannels,
    gram: np.ndarray,
    dt: float,
    order: int,
    connectivity: np.ndarray,
    opt: dict[str, Any],
    trials: list[dict[str, Any]],
    mass: np.ndarray | None = None,
    noise: NoiseModel | None = None,
) -> StructureFit:
    """``k~1 = 0``, then the search ``k_start + j k_step`` (or the given ``k_tilde``) until the ULS passes.

    Raises
    ------
    UnstableULSError
        No value up to ``k_max`` gave a stable ULS.
    """
    band = tuple(opt["band_hz"]) if opt.get("band_hz") else opt["band"]
    if opt.get("k_tilde") is not None:
        values = [float(opt["k_tilde"])]
    else:
        step, start = float(opt["k_step"]), float(opt["k_start"])
        count = int(max(0.0, (float(opt["k_max"]) - start)) // step) + 1
        values = [0.0] + [start + j * step for j in range(count) if start + j * step > 0][: MAX_TRIALS - 1]
    last: UnstableULSError | None = None
    for k_tilde in values:
        try:
            fit = fit_structure(ch, gram, dt, order, connectivity, band, opt["zeta_max"], k_tilde, mass, noise)
        except UnstableULSError as exc:
            trials.append({"k_tilde": k_tilde, "accepted": False, "eigenvalues": format_eigenvalues(exc.eigenvalues)})
            last = exc
            continue
        trials.append({"k_tilde": k_tilde, "accepted": True})
        return fit
    raise UnstableULSError(
        f"nsi-ip: no k~1 up to {values[-1]:g} N/m at the driven DOFs gave a stable underlying linear system; "
        f"last: {last}",
        None if last is None else last.eigenvalues,
    )


def static_forces(record: Record, motion: Motion, K: np.ndarray, elements: ElementSet, theta: np.ndarray) -> np.ndarray:
    """The constant force per DOF from the static balance ``mean(f) - K mean(z) - B diag(theta) mean(g)``."""
    g = elements.evaluate(motion.z, motion.v)
    return (
        np.asarray(record.f, dtype=float).mean(axis=0)
        - K @ motion.z.mean(axis=0)
        - elements.B @ (theta * g.mean(axis=0))
    )


def structure_arrays(fit: StructureFit, names: list[str], suffix: str = "") -> dict[str, np.ndarray]:
    """The arrays of a fit: ULS FRF matrix, coefficient spectra, singular values (``suffix``: the well)."""
    out = {
        f"singular_values{suffix}": np.asarray(fit.singular_values),
        f"frf_frequency_hz{suffix}": fit.w_plot / (2 * math.pi),
        f"frf_matrix{suffix}": frf_matrix(fit.uls, fit.w_plot),
        f"coef_frequency_hz{suffix}": fit.w_plot / (2 * math.pi),
    }
    for j, name in enumerate(names):
        out[f"coef_spectrum:{name}{suffix}"] = fit.spectra[:, j]
    return out


def uls_summary(fit: StructureFit) -> dict[str, Any]:
    """JSON-friendly summary of a fit's ULS."""
    return {
        "k_tilde": fit.k_tilde,
        "fn_hz": fit.uls.fn_hz.tolist(),
        "zeta": fit.uls.zeta.tolist(),
        "eigenvalues": format_eigenvalues(fit.uls.eigenvalues),
        "quality": dict(fit.quality),
        "singular_values": [float(x) for x in fit.singular_values[:20]],
    }


def identify_structure_ip(identifier: Any, record: Record, elements: ElementSet, mass: Any) -> Any:
    """``nsi-ip`` on a structure (module docstring); again with raised cut-offs when :func:`band_floor` asks."""
    t0 = time.perf_counter()
    est, fn_hz, motion = _identify_ip(identifier, record, elements, mass, 0.0)
    dofs = {int(k) for k in np.flatnonzero(np.any(elements.B != 0, axis=1))}
    if any(k > 0 for k in est.diagnostics["k_tilde_ensemble"]):
        dofs |= {d - 1 for d in record.force_dofs}
    floor = band_floor(motion, fn_hz, identifier.settings, record.fs, dofs)
    if floor is not None:
        first = list(motion.cutoffs_hz)
        est, _, _ = _identify_ip(identifier, record, elements, mass, floor)
        est.diagnostics["denoise_first_pass_hz"] = first
    est.diagnostics["seconds"] = time.perf_counter() - t0
    return est


def _identify_ip(
    identifier: Any, record: Record, elements: ElementSet, mass: Any, floor_hz: float
) -> tuple[Any, np.ndarray, Motion]:
    t0 = time.perf_counter()
    opt = identifier.settings
    n = record.n_dofs
    order = check_structure_options(opt, n)
    hold = opt["force_hold"] or record.force_hold
    motion = structure_motion(record, opt, floor_hz)
    columns = [(e.name, (element_basis(e, elements).func, e.b(n))) for e in elements]
    ch = structure_channels(record, motion, columns, hold, True, opt["intersample"])
    check_length(record.n, opt["block_rows"], ch.base.shape[1])
    gram, noise_info, noise = structure_gram(ch, record, motion, columns, opt)
    trials: list[dict[str, Any]] = []
    fit = identify_perturbed(ch, gram, record.dt, order, elements.B, opt, trials, mass, noise)
    members = [fit]
    if fit.k_tilde > 0 and opt["k_tilde_ensemble"] > 1:
        band = tuple(opt["band_hz"]) if opt.get("band_hz") else opt["band"]
        spread = np.linspace(fit.k_tilde, opt["k_tilde_spread"] * fit.k_tilde, opt["k_tilde_ensemble"])[1:]
        for k_tilde in spread:
            try:
                members.append(
                    fit_structure(ch, gram, record.dt, order, elements.B, band, opt["zeta_max"], k_tilde, mass, noise)
                )
            except UnstableULSError:
                trials.append({"k_tilde": float(k_tilde), "accepted": False, "ensemble": True})
    theta = np.mean([[m.coefficients[name] for name in elements.names] for m in members], axis=0)
    stiffness = []
    for m in members:
        K = m.uls.K.copy()
        for d in record.force_dofs:
            K[d - 1, d - 1] -= m.k_tilde
        stiffness.append(K)
    K = np.mean(stiffness, axis=0)
    C = np.mean([m.uls.C for m in members], axis=0)
    M_est = np.mean([m.uls.M for m in members], axis=0)
    warnings = [] if opt["force_hold"] or "force_hold" in record.meta else [HOLD_ASSUMED]
    diagnostics = {
        "variant": "input perturbation at the driven DOFs (fbar_d = f_d + k~1 z_d)",
        "k_tilde": fit.k_tilde,
        "k_tilde_ensemble": [m.k_tilde for m in members],
        "k_tilde_trials": trials,
        "uls": uls_summary(fit),
        "realisation_asymmetry": fit.uls.asymmetry,
        **noise_info,
        "order": order,
        "block_rows": opt["block_rows"],
        "velocity": motion.velocity,
        CHANNEL_SOURCES: source_entries(motion.sources),
        "denoise_cutoff_hz": list(motion.cutoffs_hz),
        "force_hold": hold,
        "mass_source": "given"
        if mass is not None
        else "estimated (second-order realisation, mean over the k~1 ensemble)",
        "seconds": time.perf_counter() - t0,
    }
    est = StructureEstimate(
        coefficients=elements.as_dict(theta),
        K=K,
        C=C,
        M=None if mass is not None else M_est,
        static=static_forces(record, motion, K, elements, theta) if elements.static else None,
        diagnostics=diagnostics,
        warnings=warnings,
        arrays=structure_arrays(fit, list(elements.names)),
    )
    return est, fit.uls.fn_hz, motion
