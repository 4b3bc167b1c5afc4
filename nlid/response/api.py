"""The entry points: :func:`frequency_response`, :func:`force_response` and :func:`backbone`.

Each takes a fitted model (:class:`nlid.IdentifiedModel`,
:class:`nlid.identified.structure.IdentifiedStructure` or :class:`nlid.model.structure.StructuralModel`),
checks its arguments once, and runs the harmonic balance with one BLAS thread
(the matrices are small: a thread pool only adds waiting).
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from typing import Any

import numpy as np

from ..errors import InputError
from .backbone import TRUNCATION, Backbone, backbones
from .curves import ResponseCurve
from .fitted import Fitted, as_fitted
from .harmonics import default_samples
from .result import FrequencyResponse
from .solve import Settings, continue_force, continue_frequency
from .system import HarmonicSystem

__all__ = ["frequency_response", "force_response", "backbone", "check_band", "check_forces"]

#: Most harmonics.
MAX_HARMONICS = 64


def check_band(band: Sequence[float] | str) -> tuple[float, float]:
    """``(low, high)`` in Hz from a pair or ``"5:30"``, with ``0 < low < high``."""
    if isinstance(band, str):
        parts = band.replace(",", ":").split(":")
        try:
            band = tuple(float(p) for p in parts)
        except ValueError:
            raise InputError(f"band= must be 'low:high' in Hz, got {band!r}") from None
    try:
        lo, hi = (float(x) for x in band)
    except (TypeError, ValueError):
        raise InputError(f"band= must be (low, high) in Hz, got {band!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo < hi):
        raise InputError(f"band= must satisfy 0 < low < high (Hz), got ({lo:g}, {hi:g})")
    return lo, hi


def check_forces(force: float | Sequence[float] | str) -> tuple[float, ...]:
    """Force amplitudes (N) from a number, a sequence or ``"0.5,1,2"``; each positive and finite."""
    if isinstance(force, str):
        try:
            force = [float(x) for x in force.split(",") if x.strip()]
        except ValueError:
            raise InputError(f"force= must be amplitudes in N such as '0.5,1,2', got {force!r}") from None
    values = [force] if isinstance(force, (int, float, np.floating)) else list(force)
    out = []
    for x in values:
        if isinstance(x, bool) or not isinstance(x, (int, float, np.floating)) or not math.isfinite(x) or x <= 0:
            raise InputError(f"force= amplitudes must be positive numbers of N, got {x!r}")
        out.append(float(x))
    if not out:
        raise InputError("force= needs at least one amplitude")
    return tuple(out)


def _settings(harmonics: int, settings: Settings | None) -> Settings:
    if (
        isinstance(harmonics, bool)
        or not isinstance(harmonics, (int, np.integer))
        or not 1 <= harmonics <= MAX_HARMONICS
    ):
        raise InputError(f"harmonics= must be an integer from 1 to {MAX_HARMONICS}, got {harmonics!r}")
    base = settings or Settings()
    if not isinstance(base, Settings):
        raise InputError(f"settings= must be nlid.response.Settings, got {type(base).__name__}")
    for name, low in (("samples", 8), ("memory_samples", 8)):
        value = getattr(base, name)
        if value is not None and (isinstance(value, bool) or not isinstance(value, int) or value < low):
            raise InputError(f"settings= {name} must be an integer of at least {low} (or None), got {value!r}")
    if not (isinstance(base.step, (int, float)) and 0 < base.step <= 1):
        raise InputError(f"settings= step must be in (0, 1], got {base.step!r}")
    if isinstance(base.max_points, bool) or not isinstance(base.max_points, int) or base.max_points < 2:
        raise InputError(f"settings= max_points must be an integer of at least 2, got {base.max_points!r}")
    eps = base.regularisation
    if eps is not None and not (isinstance(eps, (int, float)) and math.isfinite(eps) and eps >= 0):
        raise InputError(f"settings= regularisation must be a velocity scale >= 0 (m/s) or None, got {eps!r}")
    import dataclasses

    return dataclasses.replace(base, harmonics=int(harmonics))


def _notes(system: HarmonicSystem, settings: Settings, curves: Sequence[ResponseCurve] = ()) -> tuple[str, ...]:
    out = []
    for i, c in enumerate(curves):
        if "regularisation" in c.meta:
            eps, why = c.meta["regularisation"]
            reason = "as asked" if why == "asked" else f"where the exact sign failed, a sticking phase ({why})"
            out.append(f"curve {i}: sign(v) regularised as tanh(v/{eps:.3g} m/s), {reason}")
    n = settings.samples or default_samples(settings.harmonics)
    if system.jumps:
        some = " except where a curve above says otherwise" if out else ""
        out.append(
            f"jumping terms (Coulomb sign factors) integrated exactly between the crossings of the motion "
            f"(composite Gauss rule, {n} intervals per period), no regularisation{some}"
        )
    elif not system.smooth:
        out.append(f"non-smooth terms integrated between their kinks (composite Gauss rule, {n} intervals per period)")
    if system.uses_memory:
        m = settings.memory_samples or default_samples(settings.harmonics, memory=True)
        out.append(f"memory states integrated to their periodic regime along {m} samples per period")
    return tuple(out)


def _starts(
    fitted: Fitted, system: HarmonicSystem, starts
) -> tuple[list[np.ndarray], list[np.ndarray], list[np.ndarray]]:
    stable, unstable = fitted.stable_unstable()
    if starts is None:
        chosen = stable or [np.zeros(system.n)]
    else:
        try:
            chosen = (
                [np.atleast_1d(np.asarray(s, dtype=float)).reshape(system.n) for s in np.atleast_1d(starts)]
                if system.n == 1
                else [np.asarray(s, dtype=float).reshape(system.n) for s in starts]
            )
        except (TypeError, ValueError):
            raise InputError(f"starts= must be equilibria of {system.n} displacement(s) each, got {starts!r}") from None
        if not chosen or not all(np.all(np.isfinite(s)) for s in chosen):
            raise InputError(f"starts= must be finite equilibria, got {starts!r}")
    return chosen, stable, unstable


def _modes_in(system: HarmonicSystem, stable: list[np.ndarray], band: tuple[float, float]) -> list[int]:
    """The linear modes (1-based) whose frequency at some stable equilibrium lies within the band widened by half."""
    from scipy.linalg import eigh

    out = set()
    for z0 in stable:
        w2 = eigh(system.stiffness(z0), system.M, eigvals_only=True)
        f = np.sqrt(np.abs(w2)) / (2 * np.pi)
        out |= {j + 1 for j, x in enumerate(f) if 0.5 * band[0] <= x <= 1.5 * band[1]}
    return sorted(out) or [1]


def frequency_response(
    model: Any,
    force: float | Sequence[float] | str,
    band: Sequence[float] | str,
    *,
    harmonics: int = 7,
    dof: int | Sequence[float] | None = None,
    starts: Sequence[Any] | None = None,
    backbone: bool = True,
    settings: Settings | None = None,
) -> FrequencyResponse:
    """The periodic response to ``F cos(2 pi f t)`` for each force amplitude ``F`` over a frequency band.

    Parameters
    ----------
    model
        An :class:`nlid.IdentifiedModel` (with its mass), an :class:`nlid.identified.structure.IdentifiedStructure` or
        an :class:`nlid.model.structure.StructuralModel`.
    force
        Force amplitudes (N): a number, a sequence or ``"0.5,1,2"``. For a base-excited rig
        (``f = -m b''``) the amplitude is ``m`` times that of the base acceleration.
    band
        ``(low, high)`` Hz or ``"5:30"``; each curve is continued from ``low`` to ``high``.
    harmonics
        Number of harmonics ``H`` (the constant term is always included).
    dof
        Where the force acts on a structure: a DOF number (default 1) or a weight per DOF.
    starts
        Equilibria to start from (default: every stable one, so a double well gets a curve per well).
    backbone
        Also compute the backbones of the conservative part (:func:`backbone`).
    settings
        Quadrature sizes and continuation steps (:class:`~nlid.response.solve.Settings`).

    Returns
    -------
    FrequencyResponse

    Raises
    ------
    InputError
        A bad argument, or no periodic solution at the band's low end.
    """
    from threadpoolctl import threadpool_limits

    forces = check_forces(force)
    lo, hi = check_band(band)
    settings = _settings(harmonics, settings)
    fitted = as_fitted(model)
    system = fitted.system()
    pattern = system.force_vector(dof)
    chosen, stable, unstable = _starts(fitted, system, starts)
    saddles = tuple(float(u[0]) for u in unstable) if system.n == 1 else ()
    wells = tuple(float(s[0]) for s in stable) if system.n == 1 else ()
    t0 = time.perf_counter()
    curves: list[ResponseCurve] = []
    missing: list[str] = []
    with threadpool_limits(limits=1):
        for F in forces:
            for z0 in chosen:
                try:
                    curves.append(
                        continue_frequency(system, F, (lo, hi), z0, settings, pattern, saddles=saddles, wells=wells)
                    )
                except InputError as exc:
                    missing.append(str(exc))
        if not curves:
            raise InputError(missing[0])
        bbs: list[Backbone] = []
        if backbone and not system.uses_memory:  # a hysteretic (memory) term has no conservative part
            top = max(float(np.max(c.basis.amplitude(c.coefficients))) for c in curves)
            bbs = backbones(
                system,
                stable or chosen,
                unstable,
                1.2 * top,
                harmonics=settings.harmonics,
                modes=_modes_in(system, stable or chosen, (lo, hi)),
                samples=settings.samples,
            )
    return FrequencyResponse(
        curves=tuple(curves),
        band_hz=(lo, hi),
        harmonics=settings.harmonics,
        samples=settings.samples or default_samples(settings.harmonics),
        dofs=system.dofs,
        forced=tuple(float(x) for x in pattern),
        notes=tuple(f"no curve: {m}" for m in missing) + _notes(system, settings, curves),
        backbones=tuple(bbs),
        seconds=time.perf_counter() - t0,
        model=fitted,
        settings=settings,
    )


def force_response(
    model: Any,
    frequency_hz: float,
    forces: Sequence[float],
    *,
    harmonics: int = 7,
    dof: int | Sequence[float] | None = None,
    starts: Sequence[Any] | None = None,
    settings: Settings | None = None,
) -> FrequencyResponse:
    """The response at one frequency continued in the force amplitude from ``forces[0]`` to ``forces[1]`` (N)."""
    from threadpoolctl import threadpool_limits

    if not (isinstance(frequency_hz, (int, float)) and math.isfinite(frequency_hz) and frequency_hz > 0):
        raise InputError(f"frequency_hz= must be a positive number of Hz, got {frequency_hz!r}")
    settings = _settings(harmonics, settings)
    fitted = as_fitted(model)
    system = fitted.system()
    pattern = system.force_vector(dof)
    chosen, stable, unstable = _starts(fitted, system, starts)
    saddles = tuple(float(u[0]) for u in unstable) if system.n == 1 else ()
    wells = tuple(float(s[0]) for s in stable) if system.n == 1 else ()
    t0 = time.perf_counter()
    with threadpool_limits(limits=1):
        curves = [
            continue_force(system, frequency_hz, forces, z0, settings, pattern, saddles=saddles, wells=wells)
            for z0 in chosen
        ]
    return FrequencyResponse(
        curves=tuple(curves),
        band_hz=(float(frequency_hz), float(frequency_hz)),
        harmonics=settings.harmonics,
        samples=settings.samples or default_samples(settings.harmonics),
        dofs=system.dofs,
        forced=tuple(float(x) for x in pattern),
        notes=_notes(system, settings, curves),
        seconds=time.perf_counter() - t0,
        model=fitted,
        settings=settings,
    )


def backbone(
    model: Any,
    amplitude: float,
    *,
    harmonics: int = 7,
    modes: Sequence[int] | None = None,
    step: float = 0.02,
    truncation: float | None = TRUNCATION,
) -> list[Backbone]:
    """The backbone curves of a model's conservative part up to a first-harmonic ``amplitude`` (m).

    One per linear mode (``modes=``, 1-based) at each stable equilibrium, and for a one-DOF double well
    the cross-well backbone too (:mod:`nlid.response.backbone`). Each stops where its harmonics no longer
    hold (``truncation=``, :data:`~nlid.response.backbone.TRUNCATION`; ``None``: only at the amplitude).
    """
    from threadpoolctl import threadpool_limits

    if not (isinstance(amplitude, (int, float)) and math.isfinite(amplitude) and amplitude > 0):
        raise InputError(f"amplitude= must be a positive number of m, got {amplitude!r}")
    settings = _settings(harmonics, None)
    fitted = as_fitted(model)
    system = fitted.system()
    stable, unstable = fitted.stable_unstable()
    with threadpool_limits(limits=1):
        return backbones(
            system,
            stable or [np.zeros(system.n)],
            unstable,
            float(amplitude),
            harmonics=settings.harmonics,
            modes=modes,
            step=step,
            truncation=truncation,
        )
