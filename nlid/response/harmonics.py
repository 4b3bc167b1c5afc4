"""The truncated Fourier basis of a periodic motion, and the quadratures that project a force on it.

A periodic signal of angular frequency ``omega`` is written in the phase
``tau = omega t`` (one period is ``0 <= tau < 2 pi``) as

    x(tau) = c_0 + sum_{k=1..H} (a_k cos k tau + b_k sin k tau),

its coefficients ordered ``[c_0, a_1, b_1, ..., a_H, b_H]`` (``P = 2H + 1``
of them). :class:`Harmonics` holds that basis: its values at any phases, the
derivative in ``tau`` as a matrix acting on the coefficients, and the
projection of samples back on the coefficients (``c_0`` is the mean, ``a_k``
and ``b_k`` are ``1/pi`` times the integrals with ``cos`` and ``sin``).

Two quadratures integrate a force over the period (:meth:`Harmonics.rule`):

* **uniform**: ``N`` equally spaced phases, equal weights: spectrally
  accurate for a smooth periodic integrand (exact for a polynomial of the
  motion when ``N`` exceeds ``(degree + 1) H``);
* **composite**: the period cut into ``N`` equal intervals, and further at
  given *breakpoints* (where a term has a kink or a jump: :func:`nlid.model.terms.slopes.switches`),
  with :data:`GAUSS_NODES` Gauss-Legendre nodes on every piece, so that
  nothing non-smooth lies inside a piece.

:func:`crossings` finds the phases where a truncated series crosses a level
(the breakpoints of the motion).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["Harmonics", "crossings", "GAUSS_NODES", "default_samples"]

#: Gauss-Legendre nodes per piece of the composite rule (exact for polynomials of degree 7 on each piece).
GAUSS_NODES = 4


def default_samples(harmonics: int, memory: bool = False) -> int:
    """The number of time samples (or quadrature intervals) per period for ``harmonics`` harmonics.

    ``8 (H + 1)`` rounded up to a power of two, at least 64: exact for the
    uniform rule up to a polynomial of degree 7 in the motion. A memory term
    (a state integrated along the path) gets 8 times more, at least 512.
    """
    n = max(64, 1 << int(np.ceil(np.log2(8 * (harmonics + 1)))))
    return max(512, 8 * n) if memory else n


@dataclass(frozen=True)
class Harmonics:
    """The basis ``[1, cos tau, sin tau, ..., cos H tau, sin H tau]``.

    Attributes
    ----------
    H
        Number of harmonics (the constant term is always included).
    """

    H: int
    _cache: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    @property
    def P(self) -> int:
        """Number of coefficients, ``2 H + 1``."""
        return 2 * self.H + 1

    @property
    def D(self) -> np.ndarray:
        """``d/dtau`` on the coefficients: ``a_k' = k b_k``, ``b_k' = -k a_k`` (read-only)."""
        if "D" not in self._cache:
            D = np.zeros((self.P, self.P))
            for k in range(1, self.H + 1):
                a, b = 2 * k - 1, 2 * k
                D[a, b] = k
                D[b, a] = -k
            D.flags.writeable = False
            self._cache["D"] = D
        return self._cache["D"]

    @property
    def norms(self) -> np.ndarray:
        """Projection factors: ``1 / (2 pi)`` for ``c_0``, ``1 / pi`` for the others."""
        out = np.full(self.P, 1.0 / np.pi)
        out[0] = 0.5 / np.pi
        return out

    def values(self, tau: np.ndarray) -> np.ndarray:
        """The basis at phases ``tau``: shape ``(len(tau), P)``."""
        tau = np.asarray(tau, dtype=float).reshape(-1)
        k = np.arange(1, self.H + 1)
        arg = np.multiply.outer(tau, k)
        out = np.empty((tau.size, self.P))
        out[:, 0] = 1.0
        out[:, 1::2] = np.cos(arg)
        out[:, 2::2] = np.sin(arg)
        return out

    def slopes(self, tau: np.ndarray) -> np.ndarray:
        """``d/dtau`` of the basis at phases ``tau``: shape ``(len(tau), P)``."""
        return self.values(tau) @ self.D

    def uniform(self, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(tau, weights, basis)`` of the uniform rule with ``n`` samples (cached)."""
        key = ("uniform", n)
        if key not in self._cache:
            tau = 2 * np.pi * np.arange(n) / n
            w = np.full(n, 2 * np.pi / n)
            E = self.values(tau)
            for a in (tau, w, E):
                a.flags.writeable = False
            self._cache[key] = (tau, w, E)
        return self._cache[key]

    def composite(self, n: int, breaks: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(tau, weights, basis)`` of the composite Gauss-Legendre rule: ``n`` intervals cut at ``breaks``.

        The nodes of the intervals without a break are cached; only the cut intervals are built anew.
        """
        key = ("composite", n)
        if key not in self._cache:
            h = 2 * np.pi / n
            xi, wi = _gauss(GAUSS_NODES)
            lo = h * np.arange(n)
            tau = (lo + 0.5 * h)[:, None] + 0.5 * h * xi[None, :]
            w = np.broadcast_to(0.5 * h * wi, tau.shape).copy()
            self._cache[key] = (tau, w, self.values(tau.ravel()).reshape(n, GAUSS_NODES, self.P))
        tau0, w0, E0 = self._cache[key]
        breaks = np.mod(np.asarray(breaks, dtype=float), 2 * np.pi)
        if breaks.size == 0:
            return tau0.ravel(), w0.ravel(), E0.reshape(-1, self.P)
        h = 2 * np.pi / n
        cut = np.unique(np.minimum((breaks // h).astype(int), n - 1))
        keep = np.ones(n, dtype=bool)
        keep[cut] = False
        edges = [
            np.unique(np.concatenate([[h * k, h * (k + 1)], breaks[(breaks > h * k) & (breaks < h * (k + 1))]]))
            for k in cut
        ]
        lo = np.concatenate([e[:-1] for e in edges])
        hi = np.concatenate([e[1:] for e in edges])
        xi, wi = _gauss(GAUSS_NODES)
        half = 0.5 * (hi - lo)
        tau = ((lo + half)[:, None] + half[:, None] * xi[None, :]).ravel()
        w = (half[:, None] * wi[None, :]).ravel()
        return (
            np.concatenate([tau0[keep].ravel(), tau]),
            np.concatenate([w0[keep].ravel(), w]),
            np.concatenate([E0[keep].reshape(-1, self.P), self.values(tau)]),
        )

    def amplitude(self, coefficients: np.ndarray, order: int = 1) -> np.ndarray:
        """``sqrt(a_k^2 + b_k^2)`` of harmonic ``order`` of coefficients shaped ``(..., P)``."""
        c = np.asarray(coefficients)
        return np.hypot(c[..., 2 * order - 1], c[..., 2 * order])

    def fine(self, coefficients: np.ndarray, n: int = 512) -> np.ndarray:
        """The signal of coefficients ``(..., P)`` on ``n`` uniform phases: shape ``(..., n)``."""
        return np.asarray(coefficients) @ self.uniform(n)[2].T


_GAUSS: dict[int, tuple[np.ndarray, np.ndarray]] = {}


def _gauss(q: int) -> tuple[np.ndarray, np.ndarray]:
    if q not in _GAUSS:
        _GAUSS[q] = np.polynomial.legendre.leggauss(q)
    return _GAUSS[q]


def crossings(
    basis: Harmonics, coefficients: np.ndarray, level: float | np.ndarray, n: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Phases in ``[0, 2 pi)`` where the series of ``coefficients`` crosses each level, and its slope there.

    Sign changes on ``n`` uniform phases are refined by safeguarded Newton steps (the bracket is kept). A
    tangency without a sign change is not a crossing.

    Returns
    -------
    tau, slope, which : numpy.ndarray
        The crossing phases, ``dx/dtau`` at each, and the index of the level each belongs to.
    """
    levels = np.atleast_1d(np.asarray(level, dtype=float))
    tau, _, E = basis.uniform(n)
    x = E @ coefficients
    s = x[None, :] - levels[:, None]
    nxt = np.concatenate([s[:, 1:], s[:, :1]], axis=1)
    which, idx = np.nonzero((s == 0.0) | (np.sign(s) * np.sign(nxt) < 0))
    if idx.size == 0:
        return np.empty(0), np.empty(0), np.empty(0, dtype=int)
    h = 2 * np.pi / n
    lo = tau[idx]
    hi = lo + h
    slo, shi = s[which, idx], nxt[which, idx]
    lev = levels[which]
    exact = slo == 0.0
    t = np.where(exact, lo, lo - slo * h / np.where(shi == slo, 1.0, shi - slo))
    dc = basis.D @ coefficients
    tol = 1e-15 * max(float(np.max(np.abs(x))), 1e-300)
    for _ in range(10):
        E_t = basis.values(t)
        f = E_t @ coefficients - lev
        if np.all(np.abs(f) <= tol):
            break
        d = E_t @ dc
        same = np.sign(f) == np.sign(slo)
        lo = np.where(same & ~exact, t, lo)
        hi = np.where(~same & ~exact, t, hi)
        new = t - np.where(d != 0.0, f / np.where(d == 0.0, 1.0, d), 0.0)
        bad = ~((new >= lo) & (new <= hi))
        new = np.where(bad, 0.5 * (lo + hi), new)
        new = np.where(exact, t, new)
        done = np.all(np.abs(new - t) < 1e-13)
        t = new
        if done:
            break
    slope = basis.values(t) @ dc
    return np.mod(t, 2 * np.pi), slope, which
