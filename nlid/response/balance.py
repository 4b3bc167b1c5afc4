"""The harmonic-balance equations of a system, their Jacobian, and Hill's stability of a solution.

With the motion ``z(tau) = X phi(tau)`` (``X`` of shape ``(n, P)``, one row
per DOF) and ``tau = omega t``, the residual of the equations of motion
projected on the basis is

    r(X, omega) = omega^2 M X D^2' + omega C X D' + K X + s e_0' + sum_c b_c F_c(X) - F e_f e_1'

(``e_f`` the force pattern, ``F`` its amplitude, the force ``F cos omega t``).
:class:`Balance` evaluates ``r``, ``dr/dX`` (exact: the AFT Jacobians of
:mod:`nlid.response.aft`), ``dr/domega`` and ``dr/dF``.

Stability (:meth:`Balance.floquet`) is Hill's method on the first-order form
of the equations linearised along the periodic solution: the perturbation
``e^(lambda t) p(t)`` with ``p`` periodic gives the eigenproblem
``lambda p = (A - omega D) p`` in the coefficients, ``A`` the AFT of the
state matrix ``[[0, I], [-M^-1 K_t(t), -M^-1 C_t(t)]]`` (a memory state adds
its own rows: ``w' = h(w, v)``). Of its ``d (2H + 1)`` eigenvalues, each
Floquet exponent appears with its copies shifted by ``i k omega`` (the same
multiplier); the truncation adds eigenvalues without copies. The exponents
are the ``d`` largest groups of copies (:func:`_exponents`); the multipliers
are ``exp(lambda T)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .aft import Evaluator, GroupForce
from .harmonics import Harmonics
from .system import HarmonicSystem

__all__ = ["Balance", "Floquet"]


@dataclass(frozen=True)
class Floquet:
    """Hill's verdict on one periodic solution.

    Attributes
    ----------
    exponents
        The Floquet exponents (1/s), ``d`` of them.
    stable
        ``True`` when every exponent has a negative real part.
    multiplier
        The largest modulus of the multipliers ``exp(lambda T)``.
    kind
        Which way the critical multiplier leaves the unit circle when it is
        unstable: ``"real"`` (through +1: a fold or a branch point),
        ``"flip"`` (through -1: period doubling) or ``"complex"`` (a pair:
        Neimark-Sacker, quasi-periodic motion); ``""`` when stable.
    """

    exponents: np.ndarray
    stable: bool
    multiplier: float
    kind: str = ""


class Balance:
    """The harmonic-balance equations of a :class:`HarmonicSystem` (module docstring).

    Parameters
    ----------
    system
        The equations of motion.
    harmonics
        Number of harmonics ``H``.
    force
        The force pattern per DOF (unit amplitude).
    samples, memory_samples
        Quadrature sizes (:class:`~nlid.response.aft.Evaluator`).
    """

    def __init__(
        self,
        system: HarmonicSystem,
        harmonics: int,
        force: np.ndarray,
        samples: int | None = None,
        memory_samples: int | None = None,
    ):
        self.system = system
        self.basis = Harmonics(int(harmonics))
        self.evaluator = Evaluator(system, self.basis, samples, memory_samples)
        self.pattern = np.asarray(force, dtype=float)
        n, P = system.n, self.basis.P
        self.n, self.P = n, P
        D = self.basis.D
        self.D, self.D2 = D, D @ D
        self.linear = (np.kron(system.M, self.D2), np.kron(system.C, D), np.kron(system.K, np.eye(P)))
        self.unit = np.zeros((n, P))
        self.unit[:, 1] = self.pattern  # F cos(omega t)

    @property
    def size(self) -> int:
        """Number of unknown coefficients, ``n P``."""
        return self.n * self.P

    def evaluate(self, X: np.ndarray, omega: float, amplitude: float) -> tuple:
        """``(r, dr/dX, dr/domega, dr/dF, forces)`` at flat coefficients ``X`` (``n P``)."""
        sys_ = self.system
        Xm = X.reshape(self.n, self.P)
        Mlin, Clin, Klin = self.linear
        MX = sys_.M @ Xm
        CX = sys_.C @ Xm
        r = (omega**2) * (MX @ self.D2.T) + omega * (CX @ self.D.T) + sys_.K @ Xm
        r[:, 0] += sys_.static
        r -= amplitude * self.unit
        J = (omega**2) * Mlin + omega * Clin + Klin
        dw = (2 * omega * (MX @ self.D2.T) + CX @ self.D.T).ravel()
        forces = self.evaluator.forces(Xm, omega)
        one = self.n == 1
        for g, f in zip(sys_.groups, forces, strict=True):
            b = g.b
            Jg = f.Jx + omega * (f.Jv @ self.D) if g.uses_velocity else f.Jx
            if one:
                r[0] += f.F
                J += Jg
                if g.uses_velocity:
                    dw += f.Jv @ (self.D @ Xm[0])
                continue
            r += np.outer(b, f.F)
            J += np.kron(np.outer(b, b), Jg)
            if g.uses_velocity:
                dw += np.outer(b, f.Jv @ (self.D @ (b @ Xm))).ravel()
        return r.ravel(), J, dw, -self.unit.ravel(), forces

    # ------------------------------------------------------------------ stability
    def floquet(self, X: np.ndarray, omega: float, forces: list[GroupForce]) -> Floquet:
        """Hill's method at a solution (module docstring); ``forces`` from :meth:`evaluate` at the same point."""
        sys_ = self.system
        n, P = self.n, self.P
        eye = np.eye(P)
        Kt = np.kron(sys_.K, eye)
        Ct = np.kron(sys_.C, eye)
        memory = []
        for g, f in zip(sys_.groups, forces, strict=True):
            if f.hill is not None:
                memory.append((g, f.hill))
            elif n == 1:
                Kt += f.Jx
                Ct += f.Jv
            else:
                BB = np.outer(g.b, g.b)
                Kt += np.kron(BB, f.Jx)
                Ct += np.kron(BB, f.Jv)
        Minv = np.kron(np.linalg.inv(sys_.M), eye)
        m = len(memory)
        size = (2 * n + m) * P
        A = np.zeros((size, size))
        nP = n * P
        A[:nP, nP : 2 * nP] = np.eye(nP)
        A[nP : 2 * nP, :nP] = -Minv @ Kt
        A[nP : 2 * nP, nP : 2 * nP] = -Minv @ Ct
        for k, (g, (theta, Hw, Hv, _)) in enumerate(memory):
            rows = slice(2 * nP + k * P, 2 * nP + (k + 1) * P)
            A[nP : 2 * nP, rows] = -Minv @ np.kron(theta * g.b[:, None], eye)
            A[rows, rows] = Hw
            A[rows, nP : 2 * nP] = np.kron(g.b[None, :], Hv)
        for k in range(2 * n + m):
            A[k * P : (k + 1) * P, k * P : (k + 1) * P] -= omega * self.D
        lam = np.linalg.eigvals(A)
        exps = _exponents(lam, omega, 2 * n + m, P)
        top = float(np.max(exps.real))
        period = 2 * np.pi / omega
        tol = 1e-9 * max(omega, 1.0)
        stable = top < tol
        kind = ""
        if not stable:
            worst = exps[np.argmax(exps.real)]
            im = abs(worst.imag) % omega
            if min(im, omega - im) < 1e-6 * omega:
                kind = "real"
            elif abs(im - omega / 2) < 1e-6 * omega:
                kind = "flip"
            else:
                kind = "complex"
        return Floquet(exps, stable, float(np.exp(top * period)), kind)


