"""Least squares with honest standard errors, and collinearity diagnostics.

Shared by the identifiers that regress the force balance ``f - m a = G theta``
(Eq. 25) on the model's terms (``rfs``, ``sindy``).

Scaling
    Every column is divided by its RMS before solving, so the condition number
    reported is that of the scaled matrix: it measures how close the terms are
    to being linearly dependent on this record, not their units.

Standard errors (:func:`least_squares`)
    Two estimates of the coefficient covariance are returned:

    * ``covariance_iid = s^2 (X^T X)^-1`` with ``s^2`` the residual variance.
      It holds when the equation errors are independent, identically
      distributed and uncorrelated with exact regressors. A force balance
      formed in a filter band (:func:`nlid.estimation.balance.regression_data`) has a
      coloured residual (correlated over about ``fs / fc`` samples), so this
      estimate is then too small by roughly ``sqrt(fs / (2 fc))``.
    * ``covariance`` (the one identifiers report): the sandwich
      ``(X^T X)^-1 Omega (X^T X)^-1`` with ``Omega`` estimated from the sums
      of ``x_k e_k`` over contiguous batches of samples (batch means). It
      holds for a stationary equation error that may be coloured and
      heteroscedastic, provided it decorrelates within a batch (batches are
      at least ``BATCH_CORRELATION_LENGTHS`` correlation lengths long).

    Neither covers bias: errors in the regressors themselves (noise on the
    measured or estimated ``z``, ``v`` - errors-in-variables), a band-limited
    velocity feeding a nonlinear term, or a missing term. When such biases
    dominate, the actual error exceeds the standard error, and the scatter of
    estimates over independent records is the honest measure.

Non-smooth velocity terms (:func:`nonsmooth_warnings`)
    A term such as ``sign(v)`` is discontinuous at ``v = 0``: its column
    depends on every velocity reversal. When the force balance is formed in a
    filter band (velocity estimated or low-passed), reversals faster than the
    band are missed and the coefficient is biased towards zero, the other
    odd velocity terms absorbing the rest. The warning's measure is the
    fraction of samples whose velocity sign changes when the velocity the
    regressors were evaluated on is cut to the equation band: 0 on the EMPS
    record (slow, smooth motion), 9 % on paper-numerical with 2 % noise
    (white force, many fast reversals).

Collinearity (:func:`collinear_pairs`)
    Two terms whose columns are almost proportional on a record (absolute correlation
    above ``COLLINEAR_CORRELATION``) cannot be told apart: their coefficients
    trade off and their variances are inflated by ``1 / (1 - r^2)`` (50 at
    r = 0.99). When the model has a constant term the correlation of two other
    terms is the centred (Pearson) one, since the constant absorbs the means;
    otherwise, and for pairs with the constant itself, it is the uncentred
    cosine of the two columns.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import IdentificationError
from ..model.terms import Model
from ..signal import derivatives

__all__ = [
    "COLLINEAR_CORRELATION",
    "LeastSquaresFit",
    "least_squares",
    "collinear_pairs",
    "collinearity_warnings",
    "column_scale",
    "triangular_factor",
    "SIGN_DISAGREEMENT",
    "velocity_sign_disagreement",
    "nonsmooth_warnings",
]

#: Absolute correlation of two regressor columns above which they are reported as
#: near-collinear (variance inflation 1 / (1 - r^2) >= 50).
COLLINEAR_CORRELATION = 0.99
#: Fraction of samples whose velocity sign changes when cut to the equation
#: band above which non-smooth velocity terms are reported.
SIGN_DISAGREEMENT = 0.01
#: Most batches used for the batch-means covariance.
MAX_BATCHES = 50
#: Minimum batch length, in correlation lengths of the equation error.
BATCH_CORRELATION_LENGTHS = 10.0


#: Above this condition number of the Cholesky factor, :func:`triangular_factor`
#: falls back to Householder QR (CholeskyQR2 is accurate well beyond it).
CHOLESKY_QR_MAX_CONDITION = 1e6


def triangular_factor(A: np.ndarray) -> np.ndarray:
    """Upper-triangular ``R`` with ``R^T R = A^T A`` (the ``R`` of ``A = Q R``).

    Tall, thin matrices are factorised by CholeskyQR2 (Cholesky of the Gram
    matrix, once more on ``A R1^-1``; Yamamoto et al., 2015): two BLAS
    products instead of Householder QR, 20-50 times faster here and as
    accurate while ``A`` is reasonably conditioned. Otherwise, or when the
    Cholesky factorisation fails, Householder QR is used.
    """
    A = np.asarray(A, dtype=float)
    n, p = A.shape
    if n >= 4 * p:
        norms = np.sqrt(np.einsum("ij,ij->j", A, A))
        norms[norms == 0] = 1.0
        As = A / norms  # the condition test below must not depend on units
        try:
            R1 = np.linalg.cholesky(As.T @ As).T
            sv = np.linalg.svd(R1, compute_uv=False)
            if sv[-1] > 0 and sv[0] / sv[-1] < CHOLESKY_QR_MAX_CONDITION:
                Q1 = np.dot(As, np.linalg.inv(R1))
                return np.linalg.cholesky(Q1.T @ Q1).T @ R1 * norms
        except np.linalg.LinAlgError:
            pass
    return np.linalg.qr(A, mode="r")


@dataclass(frozen=True)
class LeastSquaresFit:
    """The solution of ``X theta = y`` in the least-squares sense.

    Attributes
    ----------
    coefficients
        ``theta``, shape ``(p,)``.
    covariance
        Batch-means sandwich covariance of ``theta`` (see module docstring).
    covariance_iid
        ``s^2 (X^T X)^-1`` (independent, identically distributed errors).
    residual
        ``y - X theta``.
    condition_number
        Ratio of the extreme singular values of the RMS-scaled ``X``.
    batches
        Number of contiguous batches used for ``covariance`` (0 when there
        were too few samples and ``covariance`` is the iid one).
    """

    coefficients: np.ndarray
    covariance: np.ndarray
    covariance_iid: np.ndarray
    residual: np.ndarray
    condition_number: float
    batches: int

    @property
    def standard_errors(self) -> np.ndarray:
        """Square roots of the diagonal of :attr:`covariance`."""
        return np.sqrt(np.diag(self.covariance))

    @property
    def standard_errors_iid(self) -> np.ndarray:
        """Square roots of the diagonal of :attr:`covariance_iid`."""
        return np.sqrt(np.diag(self.covariance_iid))


def column_scale(X: np.ndarray, names: Sequence[str], context: str = "") -> np.ndarray:
    """RMS of each column; raise naming the columns that are identically zero."""
    X = np.asarray(X, dtype=float)
    scale = np.sqrt(np.einsum("ij,ij->j", X, X) / X.shape[0])
    if np.any(scale == 0):
        zero = [names[i] for i in np.flatnonzero(scale == 0)]
        raise IdentificationError(f"{context}the regressor(s) {', '.join(zero)} are identically zero on this record")
    return scale


def least_squares(
    X: np.ndarray,
    y: np.ndarray,
    names: Sequence[str],
    *,
    correlation_length: float = 1.0,
    context: str = "",
    coefficients: np.ndarray | None = None,
) -> LeastSquaresFit:
    """Solve ``X theta = y`` by least squares, with standard errors.

    Parameters
    ----------
    X
        Regressor matrix, shape ``(N, p)``.
    y
        Left-hand side, shape ``(N,)``.
    names
        Column names, for error messages.
    correlation_length
        Number of samples over which the equation error stays correlated
        (about ``fs / fc`` after a low-pass at ``fc``, divided by any
        decimation factor; 1 for independent errors). Sets the batch length
        of the batch-means covariance.
    context
        Prefix of error messages (e.g. ``"rfs: "``).
    coefficients
        The least-squares solution when the caller already has it (e.g. from
        pysindy's unbiasing step): only the covariance is computed, from the
        Gram matrix.

    Raises
    ------
    IdentificationError
        If a column is identically zero or ``X`` is rank deficient.
    """
    X = np.asarray(X, dtype=float)
    y = np.asarray(y, dtype=float)
    n, p = X.shape
    scale = column_scale(X, names, context)
    tol = max(n, p) * np.finfo(float).eps
    if coefficients is None:
        # one QR of [X/scale, y]: the solution, the singular values and (X^T X)^-1 all follow from R
        R = triangular_factor(np.column_stack([X / scale, y]))
        Rx = R[:p, :p]
        sv = np.linalg.svd(Rx, compute_uv=False)
        if sv[-1] <= sv[0] * tol:
            raise IdentificationError(
                f"{context}the regressor matrix is rank deficient (rank {int(np.sum(sv > sv[0] * tol))} of {p})"
            )
        Rinv = np.linalg.inv(Rx)
        inv = Rinv @ Rinv.T  # (Xs^T Xs)^-1
        theta = (Rinv @ R[:p, p]) / scale
    else:
        gram = (X.T @ X) / np.outer(scale, scale)
        ev = np.linalg.eigvalsh(gram)
        sv = np.sqrt(np.clip(ev[::-1], 0.0, None))
        if sv[-1] <= sv[0] * np.sqrt(tol):
            raise IdentificationError(f"{context}the regressor matrix is (nearly) rank deficient")
        inv = np.linalg.inv(gram)
        theta = np.asarray(coefficients, dtype=float)
    resid = y - X @ theta
    dof = max(n - p, 1)
    s2 = float(resid @ resid) / dof
    cov_iid = s2 * inv / np.outer(scale, scale)
    batches = int(min(MAX_BATCHES, n // max(1.0, BATCH_CORRELATION_LENGTHS * correlation_length)))
    if batches >= max(2 * p, 4):
        bounds = np.linspace(0, n, batches + 1).astype(int)
        scores = np.add.reduceat(X * resid[:, None], bounds[:-1], axis=0) / scale
        # the scores sum to zero (normal equations): one degree of freedom is used
        omega = scores.T @ scores * (batches / (batches - 1)) * (n / dof)
        cov = inv @ omega @ inv / np.outer(scale, scale)
    else:
        batches, cov = 0, cov_iid
    return LeastSquaresFit(theta, cov, cov_iid, resid, float(sv[0] / sv[-1]), batches)


def collinear_pairs(
    X: np.ndarray, names: Sequence[str], *, threshold: float = COLLINEAR_CORRELATION
) -> list[tuple[str, str, float]]:
    """Pairs of regressor columns that are nearly proportional.

    Parameters
    ----------
    X
        Regressor matrix, shape ``(N, p)``.
    names
        Column names (the term names).
    threshold
        Report pairs with ``|r| >= threshold``.

    Returns
    -------
    list of (str, str, float)
        ``(name_i, name_j, r)`` sorted by decreasing ``|r|``; ``r`` as defined
        in the module docstring (centred when a constant column is present).
    """
    X = np.asarray(X, dtype=float)
    n, p = X.shape
    gram = X.T @ X / n
    mean = X.sum(axis=0) / n
    ms = np.diag(gram).copy()
    var = np.clip(ms - mean**2, 0.0, None)
    rms = np.sqrt(ms)
    constant = (var <= 1e-12 * ms) & (ms > 0)  # std below 1e-6 of the RMS (above rounding of ms - mean^2)
    safe_rms = np.where(rms > 0, rms, 1.0)
    cosine = gram / np.outer(safe_rms, safe_rms)
    if constant.any():
        safe_std = np.sqrt(np.where(var > 0, var, 1.0))
        pearson = (gram - np.outer(mean, mean)) / np.outer(safe_std, safe_std)
    out = []
    for i in range(p):
        for j in range(i + 1, p):
            if rms[i] == 0 or rms[j] == 0 or (constant[i] and constant[j]):
                continue
            use_pearson = constant.any() and not (constant[i] or constant[j])
            r = float(pearson[i, j] if use_pearson else cosine[i, j])
            if abs(r) >= threshold:
                out.append((names[i], names[j], r))
    return sorted(out, key=lambda t: -abs(t[2]))


def collinearity_warnings(
    X: np.ndarray, names: Sequence[str], *, threshold: float = COLLINEAR_CORRELATION
) -> list[str]:
    """One warning per near-collinear pair (see :func:`collinear_pairs`)."""
    return [
        f"terms {a!r} and {b!r} are nearly collinear on this record (correlation {r:+.4f}): their coefficients "
        "trade off against each other and are poorly determined; drop one of them or use a record that "
        "separates them (e.g. a wider range of velocities)"
        for a, b, r in collinear_pairs(X, names, threshold=threshold)
    ]


def velocity_sign_disagreement(v: np.ndarray, fs: float, cutoff: float) -> float:
    """Fraction of samples where ``sign(v)`` differs from the sign of ``v`` low-passed at ``cutoff``."""
    v = np.asarray(v, dtype=float)
    return float(np.mean(np.sign(derivatives.lowpass(v, fs, cutoff)) != np.sign(v)))


def nonsmooth_warnings(
    model: Model, v: np.ndarray | None, fs: float, cutoff: float | None
) -> tuple[float | None, list[str]]:
    """Warn when non-smooth velocity terms meet a band-limited velocity (module docstring).

    Parameters
    ----------
    model
        The terms.
    v
        The velocity the regressors were evaluated on.
    fs
        Sampling frequency (Hz).
    cutoff
        The equation band (Hz); ``None`` when nothing was filtered (no warning).

    Returns
    -------
    fraction : float or None
        :func:`velocity_sign_disagreement`, or ``None`` when not applicable.
    warnings : list of str
        One warning when the fraction exceeds :data:`SIGN_DISAGREEMENT`.
    """
    terms = [t.name for t in model.terms if t.slope_at_rest()[0] == "nonsmooth"]
    if not terms or v is None or cutoff is None:
        return None, []
    fraction = velocity_sign_disagreement(v, fs, cutoff)
    if fraction <= SIGN_DISAGREEMENT:
        return fraction, []
    return fraction, [
        f"{', '.join(terms)} {'is' if len(terms) == 1 else 'are'} discontinuous at v = 0, but on this record the "
        f"velocity changes sign on {100 * fraction:.1f} % of the samples when cut to the equation band "
        f"({cutoff:.3g} Hz): fast velocity reversals are missed, which biases these coefficients towards zero "
        "(measure the velocity, or see docs/sindy.md)"
    ]
