"""Continuing a forced response: from a fitted model to :class:`~nlid.response.curves.ResponseCurve` objects.

For each force amplitude and each stable equilibrium the curve starts at the
low end of the band from the linearised response around that equilibrium
(refined by Newton's method at that frequency), and is continued in frequency
to the high end (:class:`~nlid.response.continuation.Continuation`), every
point checked by Hill's method. :func:`continue_force` does the same in the
force amplitude at a fixed frequency.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from .balance import Balance, time_residual
from .continuation import Branch, Continuation
from .curves import ResponseCurve, SpecialPoint, motion_labels
from .system import HarmonicSystem

__all__ = ["Settings", "continue_frequency", "continue_force"]


@dataclass(frozen=True)
class Settings:
    """How a response is computed.

    Attributes
    ----------
    harmonics
        Number of harmonics ``H`` (with the constant term).
    samples
        Samples (or quadrature intervals) per period; ``None``: :func:`~nlid.response.harmonics.default_samples`.
    memory_samples
        Samples per period along which a memory state is integrated; ``None``: the default.
    step, max_points
        Largest continuation step (scaled arclength) and most points per curve.
    regularisation
        ``None``: Coulomb signs exactly, and where that fails (a sticking phase) the curve is computed
        again with ``sign(v)`` replaced by ``tanh(v / eps)``, ``eps`` :data:`REGULARISATION` times the
        largest linearised velocity amplitude in the band, which the result states; a number: that
        ``eps`` (m/s) for every curve; ``0``: never.
    """

    harmonics: int = 7
    samples: int | None = None
    memory_samples: int | None = None
    step: float = 0.05
    max_points: int = 2000
    regularisation: float | None = None


#: The regularisation scale of a sticking Coulomb term, as a fraction of the largest linearised velocity amplitude.
REGULARISATION = 1e-3


def _linear_guess(system: HarmonicSystem, balance: Balance, z0: np.ndarray, omega: float, force: float) -> np.ndarray:
    """The linearised response at ``z0`` to ``force cos(omega t)`` as starting coefficients ``(n P,)``."""
    K = system.stiffness(z0)
    C = system.C.copy()
    for g in system.groups:
        if g.memory or not g.uses_velocity:
            continue
        from ..model.terms.slopes import slopes

        x = np.atleast_1d(g.b @ z0)
        for t, th in zip(g.terms, g.theta, strict=True):
            c = slopes(t, x, np.array([1e-6]), g.pxc)[2][0]
            if np.isfinite(c) and t.slope_at_rest()[0] == "linear":
                C = C + th * c * np.outer(g.b, g.b)
    H = np.linalg.solve(K - omega**2 * system.M + 1j * omega * C, force * balance.pattern)
    X = np.zeros((system.n, balance.P))
    X[:, 0] = z0
    X[:, 1] = H.real
    X[:, 2] = -H.imag  # H e^{i w t} = Re(H) cos - Im(H) sin
    return X.ravel()


def _scale(system: HarmonicSystem, balance: Balance, z0: np.ndarray, band: tuple[float, float], force: float) -> float:
    """A displacement scale: the largest linearised amplitude over the band (with at least 1 % damping)."""
    K = system.stiffness(z0)
    lam = np.linalg.eigvals(np.linalg.solve(system.M, K))
    wn = np.sqrt(np.abs(lam.real)) + 1e-12
    w = np.linspace(band[0], band[1], 64)
    w = np.concatenate([w, wn[(wn > band[0]) & (wn < band[1])]])
    C = system.C + 0.02 * np.sqrt(np.abs(np.diag(K) * np.diag(system.M))).mean() * np.eye(system.n)
    amp = [np.max(np.abs(np.linalg.solve(K - x**2 * system.M + 1j * x * C, force * balance.pattern))) for x in w]
    return float(max(max(amp), 1e-12))


def _curve(balance: Balance, branch: Branch, parameter: str, fixed: float, start, labels_of) -> ResponseCurve:
    P, n = balance.P, balance.n
    Y = np.array(branch.y)
    coeffs = Y[:, :-1].reshape(-1, n, P)
    par = Y[:, -1]
    if parameter == "frequency":
        omega, force = par, np.full(par.size, fixed)
    else:
        omega, force = np.full(par.size, fixed), par
    flo = [a for a in branch.aux]
    stable = np.array([f.stable for f in flo], dtype=bool)
    mult = np.array([f.multiplier for f in flo])
    kinds = tuple(f.kind for f in flo)
    events = []
    amp1 = balance.basis.amplitude(coeffs)
    for e in branch.events:
        i = min(e.index, len(par) - 1)
        if e.kind == "fold":
            a = tuple(float(x) for x in amp1[i])
            events.append(SpecialPoint("fold", float(omega[i] / (2 * np.pi)), float(force[i]), a, i))
        else:
            yc = e.y[:-1].reshape(n, P)
            p = e.y[-1]
            w = p if parameter == "frequency" else fixed
            f = fixed if parameter == "frequency" else p
            a = tuple(float(x) for x in balance.basis.amplitude(yc))
            events.append(SpecialPoint(e.kind, float(w / (2 * np.pi)), float(f), a, i))
    # bifurcations not caught as folds or branch points: a change of stability with a flip or complex multiplier
    for i in range(1, len(stable)):
        if stable[i - 1] and not stable[i] and kinds[i] in ("flip", "complex"):
            kind = "flip" if kinds[i] == "flip" else "torus"
            events.append(SpecialPoint(kind, float(omega[i] / (2 * np.pi)), float(force[i]), tuple(amp1[i]), i))
        elif stable[i] and not stable[i - 1] and kinds[i - 1] in ("flip", "complex"):
            kind = "flip" if kinds[i - 1] == "flip" else "torus"
            events.append(SpecialPoint(kind, float(omega[i] / (2 * np.pi)), float(force[i]), tuple(amp1[i]), i))
    events.sort(key=lambda e: e.index)
    sys_ = balance.system
    miss = np.array(
        [time_residual(sys_, coeffs[k], omega[k], force[k], balance.pattern, balance.basis) for k in range(len(par))]
    )
    return ResponseCurve(
        parameter=parameter,
        frequency_hz=omega / (2 * np.pi),
        force=force,
        coefficients=coeffs,
        stable=stable,
        multiplier=mult,
        instability=kinds,
        labels=tuple(labels_of(coeffs)),
        start=tuple(float(x) for x in start),
        events=tuple(events),
        stopped=branch.stopped,
        dofs=balance.system.dofs,
        newton=branch.newton,
        rejected=branch.rejected,
        truncation=miss,
    )


def _problem(balance: Balance, parameter: str, fixed: float):
    def problem(y: np.ndarray):
        X, p = y[:-1], y[-1]
        omega, amp = (p, fixed) if parameter == "frequency" else (fixed, p)
        r, J, dw, dF, forces = balance.evaluate(X, omega, amp)
        col = dw if parameter == "frequency" else dF
        return r, np.column_stack([J, col]), (X, omega, forces)

    return problem


class _Floquet:
    """Wraps a problem so that each point's ``aux`` becomes Hill's verdict, computed once per kept point."""

    def __init__(self, balance: Balance, problem):
        self.balance, self.problem = balance, problem

    def __call__(self, y: np.ndarray):
        r, J, (X, omega, forces) = self.problem(y)
        return r, J, _Lazy(self.balance, X, omega, forces)


class _Lazy:
    __slots__ = ("args", "_value")

    def __init__(self, balance, X, omega, forces):
        self.args = (balance, X, omega, forces)
        self._value = None

    def value(self):
        if self._value is None:
            balance, X, omega, forces = self.args
            self._value = balance.floquet(X, omega, forces)
        return self._value


def _finish(branch: Branch) -> Branch:
    branch.aux = [a.value() for a in branch.aux]
    return branch


def continue_frequency(
    system: HarmonicSystem,
    force: float,
    band_hz: Sequence[float],
    start: np.ndarray,
    settings: Settings,
    pattern: np.ndarray,
    *,
    saddles: tuple[float, ...] = (),
    wells: tuple[float, ...] = (),
) -> ResponseCurve:
    """The response to ``force cos(omega t)`` over ``band_hz`` from the equilibrium ``start`` (module docstring).

    A system with Coulomb signs is regularised where the exact computation fails (:class:`Settings`);
    ``curve.meta["regularisation"]`` then holds the scale and why.

    Raises
    ------
    InputError
        When Newton's method finds no periodic solution at the band's low end.
    """
    eps = settings.regularisation
    lo, hi = 2 * np.pi * float(band_hz[0]), 2 * np.pi * float(band_hz[1])
    if eps is None or eps == 0 or not system.jumps:
        curve, why = _frequency_curve(system, force, band_hz, start, settings, pattern, saddles, wells)
        if not (system.jumps and eps is None and why):
            if curve is None:
                raise InputError(why)
            return curve
        probe = Balance(system, 1, pattern)
        eps = REGULARISATION * hi * _scale(system, probe, start, (lo, hi), force)
        why = why or curve.stopped
    else:
        why = "asked"
    curve, failed = _frequency_curve(system.regularised(eps), force, band_hz, start, settings, pattern, saddles, wells)
    if curve is None:
        raise InputError(failed)
    curve.meta["regularisation"] = (float(eps), why)
    return curve


def _frequency_curve(system, force, band_hz, start, settings, pattern, saddles, wells):
    """``(curve, "")``; ``(None, why)`` when no start is found; ``(curve, why)`` when a Coulomb system's corrector
    failed before the band's end (the caller may regularise)."""
    balance = Balance(system, settings.harmonics, pattern, settings.samples, settings.memory_samples)
    lo, hi = 2 * np.pi * float(band_hz[0]), 2 * np.pi * float(band_hz[1])
    x_ref = _scale(system, balance, start, (lo, hi), force)
    scale = np.r_[np.full(balance.size, x_ref), hi - lo]
    problem = _Floquet(balance, _problem(balance, "frequency", force))
    cont = Continuation(
        problem, scale, max(abs(force), 1e-12), (lo, hi), h_max=settings.step, max_points=settings.max_points
    )
    first, top = None, False
    for omega in (lo, hi):  # from the low end; failing that, from the high end (downwards)
        first = _start(cont, system, balance, start, omega, force, settings, pattern)
        if first is not None:
            top = omega == hi
            break
    if first is None:
        return None, (
            f"no periodic response found at {band_hz[0]:g} Hz or {band_hz[1]:g} Hz for force {force:g} N from the "
            f"equilibrium {np.round(start, 6).tolist()} (try another band=, or more harmonics=)"
        )
    branch = _finish(cont.run(first, -1.0 if top else +1.0))
    if top:
        branch = _reversed(branch)
    labels = (lambda c: motion_labels(c[:, 0, :], saddles, wells)) if system.n == 1 else (lambda c: [""] * len(c))
    curve = _curve(balance, branch, "frequency", force, start, labels)
    curve.meta.update(calls=cont.calls, x_ref=x_ref, jumps=system.jumps)
    failed = system.jumps and branch.stopped.startswith("the step fell")
    return curve, (branch.stopped if failed else "")


