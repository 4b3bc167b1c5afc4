"""``nsi-shift`` on a structure: the zero reference of every polynomial connection shifted to each stable well.

For a connection ``c`` carrying polynomial elements ``theta_k x^k`` (``k >= 2``)
the relative coordinate is re-expanded about a reference ``x*_c``:
``sum_k theta_k x^k = sum_j a_j xi^j`` with ``xi = x - x*_c``. The linear part
``a_1`` joins the ULS (``K_well = K + sum_c b_c b_c^T P_c'(x*_c)``, positive
definite at a stable equilibrium even when ``K`` is not), the constant the
static force, and every power ``xi^j``, ``j = 2..kmax`` is an extended input.
The Taylor shift back (:func:`nlid_nsi.shift.taylor_shift`) gives the
``theta_k``; ``K = K_well - sum_c b_c b_c^T P_c'(x*_c)`` with the modelled
powers. Other elements keep their basis function.

References (``equilibria = auto``)
    The modes of each polynomial connection's histogram of ``x``
    (:func:`nlid_nsi.shift.histogram_modes`); a connection with several gives
    several wells (every combination, at most :data:`MAX_WELLS`). Each is then
    moved to the relative coordinate of the identified model's stable
    equilibrium nearest to it, ``iterate`` identifications per well at most.
    ``equilibria`` given: the references of the one polynomial connection.

Per well
    The ULS of the well is the linearisation there: its modes (from the
    identified ``M``, ``C_well``, ``K_well``) are reported as that well's
    linearised modes. The coefficients, ``M``, ``C``, ``K`` are the mean
    (``combine = mean``) or median over the wells.
"""

from __future__ import annotations

import itertools
import time
from typing import Any

import numpy as np

from nlid.plugin import (
    CHANNEL_SOURCES,
    ElementSet,
    IdentificationError,
    InputError,
    Record,
    StructuralModel,
    StructureEstimate,
    linear_modes,
    source_entries,
)

from .basis import int_power
from .common import HOLD_ASSUMED, check_length
from .fit import UnstableULSError
from .structure import (
    check_structure_options,
    element_basis,
    fit_structure,
    noise_sharpen,
    static_forces,
    structure_arrays,
    structure_channels,
    structure_gram,
    uls_summary,
)
from .structure_motion import Motion, band_floor, structure_motion
from .structure_noise import noise_paths, noise_variances
from .wells import histogram_modes, taylor_shift

__all__ = ["identify_structure_shift", "MAX_WELLS"]

#: Combinations of references identified at most.
MAX_WELLS = 8


def _split(elements: ElementSet) -> tuple[dict[tuple[int, int], list[tuple[int, int]]], list[int]]:
    """``{connection: [(element index, power)]}`` of the polynomial elements (power >= 2), and the others."""
    poly: dict[tuple[int, int], list[tuple[int, int]]] = {}
    others = []
    for k, e in enumerate(elements):
        power = e.term.polynomial_power
        if power is not None and power >= 2:
            poly.setdefault(e.connection, []).append((k, power))
        else:
            others.append(k)
    return poly, others


def _references(
    poly: dict, elements: ElementSet, motion: Any, given: Any
) -> tuple[list[dict[tuple[int, int], float]], str]:
    """The wells: one reference ``x*`` per polynomial connection, each combination."""
    n = elements.n_dofs
    per: dict[tuple[int, int], list[float]] = {}
    if given:
        if len(poly) != 1:
            raise InputError(
                f"equilibria= gives the references of one polynomial connection; the elements have {len(poly)}"
            )
        per[next(iter(poly))] = [float(x) for x in given]
        source = "given"
    else:
        for conn, items in poly.items():
            b = _b(conn, n)
            x = motion.z @ b
            kmax = max(p for _, p in items)
            modes = histogram_modes(x, degree=max(kmax, 2) + 1)
            per[conn] = [float(m) for m in modes] or [float(np.median(x))]
        source = "modes of each connection's histogram of x, then fixed points of the identified model"
    combos = list(itertools.product(*per.values()))[:MAX_WELLS]
    return [dict(zip(per, combo, strict=True)) for combo in combos], source


def _b(conn: tuple[int, int], n: int) -> np.ndarray:
    b = np.zeros(n)
    b[conn[0] - 1] = 1.0
    if conn[1]:
        b[conn[1] - 1] = -1.0
    return b