def _exponents(lam: np.ndarray, omega: float, d: int, P: int) -> np.ndarray:
    """The ``d`` Floquet exponents among the eigenvalues of a truncated Hill matrix.

    Each exponent appears with its copies ``lambda + i k omega`` (one per harmonic, ``P`` in all), all
    with one multiplier ``exp(lambda T)``; the truncation adds eigenvalues that have no such copies.
    The eigenvalues are grouped by ``(Re lambda, Im lambda mod omega)``; the ``d`` largest groups are the
    exponents (a group of twice the size counts twice), each represented by its member of least
    ``|Im|``. (Choosing the ``d`` eigenvalues of least ``|Im|`` instead fails when two exponents share
    ``Im = omega / 2``, as after a period doubling.)
    """
    re, im = lam.real, np.mod(lam.imag + 0.5 * omega, omega) - 0.5 * omega
    tol = 1e-3 * omega
    members: list[list[int]] = []
    heads: list[int] = []
    for i in np.argsort(np.abs(lam.imag), kind="stable"):
        if heads:
            h = np.array(heads)
            d_im = np.abs(im[i] - im[h])
            near = (np.abs(re[i] - re[h]) <= tol + 1e-3 * np.abs(re[h])) & (np.minimum(d_im, omega - d_im) <= tol)
            if near.any():
                members[int(np.argmax(near))].append(int(i))
                continue
        heads.append(int(i))
        members.append([int(i)])
    order = sorted(range(len(members)), key=lambda g: (-len(members[g]), abs(lam[members[g][0]].imag)))
    out: list[complex] = []
    for g in order:
        slots = max(1, int(round(len(members[g]) / P)))
        out += [lam[members[g][0]]] * slots
        if len(out) >= d:
            break
    return np.array(out[:d])