def _start(cont: Continuation, system, balance, start, omega: float, force: float, settings, pattern):
    """A solved first point at ``omega``: Newton from the linearised response, else after a ramp of the force."""
    first = cont.solve_at(np.r_[_linear_guess(system, balance, start, omega, force), omega])
    if first is None:  # grow the force from a hundredth at this frequency (past folds in the force, if any)
        try:
            ramp = continue_force(system, omega / (2 * np.pi), (0.01 * force, force), start, settings, pattern)
        except InputError:
            ramp = None
        if ramp is not None and ramp.force[-1] >= force * (1 - 1e-9):
            first = cont.solve_at(np.r_[ramp.coefficients[-1].ravel(), omega])
    return first


def _reversed(branch: Branch) -> Branch:
    """A branch continued from the high end, put in the order of increasing frequency at its start."""
    n = len(branch.y)
    out = Branch(
        y=branch.y[::-1],
        tangents=[-t for t in branch.tangents[::-1]],
        aux=branch.aux[::-1],
        folds=[n - 1 - i for i in branch.folds],
        stopped=branch.stopped.replace("turned back to the start", "reached the start of the range from its end"),
        newton=branch.newton,
        rejected=branch.rejected,
    )
    out.events = [
        type(e)(e.kind, max(0, n - 1 - e.index if e.kind == "fold" else n - e.index), e.y) for e in branch.events
    ]
    return out