def _columns(poly: dict, others: list[int], elements: ElementSet, refs: dict) -> tuple[list, np.ndarray]:
    """The extended inputs of a well: ``xi_c^k`` per polynomial connection, then the other elements."""
    n = elements.n_dofs
    columns = []
    for conn, items in poly.items():
        kmax = max(p for _, p in items)
        s = refs[conn]
        for k in range(kmax, 1, -1):
            columns.append((f"xi_{conn[0]}-{conn[1]}^{k}", (lambda x, v, s=s, k=k: int_power(x - s, k), _b(conn, n))))
    for k in others:
        e = elements.elements[k]
        columns.append((e.name, (element_basis(e, elements).func, e.b(n))))
    return columns, np.column_stack([b for _, (_, b) in columns]) if columns else np.zeros((n, 0))


def _map_back(fit: Any, poly: dict, others: list[int], elements: ElementSet, refs: dict) -> tuple[np.ndarray, dict]:
    """The element coefficients in ``x`` and the polynomial powers that are not elements (``unmodelled``)."""
    theta = np.zeros(len(elements))
    unmodelled = {}
    for conn, items in poly.items():
        kmax = max(p for _, p in items)
        a = np.zeros(kmax + 1)
        for k in range(2, kmax + 1):
            a[k] = fit.coefficients[f"xi_{conn[0]}-{conn[1]}^{k}"]
        th = taylor_shift(a, -refs[conn])
        modelled = {p: k for k, p in items}
        for p in range(2, kmax + 1):
            if p in modelled:
                theta[modelled[p]] = th[p]
            else:
                unmodelled[f"x_{conn[0]}-{conn[1]}^{p}"] = float(th[p])
    for k in others:
        theta[k] = fit.coefficients[elements.names[k]]
    return theta, unmodelled


def _linear_part(poly: dict, elements: ElementSet, theta: np.ndarray, refs: dict) -> np.ndarray:
    """``sum_c b_c b_c^T P_c'(x*_c)`` of the modelled powers."""
    n = elements.n_dofs
    out = np.zeros((n, n))
    for conn, items in poly.items():
        b = _b(conn, n)
        slope = sum(p * theta[k] * refs[conn] ** (p - 1) for k, p in items)
        out += slope * np.outer(b, b)
    return out


def identify_structure_shift(identifier: Any, record: Record, elements: ElementSet, mass: Any) -> Any:
    """``nsi-shift`` on a structure (module docstring); again with raised cut-offs when :func:`band_floor` asks."""
    t0 = time.perf_counter()
    opt = identifier.settings
    check_structure_options(opt, record.n_dofs)
    motion = structure_motion(record, opt)
    # the noise floors of the measured channels serve both passes (the noise paths change with the cut-offs)
    variances = noise_variances(record, motion) if opt["noise_correction"] else None
    # the first pass only places the band and the references: one identification per well
    _, fn_hz, refs = _identify_shift(identifier, record, elements, mass, motion, variances, iterate=1)
    dofs = {int(k) for k in np.flatnonzero(np.any(elements.B != 0, axis=1))}
    floor = band_floor(motion, fn_hz, opt, record.fs, dofs)
    # without a raised floor the second pass de-noises exactly as the first: its motion is reused
    second = motion if floor is None else structure_motion(record, opt, floor, motion.suggested_hz)
    est, _, _ = _identify_shift(identifier, record, elements, mass, second, variances, start=refs)
    if floor is not None:
        est.diagnostics["denoise_first_pass_hz"] = list(motion.cutoffs_hz)
    est.diagnostics["seconds"] = time.perf_counter() - t0
    return est