def time_residual(
    system: HarmonicSystem,
    X: np.ndarray,
    omega: float,
    amplitude: float,
    pattern: np.ndarray,
    basis: Harmonics,
    measure: str = "motion",
) -> float:
    """How far a truncated solution is from solving the equations between the harmonics it balances.

    The equations of motion are evaluated on ``16 (2H + 1)`` phases of the truncated motion ``X``
    (``(n, P)``); the balance makes their first ``H`` harmonics vanish, and what is left is the
    truncation's error (NaN for a memory term, whose force needs the path):

    * ``measure="motion"``: each harmonic ``k > H`` left, ``r_k``, would move DOF ``i`` by about
      ``r_k / (k^2 omega^2 M_ii)`` (inertia dominates there); the RMS of those displacements over the
      harmonics, relative to the largest first-harmonic amplitude. A non-smooth force (``v|v|``,
      ``sign(v)``) leaves harmonics that fall slowly, but the motion they cause falls ``1/k^2`` faster:
      this measures the error of the motion.
    * ``measure="force"``: ``max |residual| / max |M z''|`` over the phases, which is what a free motion
      near a separatrix is sensitive to (its period depends on the energy without bound).
    """
    if system.uses_memory:
        return float("nan")
    from ..model.terms.slopes import slopes

    n_phase = 16 * basis.P
    tau, _, E = basis.uniform(n_phase)
    Z = X @ E.T  # (n, N)
    V = omega * (X @ basis.D.T) @ E.T
    A = omega**2 * (X @ (basis.D @ basis.D).T) @ E.T
    r = system.M @ A + system.C @ V + system.K @ Z + system.static[:, None]
    r -= amplitude * np.outer(pattern, np.cos(tau))
    for g in system.groups:
        x, xd = g.b @ Z, g.b @ V
        cache: dict = {}
        force = sum(th * slopes(t, x, xd, g.pxc, cache)[0] for t, th in zip(g.terms, g.theta, strict=True))
        r += np.outer(g.b, force)
    if measure == "force":
        inertia = float(np.max(np.abs(system.M @ A)))
        return float(np.max(np.abs(r)) / inertia) if inertia > 0 else float("nan")
    spectrum = np.abs(np.fft.rfft(r, axis=1)) * (2.0 / n_phase)
    k = np.arange(spectrum.shape[1])
    high = k > basis.H
    moved = spectrum[:, high] / (k[high] ** 2 * omega**2 * np.diag(system.M)[:, None])
    first = float(np.max(basis.amplitude(X)))
    return float(np.sqrt(np.sum(moved**2)) / first) if first > 0 else float("nan")
