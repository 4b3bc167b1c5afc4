"""The sparsity threshold: its meaning and its data-driven default.

Meaning
    The plugin runs pysindy's sequentially thresholded least squares (STLSQ)
    with ``normalize_columns=True`` on a left-hand side scaled to unit RMS, and
    passes it the threshold ``t * sqrt(N)`` (``N`` the number of equations).
    STLSQ then drops term ``j`` when ``|xi_j| * RMS(g_j) < t * RMS(lhs)``: a
    term is kept only if its RMS contribution to the equation is at least the
    fraction ``t`` of the RMS of the left-hand side. ``t`` is dimensionless and
    does not depend on the record length or units.

Default: cross-validation on contiguous segments (:func:`choose_threshold`)
    1. Candidates: least squares with every term gives each term's relative
       contribution ``c_j``; sorted, the geometric means of neighbours are the
       thresholds at which the model loses one more term. ``0`` (keep all) is
       a candidate too; thresholds that would drop a protected term (the
       force, whose coefficient is ``1/m``) are not.
    2. The equations are cut into ``K`` contiguous segments (folds). For each
       candidate and fold, STLSQ is fitted on the other folds and its mean
       squared error is measured on the held-out fold, leaving out ``gap``
       equations at each end of the held-out fold so that the filtered
       equation errors it shares with its neighbours do not leak into the
       test.
    3. One-standard-error rule (Hastie, Tibshirani & Friedman, *The Elements
       of Statistical Learning*, Sec. 7.10): the largest threshold whose
       cross-validated error is within one standard error (over folds) of the
       smallest - the sparsest model the data cannot tell apart from the best
       one. Differences below ``MSE_FLOOR`` (a relative RMS error of 1e-6)
       count as none, so that on noise-free data rounding errors do not decide.

    Every fit is pysindy's own STLSQ. It is run on the triangular factor of
    each fold (QR of ``[X, y]``) instead of the fold's rows: least squares,
    ridge and column norms are identical on both, so the choice is exact and
    costs ``K`` QR factorisations plus ``K x candidates`` tiny fits.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np
import pysindy as ps

from nlid.plugin import InputError, triangular_factor

__all__ = ["MSE_FLOOR", "RIDGE", "stlsq", "choose_threshold", "ThresholdChoice", "augmented_factor"]

#: Held-out errors (mean squares of the unit-RMS left-hand side) closer than
#: this count as equal: a relative RMS of 1e-6, far below any measurement
#: noise, and far above the rounding errors of a noise-free record.
MSE_FLOOR = 1e-12
#: Ridge regularisation of STLSQ's least-squares steps, on unit-norm columns:
#: negligible, it only keeps the normal equations positive definite.
RIDGE = 1e-10


def stlsq(threshold: float, n_equations: int) -> ps.STLSQ:
    """pysindy's STLSQ with the relative threshold ``t`` of the module docstring."""
    return ps.STLSQ(
        threshold=float(threshold) * np.sqrt(n_equations),
        alpha=RIDGE,
        normalize_columns=True,
        unbias=True,
        max_iter=50,
    )


