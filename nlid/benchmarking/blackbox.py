"""Discrete-time peer rows: a linear state-space baseline and sysidentpy's polynomial NARX (FROLS).

"Better than linear?" is the first question a reviewer asks of a nonlinear model, and a
polynomial NARX fitted by FROLS is the classic nonlinear baseline of the field. Both are run as
a competent user of each would, with every choice made on the *estimation* part:

:class:`LinearModel` (pipeline ``linear-ss``)
    A linear discrete-time model ``y = B(q)/F(q) (u - u0)`` of order ``n`` (a state space of
    order ``n`` with direct feedthrough and an input offset), fitted by output error: ARX least
    squares gives the start, ``scipy.optimize.least_squares`` minimises the free-run error of the
    fit part; the order (:data:`LINEAR_ORDERS`) is chosen by the free-run error on the held-out end. Written in
    numpy/scipy: ``nfoursid`` (the ``bench`` extra) takes a full SVD of its data matrix, an
    ``N x N`` array (31 GiB on the Silverbox estimation part).
:class:`NarxModel` (pipeline ``sysidentpy``)
    ``sysidentpy.model_structure_selection.FROLS`` with a polynomial basis and least squares, as
    in sysidentpy's own Silverbox case study; degree, lags (:data:`NARX_GRID`) and the number of
    terms (:data:`NARX_TERMS`) are chosen by the free-run error on the held-out end. Optional:
    when sysidentpy is not installed the row says so (``pip install sysidentpy``; it is not an extra of
    nlid because sysidentpy 0.9 pins ``numpy<=2.3.5``; it runs on newer numpy installed without its
    dependencies). ``benchmarks/peer_side_by_side_narx.py`` runs sysidentpy as its documentation advises
    (its Silverbox tutorial's three FROLS configurations, the electromechanical tutorial's on EMPS), with
    nothing of nlid but the data split, and compares: the row is within 2x of it on every test set.

Both are scored like every row (:meth:`free_run`) under the test set's transient rule: a window
``window:N`` initialises the model from the first ``N`` measured samples (the NARX's lags are
the measured outputs; the state space's initial state is fitted to them by least squares) and
scores the rest; ``periodic:N`` runs preceding periods of the record's own force until the
output settles; ``first-sample`` starts at rest at the first sample.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..data.record import Record
from ..errors import DataError, InputError
from .peer import DIVERGED, MAX_PERIODS, PeerScore

__all__ = ["LinearModel", "NarxModel", "fit_linear", "fit_narx", "LINEAR_ORDERS", "NARX_GRID", "NARX_TERMS"]

#: Orders of the linear model tried on the held-out end of the estimation part.
LINEAR_ORDERS = (2, 3, 4, 6, 8)
#: ``(degree, lag)`` pairs of the polynomial NARX tried (lags of the output and the input alike).
NARX_GRID = ((2, 1), (2, 2), (2, 3), (3, 1), (3, 2))
#: Numbers of terms FROLS selects (tried with each degree and lag). sysidentpy's Silverbox case study caps
#: 40 terms with ``err_tol = 0.9999``; on a position record (EMPS) the first lag of the output alone passes
#: that tolerance, so the number of terms is chosen on the held-out end instead.
NARX_TERMS = (10, 30)
#: Relative change of the output between two periods below which a periodic free run has settled.
PERIODIC_TOL = 1e-6


def _score(y: np.ndarray, yhat: np.ndarray, skip: int, text: str, limit: float) -> PeerScore:
    n = y.size - skip
    e = yhat[skip:] - y[skip:]
    if not np.all(np.isfinite(e)) or np.max(np.abs(yhat[skip:])) > limit:
        return PeerScore(np.nan, np.nan, np.nan, n, text, "free run diverged")
    yy = y[skip:]
    rmse = float(np.sqrt(np.mean(e**2)))
    fit = 100.0 * (1.0 - float(np.linalg.norm(e)) / float(np.linalg.norm(yy - yy.mean())))
    return PeerScore(rmse, 100.0 * rmse / float(np.std(yy)), fit, n, text)


def _limit(y: np.ndarray) -> float:
    return DIVERGED * (float(np.ptp(y)) + float(np.max(np.abs(y))) or 1.0)


def _parse_rule(rule: str, n: int) -> tuple[str, int]:
    """``(kind, number)``: ``("first", 0)``, ``("window", N)`` or ``("periodic", P)``."""
    if rule == "first-sample":
        return "first", 0
    if rule.startswith("window:"):
        skip = int(rule.split(":", 1)[1])
        if skip >= n - 1:
            raise InputError(f"rule {rule}: the record has only {n} samples")
        return "window", skip
    if rule.startswith("periodic"):
        period = int(rule.split(":", 1)[1]) if ":" in rule else n
        if n % period:
            raise InputError(f"rule {rule}: the record's {n} samples are not whole periods")
        return "periodic", period
    raise InputError(f"unknown rule {rule!r}")


# --------------------------------------------------------------------------- the linear model
@dataclass
class LinearModel:
    """A linear discrete-time model ``y = B(q)/F(q) u`` as a state space ``(A, B, C, D)``, on centred data.

    Attributes
    ----------
    b, f
        The numerator (``n + 1`` coefficients, direct term first) and the monic denominator
        (``1, f_1 ... f_n``) in powers of ``q^-1``.
    u_mean, y_mean
        Subtracted from the force and the output before the model (the estimation part's means;
        ``u_mean`` also holds the fitted input offset).
    """

    b: np.ndarray
    f: np.ndarray
    u_mean: float
    y_mean: float
    seconds: float = 0.0
    selection: dict[str, Any] = field(default_factory=dict)

    @property
    def order(self) -> int:
        """The model's order ``n``."""
        return self.f.size - 1

    @property
    def parameters(self) -> int:
        """Fitted coefficients: ``n + 1`` of ``B``, ``n`` of ``F``, the input offset."""
        return self.b.size + self.f.size

    @property
    def equations(self) -> list[str]:
        """The model in words."""
        return [f"linear, order {self.order}: poles |p| = {', '.join(f'{abs(p):.4f}' for p in self.poles())}"]

    def poles(self) -> np.ndarray:
        """The poles (roots of ``F``)."""
        return np.roots(self.f)

    def _matrices(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        from scipy.signal import tf2ss

        a, b, c, d = tf2ss(self.b, self.f)
        return a, b[:, 0], c[0], float(d[0, 0])

    def _forced(self, u: np.ndarray, x0: np.ndarray) -> np.ndarray:
        """The output over ``u`` from the state ``x0``: the zero-state response plus the state's."""
        from scipy.signal import lfilter

        out = lfilter(self.b, self.f, u)
        if np.any(x0):
            out = out + self._free(u.size) @ x0
        return out

    def _free(self, n_samples: int) -> np.ndarray:
        """``O[k] = C A^k``: the output's response to the initial state."""
        a, _, c, _ = self._matrices()
        out = np.empty((n_samples, self.order))
        row = c.copy()
        for k in range(n_samples):
            out[k] = row
            row = row @ a
        return out

    def simulate(self, u: np.ndarray, x0: np.ndarray | None = None) -> np.ndarray:
        """The output over the force ``u`` (record units) from the state ``x0`` (default zero)."""
        x0 = np.zeros(self.order) if x0 is None else x0
        return self._forced(np.asarray(u, float) - self.u_mean, x0) + self.y_mean

    def free_run(self, record: Record, rule: str) -> PeerScore:
        """Scores on ``record`` under ``rule`` (as :meth:`nlid.benchmarking.peer.PeerModel.free_run`)."""
        kind, k = _parse_rule(rule, record.n)
        u = record.f - self.u_mean
        y = record.z - self.y_mean
        limit = _limit(y)
        zero = self._forced(u, np.zeros(self.order))
        if kind == "window":
            x0 = np.linalg.lstsq(self._free(k), y[:k] - zero[:k], rcond=None)[0]
            yhat = zero + self._free(record.n) @ x0
            text = f"initialisation window of {k} samples (state fitted to them; not scored)"
            return _score(y, yhat, k, text, limit)
        if kind == "first":
            a, b, c, d = self._matrices()
            steady = np.linalg.lstsq(np.eye(self.order) - a, b * u[0], rcond=None)[0]  # at rest under the first force
            x0 = steady + np.linalg.pinv(c[None, :]) @ np.atleast_1d(y[0] - c @ steady - d * u[0])
            yhat = self._forced(u, x0)
            return _score(y, yhat, 0, "from the record's first sample (at rest)", limit)
        a, b, c, d = self._matrices()
        period = u[:k]
        after_one = np.zeros(self.order)
        for j in range(k):
            after_one = a @ after_one + b * period[j]
        ap = np.linalg.matrix_power(a, k)
        x0 = np.linalg.lstsq(np.eye(self.order) - ap, after_one, rcond=None)[0]  # the exact periodic state
        yhat = np.concatenate([self._forced(period, x0)] * (record.n // k))
        return _score(y, yhat, 0, f"periodic steady state (period {k} samples, declared; solved exactly)", limit)


def _arx(u: np.ndarray, y: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """ARX least squares ``y_k + f_1 y_{k-1} ... = b_0 u_k + ... + b_n u_{k-n}``."""
    rows = y.size - n
    cols = [-y[n - i : n - i + rows] for i in range(1, n + 1)] + [u[n - i : n - i + rows] for i in range(n + 1)]
    theta = np.linalg.lstsq(np.column_stack(cols), y[n:], rcond=None)[0]
    return theta[n:], np.concatenate([[1.0], theta[:n]])


def _stabilise(f: np.ndarray) -> np.ndarray:
    """``f`` with its roots outside the unit circle reflected inside (a stable denominator)."""
    roots = np.roots(f)
    big = np.abs(roots) >= 1.0
    if not big.any():
        return f
    roots[big] = 1.0 / np.conj(roots[big]) * 0.999
    return np.real(np.poly(roots))


def _oe(u: np.ndarray, y: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray, float]:
    """Output error: the free-run error of ``B/F (u - u0)`` minimised from the ARX start (``scipy.signal.lfilter``).

    ``u0`` is an input offset (a constant force: a static load, a friction bias), fitted with ``B`` and ``F``.
    """
    from scipy.optimize import least_squares
    from scipy.signal import lfilter

    b0, f0 = _arx(u, y, n)
    f0 = _stabilise(f0)
    scale = float(np.std(y)) or 1.0
    uscale = float(np.std(u)) or 1.0

    def resid(p: np.ndarray) -> np.ndarray:
        f = np.concatenate([[1.0], p[n + 1 : 2 * n + 1]])
        if np.max(np.abs(np.roots(f))) >= 1.0:
            return np.full(y.size, 1e3)
        return (lfilter(p[: n + 1], f, u - p[-1] * uscale) - y) / scale

    p0 = np.concatenate([b0, f0[1:], [0.0]])
    sol = least_squares(resid, p0, method="lm", max_nfev=200 * (2 * n + 2))
    p = sol.x if np.max(np.abs(np.roots(np.concatenate([[1.0], sol.x[n + 1 : 2 * n + 1]])))) < 1.0 else p0
    return p[: n + 1], np.concatenate([[1.0], p[n + 1 : 2 * n + 1]]), float(p[-1] * uscale)


def fit_linear(record: Record, *, holdout: float = 0.25, rule: str = "first-sample") -> LinearModel:
    """The linear model fitted on the estimation record, its order chosen on the record's last part."""
    start = time.perf_counter()
    fit_part, held = record.split(holdout)
    errors: dict[str, float] = {}
    best, best_err = LINEAR_ORDERS[0], np.inf
    um, ym = float(fit_part.f.mean()), float(fit_part.z.mean())
    for n in LINEAR_ORDERS:
        b, f, offset = _oe(fit_part.f - um, fit_part.z - ym, n)
        err = LinearModel(b, f, um + offset, ym).free_run(held, rule).rmse
        errors[f"order {n}"] = err
        if np.isfinite(err) and err < best_err:
            best, best_err = n, err
    um, ym = float(record.f.mean()), float(record.z.mean())
    b, f, offset = _oe(record.f - um, record.z - ym, best)
    model = LinearModel(b, f, um + offset, ym, seconds=time.perf_counter() - start)
    model.selection = {
        "order": best,
        "holdout_rmse": errors,
        "holdout_fraction": holdout,
        "holdout_rule": rule,
    }
    return model


# --------------------------------------------------------------------------- sysidentpy's NARX
def _sysidentpy() -> Any:
    try:
        import sysidentpy
    except ImportError:
        raise DataError("sysidentpy is not installed (pip install sysidentpy)") from None
    return sysidentpy


@dataclass
class NarxModel:
    """A polynomial NARX fitted by sysidentpy's FROLS, and what is needed to run it freely.

    Attributes
    ----------
    model
        The fitted ``sysidentpy`` ``FROLS`` object.
    degree, lag, terms
        The polynomial degree, the lags of output and input, the number of terms asked of FROLS.
    """

    model: Any
    degree: int
    lag: int
    terms: int = 0
    seconds: float = 0.0
    selection: dict[str, Any] = field(default_factory=dict)

    @property
    def max_lag(self) -> int:
        """The model's largest lag (samples of output it starts from)."""
        return int(self.model.max_lag)

    @property
    def parameters(self) -> int:
        """Terms FROLS selected."""
        return int(len(self.model.final_model))

    @property
    def equations(self) -> list[str]:
        """The model in words."""
        return [f"polynomial NARX, degree {self.degree}, lags {self.lag}: {self.parameters} terms (FROLS)"]

    def _predict(self, u: np.ndarray, y_init: np.ndarray) -> np.ndarray:
        """Output over ``u`` whose first ``max_lag`` values are ``y_init`` (sysidentpy's free run)."""
        with warnings.catch_warnings(), np.errstate(all="ignore"):
            warnings.simplefilter("ignore")
            out = self.model.predict(X=np.asarray(u, float).reshape(-1, 1), y=np.asarray(y_init, float).reshape(-1, 1))
        return np.asarray(out, dtype=float).ravel()

    def free_run(self, record: Record, rule: str) -> PeerScore:
        """Scores on ``record`` under ``rule`` (as :meth:`nlid.benchmarking.peer.PeerModel.free_run`)."""
        kind, k = _parse_rule(rule, record.n)
        y, u, lag = record.z, record.f, self.max_lag
        limit = _limit(y)
        if kind == "window":
            if k < lag:
                raise InputError(f"rule {rule}: the window is shorter than the NARX's {lag} lags")
            yhat = np.concatenate([y[: k - lag], self._predict(u[k - lag :], y[k - lag : k])])
            text = f"initialisation window of {k} samples (the NARX's lags are its last {lag} measured outputs)"
            return _score(y, yhat, k, text, limit)
        if kind == "first":
            yhat = self._predict(np.concatenate([np.full(lag, u[0]), u]), np.full(lag, y[0]))[lag:]
            return _score(y, yhat, 0, "from the record's first sample (at rest: lags filled with it)", limit)
        period = u[:k]
        run = self._predict(np.concatenate([np.zeros(lag), np.tile(period, 2)]), np.zeros(lag))[lag:]
        periods = 2
        while periods < MAX_PERIODS:
            last, before = run[-k:], run[-2 * k : -k]
            if not np.all(np.isfinite(last)) or np.max(np.abs(last - before)) <= PERIODIC_TOL * (np.std(last) or 1.0):
                break
            more = self._predict(np.concatenate([period[-lag:], period]), run[-lag:])[lag:]
            run = np.concatenate([run, more])
            periods += 1
        yhat = np.tile(run[-k:], record.n // k)
        return _score(y, yhat, 0, f"periodic steady state (period {k} samples, declared; {periods} periods run)", limit)


def _frols(record: Record, degree: int, lag: int, terms: int) -> Any:
    _sysidentpy()
    from sysidentpy.basis_function import Polynomial
    from sysidentpy.model_structure_selection import FROLS
    from sysidentpy.parameter_estimation import LeastSquares

    model = FROLS(
        xlag=lag,
        ylag=lag,
        basis_function=Polynomial(degree=degree),
        estimator=LeastSquares(),
        n_terms=terms,
        order_selection=False,
    )
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore")
        model.fit(X=record.f.reshape(-1, 1), y=record.z.reshape(-1, 1))
    return model


def fit_narx(record: Record, *, holdout: float = 0.25, rule: str = "first-sample") -> NarxModel:
    """sysidentpy's FROLS NARX fitted on the estimation record, degree and lags chosen on its last part.

    Raises
    ------
    DataError
        sysidentpy is not installed.
    """
    _sysidentpy()
    start = time.perf_counter()
    fit_part, held = record.split(holdout)
    errors: dict[str, float] = {}
    best, best_err = (*NARX_GRID[0], NARX_TERMS[0]), np.inf
    for degree, lag in NARX_GRID:
        for terms in NARX_TERMS:
            try:
                err = NarxModel(_frols(fit_part, degree, lag, terms), degree, lag, terms).free_run(held, rule).rmse
            except (ValueError, np.linalg.LinAlgError):  # a degenerate regressor matrix: this candidate fails
                err = np.nan
            errors[f"degree {degree}, lags {lag}, {terms} terms"] = err
            if np.isfinite(err) and err < best_err:
                best, best_err = (degree, lag, terms), err
    degree, lag, terms = best
    narx = NarxModel(_frols(record, degree, lag, terms), degree, lag, terms, seconds=time.perf_counter() - start)
    narx.selection = {
        "degree": degree,
        "lags": lag,
        "terms": terms,
        "holdout_rmse": errors,
        "holdout_fraction": holdout,
        "holdout_rule": rule,
    }
    return narx