def continue_force(
    system: HarmonicSystem,
    frequency_hz: float,
    forces: Sequence[float],
    start: np.ndarray,
    settings: Settings,
    pattern: np.ndarray,
    *,
    saddles: tuple[float, ...] = (),
    wells: tuple[float, ...] = (),
) -> ResponseCurve:
    """The response at ``frequency_hz`` continued in the force amplitude over ``forces = (low, high)``."""
    balance = Balance(system, settings.harmonics, pattern, settings.samples, settings.memory_samples)
    omega = 2 * np.pi * float(frequency_hz)
    f_lo, f_hi = float(min(forces)), float(max(forces))
    if not f_hi > f_lo >= 0:
        raise InputError(f"forces= must be (low, high) with 0 <= low < high, got {tuple(forces)}")
    x_ref = _scale(system, balance, start, (0.5 * omega, 1.5 * omega), f_hi)
    scale = np.r_[np.full(balance.size, x_ref), f_hi - f_lo]
    problem = _Floquet(balance, _problem(balance, "force", omega))
    cont = Continuation(problem, scale, f_hi, (f_lo, f_hi), h_max=settings.step, max_points=settings.max_points)
    guess = np.r_[_linear_guess(system, balance, start, omega, f_lo), f_lo]
    first = cont.solve_at(guess)
    if first is None:
        raise InputError(f"no periodic response found at {frequency_hz:g} Hz for force {f_lo:g} N")
    branch = _finish(cont.run(first, +1.0))
    labels = (lambda c: motion_labels(c[:, 0, :], saddles, wells)) if system.n == 1 else (lambda c: [""] * len(c))
    return _curve(balance, branch, "force", omega, start, labels)