def _identify_shift(
    identifier: Any,
    record: Record,
    elements: ElementSet,
    mass: Any,
    motion: Motion,
    variances: Any,
    iterate: int | None = None,
    start: list[dict] | None = None,
) -> tuple[Any, np.ndarray, list[dict]]:
    """One pass on ``motion``: at most ``iterate`` identifications per well from the references ``start`` (or found).

    The noise paths of the motion (:func:`nlid_nsi.structure_noise.noise_paths`, from the record's noise
    ``variances``) are computed once and serve every well and iteration: only the extended inputs change
    with the reference.
    """
    t0 = time.perf_counter()
    opt = identifier.settings
    n = record.n_dofs
    order = check_structure_options(opt, n)
    hold = opt["force_hold"] or record.force_hold
    band = tuple(opt["band_hz"]) if opt.get("band_hz") else opt["band"]
    paths = None
    if opt["noise_correction"]:
        paths = noise_paths(record, motion, opt["noise_max_lag"], noise_sharpen(opt), variances)
    poly, others = _split(elements)
    wells_refs, source = _references(poly, elements, motion, opt["equilibria"])
    if start:
        wells_refs = start
    iterate = iterate or opt["iterate"]
    following: list[dict] = []
    z_range = [(float(lo), float(hi)) for lo, hi in zip(record.z.min(axis=0), record.z.max(axis=0), strict=True)]
    wells: list[dict[str, Any]] = []
    warnings: list[str] = [] if opt["force_hold"] or "force_hold" in record.meta else [HOLD_ASSUMED]
    arrays: dict[str, np.ndarray] = {}
    identifications = 0
    for refs in wells_refs:
        history = [dict(refs)]
        nxt = dict(refs)
        try:
            for it in range(iterate):
                columns, connectivity = _columns(poly, others, elements, refs)
                ch = structure_channels(record, motion, columns, hold, False, opt["intersample"])
                check_length(record.n, opt["block_rows"], ch.base.shape[1])
                gram, noise_info, noise = structure_gram(ch, record, motion, columns, opt, paths)
                fit = fit_structure(ch, gram, record.dt, order, connectivity, band, opt["zeta_max"], 0.0, mass, noise)
                identifications += 1
                theta, unmodelled = _map_back(fit, poly, others, elements, refs)
                K = fit.uls.K - _linear_part(poly, elements, theta, refs)
                M = fit.uls.M if mass is None else np.asarray(mass, dtype=float)
                static = static_forces(record, motion, K, elements, theta)
                model = StructuralModel(M, fit.uls.C, K, elements, elements.as_dict(theta), static)
                stable = [np.asarray(z) for z in model.equilibria(z_range).stable]
                if not stable or not poly:
                    z_eq = stable[0] if stable else np.zeros(n)
                    break
                dist = [sum(abs(float(z @ _b(c, n)) - refs[c]) for c in poly) for z in stable]
                z_eq = stable[int(np.argmin(dist))]
                new = {c: float(z_eq @ _b(c, n)) for c in poly}
                nxt = new
                scale = max(float(np.std(motion.z)), 1e-12)
                if all(abs(new[c] - refs[c]) <= 1e-7 * scale for c in poly) or it == iterate - 1:
                    break
                refs = new
                history.append(dict(refs))
        except UnstableULSError as exc:
            warnings.append(f"references {_text(refs)}: {exc}")
            continue
        following.append(nxt)
        suffix = "" if not wells else f"@well{len(wells)}"
        names = [c[0] for c in columns]
        arrays.update(structure_arrays(fit, names, suffix))
        wells.append(
            {
                "references": _text(refs),
                "reference_history": [_text(h) for h in history],
                "equilibrium": [float(x) for x in z_eq],
                "coefficients": elements.as_dict(theta),
                "unmodelled": unmodelled,
                "M": M,
                "C": fit.uls.C,
                "K": K,
                "K_well": fit.uls.K,
                "uls": uls_summary(fit),
            }
        )
    if not wells:
        raise IdentificationError(
            "nsi-shift: no zero reference gave a stable underlying linear system: " + "; ".join(warnings)
        )
    agg = np.median if opt["combine"] == "median" else np.mean
    theta = agg([elements.vector(w["coefficients"]) for w in wells], axis=0)
    M, C, K = (agg([w[key] for w in wells], axis=0) for key in ("M", "C", "K"))
    modes = [
        linear_modes(w["M"], w["C"], w["K_well"], w["equilibrium"], "ULS of the well (zero reference shifted to it)")
        for w in wells
    ]
    diagnostics = {
        "variant": "zero reference of each polynomial connection shifted to each stable well",
        "wells": [{k: v for k, v in w.items() if k not in ("M", "C", "K", "K_well")} for w in wells],
        "references_source": source,
        "identifications": identifications,
        "combine": opt["combine"],
        "order": order,
        "block_rows": opt["block_rows"],
        "velocity": motion.velocity,
        CHANNEL_SOURCES: source_entries(motion.sources),
        "denoise_cutoff_hz": list(motion.cutoffs_hz),
        "force_hold": hold,
        **noise_info,
        "mass_source": "given" if mass is not None else f"estimated ({opt['combine']} of the wells' ULS)",
        "arrays_note": "no suffix: first well; '@wellN': well N+1 (spectra of the shifted inputs xi^k)",
        "seconds": time.perf_counter() - t0,
    }
    est = StructureEstimate(
        coefficients=elements.as_dict(theta),
        K=K,
        C=C,
        M=None if mass is not None else M,
        static=static_forces(record, motion, K, elements, theta) if elements.static else None,
        modes=modes,
        diagnostics=diagnostics,
        warnings=warnings,
        arrays=arrays,
    )
    fn_hz = np.concatenate([np.asarray(w["uls"]["fn_hz"], dtype=float) for w in wells])
    return est, fn_hz, following


def _text(refs: dict) -> dict[str, float]:
    return {f"{i}-{j}": float(x) for (i, j), x in refs.items()}