def augmented_factor(X: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Upper-triangular ``R`` of ``[X, y] = Q R`` (at most ``(p+1) x (p+1)``)."""
    return triangular_factor(np.column_stack([X, y]))


@dataclass(frozen=True)
class ThresholdChoice:
    """The outcome of :func:`choose_threshold`.

    Attributes
    ----------
    threshold
        The chosen relative threshold ``t``.
    table
        One entry per candidate: ``threshold``, ``cv_mse`` (mean over folds of
        the held-out mean squared error of the scaled equation), ``cv_se``
        (its standard error) and ``kept`` (terms kept on all the data).
    folds, gap
        Number of folds and equations left out at each end of a held-out fold.
    """

    threshold: float
    table: list[dict] = field(default_factory=list)
    folds: int = 0
    gap: int = 0


def _fit(R: np.ndarray, n_rows: int, threshold: float) -> np.ndarray:
    p = R.shape[1] - 1
    opt = stlsq(threshold, n_rows)
    opt.fit(R[:p, :p], R[:p, p])
    return np.asarray(opt.coef_).reshape(-1)


def _sse(R: np.ndarray, coef: np.ndarray) -> float:
    return float(np.sum((R @ np.append(coef, -1.0)) ** 2))


def choose_threshold(
    X: np.ndarray,
    y: np.ndarray,
    names: list[str],
    *,
    folds: int = 5,
    gap: int = 0,
    protected: tuple[int, ...] = (),
) -> ThresholdChoice:
    """Choose the sparsity threshold by K-fold cross-validation (module docstring).

    Parameters
    ----------
    X
        Library matrix, shape ``(N, p)`` (rows in time order).
    y
        Left-hand side scaled to unit RMS, shape ``(N,)``.
    names
        Column names, for the table.
    folds
        Number of contiguous folds ``K``.
    gap
        Equations left out at each end of each held-out fold.
    protected
        Columns that must never be dropped.

    Raises
    ------
    InputError
        If a fold is too short for the number of columns.
    """
    n, p = X.shape
    bounds = np.linspace(0, n, folds + 1).astype(int)
    if np.min(np.diff(bounds)) - 2 * gap < 2 * p:
        raise InputError(
            f"sindy: {n} equations are too few for {folds}-fold cross-validation of {p} terms; "
            "lower 'folds', give a 'threshold' or use a longer record"
        )
    inner, full = [], []
    for a, b in zip(bounds[:-1], bounds[1:], strict=True):
        inner.append(augmented_factor(X[a + gap : b - gap], y[a + gap : b - gap]))
        ends = [augmented_factor(X[i:j], y[i:j]) for i, j in ((a, a + gap), (b - gap, b)) if j > i]
        full.append(np.linalg.qr(np.vstack([inner[-1], *ends]), mode="r") if ends else inner[-1])
    sizes = np.diff(bounds)
    everything = np.linalg.qr(np.vstack(full), mode="r")
    train = [np.linalg.qr(np.vstack([full[j] for j in range(folds) if j != k]), mode="r") for k in range(folds)]

    # candidates: between consecutive relative contributions of the full least-squares fit
    R = everything
    coef = np.linalg.lstsq(R[:p, :p], R[:p, p], rcond=None)[0]
    rms = np.sqrt(np.sum(R[:p, :p] ** 2, axis=0) / n)
    contribution = np.abs(coef) * rms / np.sqrt(np.sum(y**2) / n)
    ceiling = min((contribution[j] for j in protected), default=np.inf)
    levels = np.unique(contribution[(contribution > 0) & (contribution < ceiling)])
    candidates = [0.0, *np.sqrt(levels[:-1] * levels[1:])] if levels.size else [0.0]
    if levels.size and levels[-1] < ceiling and np.isfinite(ceiling):
        candidates.append(float(np.sqrt(levels[-1] * ceiling)))

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # "eliminated all coefficients" is an expected outcome of large candidates
        errors = np.empty((len(candidates), folds))
        kept = []
        for i, t in enumerate(candidates):
            for k in range(folds):
                w = _fit(train[k], n - sizes[k], t)
                errors[i, k] = _sse(inner[k], w) / (sizes[k] - 2 * gap)
            kept.append([names[j] for j in np.flatnonzero(_fit(everything, n, t))])
    cv = errors.mean(axis=1)
    se = errors.std(axis=1, ddof=1) / np.sqrt(folds)
    best = int(np.argmin(cv))
    eligible = [
        i
        for i in range(len(candidates))
        if cv[i] <= cv[best] + max(se[best], MSE_FLOOR) and all(names[j] in kept[i] for j in protected)
    ]
    chosen = max(eligible, key=lambda i: candidates[i]) if eligible else best
    table = [
        {"threshold": float(t), "cv_mse": float(cv[i]), "cv_se": float(se[i]), "kept": kept[i]}
        for i, t in enumerate(candidates)
    ]
    return ThresholdChoice(float(candidates[chosen]), table, folds, gap)
