"""Physics of the identified oscillator: K(z), D(z, v), equilibria, modes, residual.

All functions take a :class:`~nlid.terms.Model` and its coefficients
(``{canonical term: value}`` or a vector in model order). Coefficients are the
coefficients of the terms of the restoring force
``R(z, v) = K(z) + D(z, v) = f - m z''`` (Eq. 5, 6, 25).

* ``K(z)``: the stiffness family (terms without v, the constant included), Eq. 6.
* ``D(z, v)``: the damping family, Eq. 14 / 24.
* ``U(z) = integral_0^z K``: the potential, Eq. 7.
* Equilibria: roots of ``K``; stable where ``K' > 0`` (Fig. 4).
* Linear natural frequency at a stable equilibrium: ``sqrt(K'(z*) / m)``, Eq. 8.
* Damping ratio there: ``c(z*) / (2 m w_n)`` with ``c(z*) = dD/dv(z*, 0)``
  from the terms that are linear in v at rest (``v``, ``z^2*v``,
  ``v*|px(z)|``, ``tanh(v/c)``...); Coulomb-like terms have no linearisation
  and are left out. When ``v`` is the only such term this is Eq. 22.
* The percentage RMS residual ``epsilon`` of Eq. 26.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field

import numpy as np
from scipy import optimize

from . import derivatives
from .errors import DataError, InputError
from .record import Record
from .terms import Model

__all__ = [
    "Coefficients",
    "Equilibria",
    "Modal",
    "RegressionData",
    "elastic",
    "damping",
    "restoring",
    "potential",
    "equilibria",
    "stiffness_roots",
    "modal",
    "regression_data",
    "epsilon",
    "residual_percent",
    "force_residual_percent",
    "rms_contributions",
    "damping_slice",
    "DampingSlice",
]

Coefficients = Mapping[str, float] | np.ndarray | Sequence[float]


def elastic(model: Model, coefficients: Coefficients, z: np.ndarray) -> np.ndarray:
    """The elastic restoring force ``K(z)`` (Eq. 6): the stiffness-family terms."""
    return model.evaluate_terms(dict_or_vector(model, coefficients), z, family="stiffness")


def damping(model: Model, coefficients: Coefficients, z: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The damping force ``D(z, v)`` (Eq. 14, 24): the velocity-dependent terms."""
    return model.evaluate_terms(dict_or_vector(model, coefficients), z, v, family="damping")


def restoring(model: Model, coefficients: Coefficients, z: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The restoring force ``R(z, v) = K(z) + D(z, v)`` (Eq. 25)."""
    return model.evaluate_terms(dict_or_vector(model, coefficients), z, v)


def dict_or_vector(model: Model, coefficients: Coefficients) -> np.ndarray:
    """Coefficients as a vector in model order."""
    if isinstance(coefficients, Mapping):
        return model.vector(dict(coefficients))
    return model.vector(coefficients)


def potential(model: Model, coefficients: Coefficients, z: np.ndarray) -> np.ndarray:
    """The potential ``U(z) = int_0^z K(s) ds`` (Eq. 7), by 32-point Gauss-Legendre."""
    z = np.asarray(z, dtype=float)
    nodes, weights = np.polynomial.legendre.leggauss(32)
    s = 0.5 * (nodes[None, :] + 1.0) * z.reshape(-1, 1)
    k = elastic(model, coefficients, s.ravel()).reshape(s.shape)
    return (0.5 * z.reshape(-1) * (k @ weights)).reshape(z.shape)


def _stiffness_polynomial(model: Model, theta: np.ndarray, with_constant: bool = True) -> np.ndarray | None:
    """Coefficients (highest power first) of K if it is a polynomial, else None."""
    coeffs: dict[int, float] = {}
    for term, value in zip(model.terms, theta, strict=True):
        if term.family != "stiffness":
            continue
        power = term.polynomial_power
        if power is None:
            return None
        if power == 0 and not with_constant:
            continue
        coeffs[power] = coeffs.get(power, 0.0) + float(value)
    if not coeffs:
        return np.zeros(1)
    deg = max(coeffs)
    return np.array([coeffs.get(k, 0.0) for k in range(deg, -1, -1)])


def _derivative(fun, z: np.ndarray) -> np.ndarray:
    h = 1e-6 * np.maximum(np.abs(z), 1e-3)
    return (fun(z + h) - fun(z - h)) / (2.0 * h)


@dataclass(frozen=True)
class Equilibria:
    """Equilibrium positions (m), sorted ascending."""

    stable: tuple[float, ...]
    unstable: tuple[float, ...]

    @property
    def all(self) -> tuple[float, ...]:
        """Every equilibrium, sorted."""
        return tuple(sorted(self.stable + self.unstable))

    def to_dict(self) -> dict[str, list[float]]:
        """``{"stable": [...], "unstable": [...]}``."""
        return {"stable": list(self.stable), "unstable": list(self.unstable)}


def _real_roots(poly: np.ndarray) -> np.ndarray:
    poly = np.trim_zeros(np.asarray(poly, dtype=float), "f")
    if poly.size <= 1:
        return np.zeros(0)
    roots = np.roots(poly)
    scale = max(1.0, float(np.max(np.abs(roots))))
    real = roots[np.abs(roots.imag) <= 1e-7 * scale].real
    return np.sort(real)


def _numeric_roots(fun, lo: float, hi: float, n: int = 4001) -> np.ndarray:
    grid = np.linspace(lo, hi, n)
    values = fun(grid)
    roots = []
    for i in np.flatnonzero(np.signbit(values[:-1]) != np.signbit(values[1:])):
        roots.append(optimize.brentq(lambda x: float(fun(np.array([x]))[0]), grid[i], grid[i + 1], xtol=1e-14))
    return np.array(roots)


def equilibria(
    model: Model,
    coefficients: Coefficients,
    z_range: Sequence[float] | None = None,
) -> Equilibria:
    """Roots of ``K(z)`` classified by the sign of ``K'`` (Sec. 2.1, Fig. 4).

    Parameters
    ----------
    model, coefficients
        The identified (or true) model.
    z_range
        ``(z_min, z_max)`` of the data. Polynomial stiffness is solved exactly
        and roots farther than one range-width outside it are dropped (they are
        artefacts of extrapolating a fit); other stiffness laws are solved
        numerically on the range widened by half its width on each side, and
        then ``z_range`` is required.
    """
    theta = dict_or_vector(model, coefficients)
    poly = _stiffness_polynomial(model, theta)

    def k_of(z: np.ndarray) -> np.ndarray:
        return elastic(model, theta, z)

    if poly is not None:
        roots = _real_roots(poly)
        slopes = np.polyval(np.polyder(poly), roots) if roots.size else roots
        if z_range is not None:
            lo, hi = float(min(z_range)), float(max(z_range))
            width = hi - lo
            keep = (roots >= lo - width) & (roots <= hi + width)
            roots, slopes = roots[keep], slopes[keep]
    else:
        if z_range is None:
            raise InputError("equilibria of a non-polynomial stiffness need the data range z_range")
        lo, hi = float(min(z_range)), float(max(z_range))
        width = hi - lo
        roots = _numeric_roots(k_of, lo - 0.5 * width, hi + 0.5 * width)
        slopes = _derivative(k_of, roots) if roots.size else roots
    stable = tuple(float(r) for r, s in zip(roots, slopes, strict=True) if s > 0)
    unstable = tuple(float(r) for r, s in zip(roots, slopes, strict=True) if s <= 0)
    return Equilibria(stable=stable, unstable=unstable)


def stiffness_roots(
    model: Model, coefficients: Coefficients, z_range: Sequence[float] | None = None
) -> tuple[float, float]:
    """Roots ``z^- < 0 < z^+`` of ``p_zeta`` (Eq. 4) for ``px(z)`` (Eq. 9-11).

    ``p_zeta`` is the stiffness without the constant (gravity excluded) and
    without terms that themselves use ``px``; ``z^-`` and ``z^+`` are its real
    roots nearest to zero on either side.

    Raises
    ------
    InputError
        If the stiffness has no root on one side of zero (not a double well).
    """
    theta = dict_or_vector(model, coefficients)
    keep = [i for i, t in enumerate(model.terms) if t.family == "stiffness" and not t.is_constant and not t.uses_px]
    if not keep:
        raise InputError("px(z) needs stiffness terms to take its roots from")
    sub = Model(tuple(model.terms[i] for i in keep))
    sub_theta = theta[keep]
    poly = _stiffness_polynomial(sub, sub_theta, with_constant=False)
    if poly is not None:
        roots = _real_roots(poly)
    else:
        lo, hi = (-1.0, 1.0) if z_range is None else (float(min(z_range)), float(max(z_range)))
        width = hi - lo
        roots = _numeric_roots(lambda z: elastic(sub, sub_theta, z), lo - width, hi + width)
    scale = max(1e-12, float(np.max(np.abs(roots)))) if roots.size else 1.0
    neg = roots[roots < -1e-9 * scale]
    pos = roots[roots > 1e-9 * scale]
    if neg.size == 0 or pos.size == 0:
        raise InputError(
            "px(z) needs the stiffness to have a root on each side of zero (a double well); "
            f"the roots are {', '.join(f'{r:.4g}' for r in roots) or 'none'}"
        )
    return float(neg.max()), float(pos.min())


@dataclass(frozen=True)
class Modal:
    """Linearised modal parameters at one stable equilibrium (Eq. 8, 22).

    Attributes
    ----------
    equilibrium
        The equilibrium position (m).
    fn_hz
        Natural frequency (Hz).
    zeta
        Damping ratio (fraction, not percent).
    stiffness
        ``K'(z*)`` (N/m).
    damping
        Linearised viscous coefficient ``dD/dv(z*, 0)`` (N s/m).
    """

    equilibrium: float
    fn_hz: float
    zeta: float
    stiffness: float
    damping: float

    def to_dict(self) -> dict[str, float]:
        """Plain dictionary."""
        return asdict(self)


def linear_damping(model: Model, coefficients: Coefficients, z: float) -> float:
    """``dD/dv`` at ``(z, v = 0)`` from the terms that are linear in v at rest."""
    theta = dict_or_vector(model, coefficients)
    total = 0.0
    zz = np.array([float(z)])
    for term, value in zip(model.terms, theta, strict=True):
        kind, factor = term.slope_at_rest()
        if kind != "linear":
            continue
        part = Model((term.position_part(),), model.px_roots)
        total += float(value) * factor * float(part.evaluate(zz)[0, 0])
    return total


def modal(
    model: Model,
    coefficients: Coefficients,
    mass: float | None,
    points: Sequence[float] | None = None,
    z_range: Sequence[float] | None = None,
) -> list[Modal]:
    """Modal parameters at each stable equilibrium (or at given points).

    Parameters
    ----------
    model, coefficients
        The model.
    mass
        Mass in kg; ``None`` gives an empty list (frequencies need the mass).
    points
        Positions to linearise at; default: the stable equilibria.
    z_range
        Passed to :func:`equilibria`.
    """
    if mass is None:
        return []
    theta = dict_or_vector(model, coefficients)
    if points is None:
        points = equilibria(model, theta, z_range).stable
    out = []
    for z0 in points:
        k = float(_derivative(lambda z: elastic(model, theta, z), np.array([float(z0)]))[0])
        c = linear_damping(model, theta, z0)
        if k <= 0:
            continue
        wn = np.sqrt(k / mass)
        out.append(Modal(float(z0), float(wn / (2 * np.pi)), float(c / (2 * mass * wn)), k, c))
    return out


# --------------------------------------------------------------------------- the restoring surface
#: The regressors are evaluated on z and v kept to this multiple of the
#: equation band (capped at 0.4 fs) before being cut to the band: measured on
#: paper-numerical with 2 % noise, a factor 4 instead of 1 cuts the RFS error
#: of mu from 3.1 % to 0.6 % and of c_v from 41 % to 2.5 %.
REGRESSOR_BAND_FACTOR = 4.0
#: Samples within this many cut-off periods of either end are dropped from a
#: filtered force balance: there the filters have not settled (on
#: paper-numerical the first samples' residual reaches 90 N).
EDGE_PERIODS = 3.0


@dataclass(frozen=True)
class RegressionData:
    """Force, acceleration and regressors on a common footing.

    When a channel the model needs (the acceleration, or the velocity of
    velocity-dependent terms) is estimated from the displacement, the force
    balance ``f - m a = G theta`` is formed in the band of the differentiating
    filter (cut-off ``fc``):

    * ``a`` is the displacement differentiated twice through the low-pass at
      ``fc`` (or the measured ``a`` low-passed at ``fc``);
    * each regressor ``g_i(z, v)`` is evaluated on ``z`` and ``v`` kept to the
      wider band ``REGRESSOR_BAND_FACTOR * fc`` (the terms are nonlinear, so
      their in-band part depends on the motion above ``fc``), then low-passed
      at ``fc``;
    * the force is low-passed at ``fc``; a zero-order-held force
      (``record.force_hold == "zoh"``) compared with an acceleration derived
      from the motion is first given the hold's response
      (:func:`nlid.derivatives.zoh_equivalent`), since the motion feels it
      half a sample late.

    Every filter is the same zero-phase response (:mod:`nlid.derivatives`), so
    no phase or gain mismatch enters. The ``EDGE_PERIODS * fs / fc`` samples
    at each end, where the filters have not settled, are dropped from every
    array. With every needed channel measured nothing is filtered or dropped:
    the samples are consistent as they are.

    Attributes
    ----------
    f, a
        Force and acceleration, shape ``(N,)``.
    G
        Regressor matrix, shape ``(N, p)``.
    z, v
        The displacement and velocity the regressors were evaluated on.
    filtered_at
        The equation band ``fc`` in Hz, or ``None``.
    provenance
        Where each channel came from.
    kept
        The slice of the record's samples that hold a settled force balance;
        the arrays are these samples (or every sample, with ``trim=False``).
    """

    f: np.ndarray
    a: np.ndarray
    G: np.ndarray
    z: np.ndarray
    v: np.ndarray | None
    filtered_at: float | None
    provenance: dict[str, str]
    kept: slice = field(default_factory=lambda: slice(None))

    def restoring_force(self, mass: float) -> np.ndarray:
        """``R_e = f - m a`` (Eq. 25)."""
        return self.f - mass * self.a


def regression_data(
    record: Record, model: Model, *, cutoff: float | None = None, trim: bool = True, regressors: bool = True
) -> RegressionData:
    """Evaluate the model's regressors and the force balance on a record.

    Parameters
    ----------
    record
        The data; missing ``v`` and ``a`` are estimated from ``z``.
    model
        The terms.
    cutoff
        Equation band ``fc`` in Hz (default
        :func:`nlid.derivatives.suggest_cutoff` of ``z``); only used when a
        needed channel is estimated.
    trim
        Drop the unsettled ends (default). With ``trim=False`` the arrays keep
        every sample of the record and :attr:`RegressionData.kept` says which
        of them hold a settled force balance (for callers that filter
        further, or that mark the ends as missing themselves).
    regressors
        Evaluate the model's columns (default). With ``False``, ``G`` has no
        columns and the model only says which channels are needed: for
        callers that evaluate the regressors themselves.
    """
    needs_v = model.uses_velocity
    estimated = not record.is_measured("a") or (needs_v and not record.is_measured("v"))
    prov = {c: record.source_of(c) for c in record.channels}
    if not estimated:
        v = record.v if needs_v else None
        G = model.evaluate(record.z, v) if regressors else np.empty((record.n, 0))
        return RegressionData(record.f, record.a, G, record.z, v, None, prov)
    fs = record.fs
    fc = float(cutoff) if cutoff is not None else derivatives.suggest_cutoff(record.z, fs)
    wide = min(REGRESSOR_BAND_FACTOR * fc, derivatives.CUTOFF_MAX_FRACTION * fs)
    z = derivatives.lowpass(record.z, fs, wide)
    v = None
    if needs_v:
        if record.is_measured("v"):
            v = derivatives.lowpass(record.v, fs, wide)
        else:
            v, used = derivatives.differentiate(record.z, fs, order=1, cutoff=wide)
            prov["v"] = f"estimated from z: {used.describe()}"
    G = derivatives.lowpass(model.evaluate(z, v), fs, fc) if regressors else np.empty((record.n, 0))
    if record.is_measured("a"):
        a = derivatives.lowpass(record.a, fs, fc)
        f = derivatives.lowpass(record.f, fs, fc)
    else:
        a, used = derivatives.differentiate(record.z, fs, order=2, cutoff=fc)
        prov["a"] = f"estimated from z: {used.describe()}"
        # the acceleration of the motion feels a held force half a sample late
        f = (
            derivatives.zoh_equivalent(record.f, fs, fc)
            if record.force_hold == "zoh"
            else derivatives.lowpass(record.f, fs, fc)
        )
    edge = int(np.ceil(EDGE_PERIODS * fs / fc))
    if record.n - 2 * edge < max(64, 4 * len(model)):
        raise DataError(
            f"record too short for a filtered force balance: {record.n} samples, {edge} dropped at each end "
            f"at the cut-off {fc:.3g} Hz"
        )
    keep = slice(edge, record.n - edge)
    if not trim:
        return RegressionData(f, a, G, z, v, fc, prov, keep)
    return RegressionData(f[keep], a[keep], G[keep], z[keep], None if v is None else v[keep], fc, prov, keep)


def epsilon(measured: np.ndarray, identified: np.ndarray) -> float:
    """Percentage RMS residual ``100 RMS(R - R_e) / RMS(R_e)`` (Eq. 26)."""
    measured = np.asarray(measured, dtype=float)
    rms = np.sqrt(np.mean(measured**2))
    if rms == 0:
        raise DataError("the measured restoring force is identically zero")
    return float(100.0 * np.sqrt(np.mean((np.asarray(identified) - measured) ** 2)) / rms)


def residual_percent(
    record: Record,
    model: Model,
    coefficients: Coefficients,
    mass: float,
    *,
    cutoff: float | None = None,
    data: RegressionData | None = None,
) -> float:
    """Epsilon (Eq. 26) of a model on a record, computed from the data.

    Parameters
    ----------
    record, model, coefficients, mass
        The data and the identified model.
    cutoff
        Differentiating-filter cut-off for estimated channels.
    data
        Pre-computed :func:`regression_data` (saves the filtering).
    """
    data = data if data is not None else regression_data(record, model, cutoff=cutoff)
    theta = dict_or_vector(model, coefficients)
    return epsilon(data.restoring_force(mass), data.G @ theta)


def force_residual_percent(data: RegressionData, coefficients: np.ndarray, mass: float) -> float:
    """Residual relative to the force: ``100 RMS(f - m a - G theta) / RMS(f)``.

    This is the "relative force residual" of inverse-dynamics benchmarks such
    as EMPS (IDIM-LS), where the mass is estimated with the other
    coefficients and the force is the regressed variable. It has the same
    numerator as epsilon (Eq. 26) but divides by the force, not by the
    restoring force.
    """
    resid = data.f - mass * data.a - data.G @ np.asarray(coefficients, dtype=float)
    return float(100.0 * np.sqrt(np.mean(resid**2)) / np.sqrt(np.mean(data.f**2)))


@dataclass(frozen=True)
class DampingSlice:
    """The damping force near one position (paper Fig. 21 b-d).

    Attributes
    ----------
    z0, half_width
        The slice ``|z - z0| <= half_width`` (m).
    v
        Velocities of the samples in the slice (m/s).
    measured
        Their measured damping force ``R_e - K(z)`` (N): the restoring force
        minus the identified elastic part at each sample's own position,
        formed in the force balance's band (the stiffness columns of ``G``)
        so that a filtered balance does not leak the out-of-band part of
        ``K(z)`` into the damping force.
    v_grid, model
        The identified ``D(z0, v)`` on a velocity grid spanning the slice.
    """

    z0: float
    half_width: float
    v: np.ndarray
    measured: np.ndarray
    v_grid: np.ndarray
    model: np.ndarray


def damping_slice(
    data: RegressionData,
    model: Model,
    coefficients: Coefficients,
    mass: float,
    z0: float,
    half_width: float | None = None,
    grid: int = 200,
) -> DampingSlice:
    """Slice the restoring surface at ``z0`` to compare ``D`` with the data (Fig. 21 b-d).

    Parameters
    ----------
    data
        From :func:`regression_data` (needs velocity: the model must have
        velocity terms).
    model, coefficients, mass
        The identified model.
    z0
        Position of the slice (m).
    half_width
        Half width of the slice; default 5 % of the displacement range.
    grid
        Number of velocity points of the model curve.
    """
    if data.v is None:
        raise InputError("a damping slice needs velocity: the model has no velocity-dependent term")
    theta = dict_or_vector(model, coefficients)
    if data.G.shape[1] != len(model):
        raise InputError(f"the force balance has {data.G.shape[1]} regressors but the model has {len(model)} terms")
    if half_width is None:
        half_width = 0.05 * float(np.ptp(data.z))
    near = np.abs(data.z - z0) <= half_width
    if near.sum() < 3:
        raise InputError(f"fewer than 3 samples within {half_width:.3g} m of z0 = {z0:.4g} m")
    v = data.v[near]
    stiff = [i for i, t in enumerate(model.terms) if t.family == "stiffness"]
    # K in the balance's band: the stiffness regressors of G (equal to K(z) when nothing is filtered)
    measured = data.restoring_force(mass)[near] - data.G[near][:, stiff] @ theta[stiff]
    v_grid = np.linspace(v.min(), v.max(), grid)
    curve = damping(model, theta, np.full(grid, float(z0)), v_grid)
    return DampingSlice(float(z0), float(half_width), v, measured, v_grid, curve)


def rms_contributions(
    model: Model, coefficients: Coefficients, z: np.ndarray, v: np.ndarray | None
) -> dict[str, float]:
    """RMS of each term's contribution ``theta_i g_i`` to ``R`` (paper Fig. 22)."""
    theta = dict_or_vector(model, coefficients)
    G = model.evaluate(z, v)
    return {name: float(np.sqrt(np.mean((G[:, i] * theta[i]) ** 2))) for i, name in enumerate(model.names)}
