"""The force balance of a structure as a regression: ``f - M a = K z + C v + s + B theta g`` per DOF.

The multi-DOF counterpart of :func:`nlid.estimation.balance.regression_data`, shared by
the identifiers of several DOFs (``rfs``, ``sindy``, ``oe``'s start).
:func:`structure_regression_data` puts every channel on one footing: when a
velocity or acceleration is estimated from the displacement (a structure's
balance always needs the velocity, for ``C``), every DOF passes through the
same zero-phase filters, as for one DOF:

* ``a`` is the displacement differentiated twice through the low-pass at
  ``fc`` (or the measured ``a`` low-passed at ``fc``);
* each element's regressor ``g_e(x_e, x_e')`` is evaluated on the
  displacements and velocities kept to the wider band
  ``REGRESSOR_BAND_FACTOR * fc``, then low-passed at ``fc``; the linear
  regressors ``z`` and ``v`` are the wide-band ones low-passed at ``fc``;
* the force is low-passed at ``fc`` (given the hold's response first when it
  was zero-order held and ``a`` is derived from the motion).

One cut-off serves every DOF (:meth:`Record.suggest_cutoff <nlid.data.record.Record.suggest_cutoff>`), and
``EDGE_PERIODS * fs / fc`` samples are dropped at each end. With every
velocity and acceleration measured nothing is filtered. Any other nonlinear
function of the motion (a candidate element, a probe) enters the balance on
the same footing through :meth:`StructureRegressionData.regressors`.

:func:`linear_design` builds the columns of the joint least squares: the
unknowns are the element coefficients ``theta`` (each shared by the two DOFs
its element connects), the free entries of ``K`` and ``C`` (symmetric by
default: ``n (n + 1) / 2`` each, which also couples the DOFs' equations), the
static force per DOF and, with the mass unknown, the free entries of ``M``.
The equations of the DOFs are interleaved sample by sample (row ``t n + k``),
so contiguous rows are contiguous in time (batch-means standard errors).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from ..base.validate import check_cutoff
from ..data.record import Record
from ..errors import InputError
from ..model.elements import ElementSet
from ..signal import derivatives
from .balance import REGRESSOR_BAND_FACTOR, settled_samples

__all__ = [
    "StructureRegressionData",
    "structure_regression_data",
    "stack_regression_data",
    "matrix_basis",
    "linear_design",
    "LinearDesign",
    "check_elements_nonlinear",
    "dof_weights",
    "matrix_labels",
    "static_labels",
    "unknown_names",
]


@dataclass(frozen=True)
class StructureRegressionData:
    """Force, acceleration, motion and element regressors of a structure on a common footing.

    Attributes
    ----------
    z, v, a, f
        ``(N, n)``: displacement, velocity, acceleration and force per DOF (in the equation band).
    G
        ``(N, n_elements)``: each element's ``g_e(x_e, x_e')``.
    filtered_at
        The equation band ``fc`` (Hz), ``None`` when nothing was filtered.
    provenance
        Where each channel came from.
    kept
        The samples of the record whose balance has settled (the rows, when :attr:`trimmed`).
    fs
        The record's sampling frequency (Hz).
    wide
        The whole record's displacements and velocities in the regressor band (the measured ones when
        nothing is filtered), from which :meth:`regressors` builds new columns; ``None`` for stacked parts.
    trimmed
        The rows are the settled samples :attr:`kept` (else every sample of the record).
    """

    z: np.ndarray
    v: np.ndarray
    a: np.ndarray
    f: np.ndarray
    G: np.ndarray
    filtered_at: float | None
    provenance: dict[str, str]
    kept: slice
    fs: float | None = None
    wide: tuple[np.ndarray, np.ndarray] | None = field(default=None, repr=False)
    trimmed: bool = True

    @property
    def n(self) -> int:
        """Number of samples."""
        return int(self.z.shape[0])

    @property
    def n_dofs(self) -> int:
        """Number of DOFs."""
        return int(self.z.shape[1])

    def regressors(self, evaluate: Callable[[np.ndarray, np.ndarray], np.ndarray]) -> np.ndarray:
        """Columns of a nonlinear function of the motion on the footing of :attr:`G` (module docstring).

        ``evaluate(z, v)`` receives the whole record's displacements and velocities ``(N_record, n)`` in the
        regressor band (the measured ones when nothing is filtered) and returns ``(N_record, m)`` columns;
        they are low-passed at :attr:`filtered_at` and cut to these rows, as the elements' :attr:`G` are.
        A candidate element or a probe scored against ``f - M a`` must be built this way: the same
        function of the motion in the narrow band alone misses what the motion above ``fc`` puts into
        the band (on a 3-DOF chain with 1 % noise, a cubic fitted that way came out 24 % low).

        Raises
        ------
        InputError
            The data were stacked from parts (:func:`stack_regression_data`) and cannot take new columns.
        """
        if self.wide is None:
            raise InputError("stacked regression data cannot take new columns; build them on each part")
        out = np.asarray(evaluate(*self.wide), dtype=float)
        out = out.reshape(out.shape[0], -1)
        if self.filtered_at is not None and out.shape[1]:
            out = derivatives.lowpass(out, float(self.fs), self.filtered_at)
        return out[self.kept] if self.trimmed else out

    def with_elements(self, elements: ElementSet) -> StructureRegressionData:
        """The same samples with :attr:`G` the regressors of ``elements``."""
        G = self.regressors(elements.evaluate) if len(elements) else np.empty((self.n, 0))
        return replace(self, G=G)


def stack_regression_data(parts: Sequence[StructureRegressionData]) -> StructureRegressionData:
    """The rows of several parts of a record (each filtered on its own) as one data set, for one joint fit."""
    first = parts[0]
    join = lambda key: np.concatenate([getattr(p, key) for p in parts], axis=0)  # noqa: E731
    rows = sum(p.n for p in parts)
    return StructureRegressionData(
        join("z"), join("v"), join("a"), join("f"), join("G"), first.filtered_at, dict(first.provenance),
        slice(0, rows), first.fs, None, True,
    )  # fmt: skip


def check_elements_nonlinear(elements: ElementSet, context: str) -> None:
    """Refuse an element that is a linear spring or damper: that is part of ``K`` or ``C``, which are estimated."""
    for e in elements:
        if e.term.name in ("z", "v"):
            kind = "K" if e.term.name == "z" else "C"
            raise InputError(
                f"{context}element {e.name} is linear: the underlying linear {kind} is identified in full; leave it out"
            )


def _columns(x: np.ndarray) -> list[np.ndarray]:
    return [x[:, k] for k in range(x.shape[1])]


def structure_regression_data(
    record: Record, elements: ElementSet, *, cutoff: float | None = None, trim: bool = True
) -> StructureRegressionData:
    """The samples of a structure's force balance and its element regressors (module docstring).

    Parameters
    ----------
    record
        The data; missing velocities and accelerations are estimated from the displacements.
    elements
        The elements whose regressors are evaluated.
    cutoff
        Equation band ``fc`` (Hz); default :meth:`Record.suggest_cutoff <nlid.data.record.Record.suggest_cutoff>`.
        Only used when a channel is estimated.
    trim
        Drop the unsettled ends (default); with ``False`` every sample is kept and :attr:`kept` says
        which hold a settled balance.

    Raises
    ------
    DataError
        A record too short for the filtered balance.
    """
    check_cutoff(cutoff, record.fs)
    if elements.n_dofs != record.n_dofs:
        raise InputError(f"the elements are on {elements.n_dofs} DOFs but the record has {record.n_dofs}")
    n = record.n_dofs
    prov = {c: record.source_of(c) for c in record.channels}
    measured_v = record.v is not None and all(record.is_measured(f"v{k}") for k in range(1, n + 1))
    measured_a = record.a is not None and all(record.is_measured(f"a{k}") for k in range(1, n + 1))
    if measured_v and measured_a:
        raw = StructureRegressionData(
            record.z, record.v, record.a, record.f, np.empty((record.n, 0)), None, prov, slice(0, record.n),
            record.fs, (record.z, record.v), trim,
        )  # fmt: skip
        return raw.with_elements(elements)
    fs = record.fs
    fc = record.suggest_cutoff() if cutoff is None else float(cutoff)
    wide = min(REGRESSOR_BAND_FACTOR * fc, derivatives.CUTOFF_MAX_FRACTION * fs)
    z_wide = derivatives.lowpass(record.z, fs, wide)
    if measured_v:
        v_wide = derivatives.lowpass(record.v, fs, wide)
    else:
        v_wide = np.empty_like(record.z)
        for k, col in enumerate(_columns(record.z)):
            v_wide[:, k], used = derivatives.differentiate(col, fs, order=1, cutoff=wide)
            prov[f"v{k + 1}"] = f"estimated from z{k + 1}: {used.describe()}"
    z = derivatives.lowpass(z_wide, fs, fc)
    v = derivatives.lowpass(v_wide, fs, fc)
    if measured_a:
        a = derivatives.lowpass(record.a, fs, fc)
        f = derivatives.lowpass(record.f, fs, fc)
    else:
        a = np.empty_like(record.z)
        for k in range(n):
            if record.v is not None and record.is_measured(f"v{k + 1}"):
                a[:, k], used = derivatives.differentiate(record.v[:, k], fs, order=1, cutoff=fc)
                prov[f"a{k + 1}"] = f"estimated from v{k + 1}: {used.describe()}"
            else:
                a[:, k], used = derivatives.differentiate(record.z[:, k], fs, order=2, cutoff=fc)
                prov[f"a{k + 1}"] = f"estimated from z{k + 1}: {used.describe()}"
        if record.force_hold == "zoh":  # the motion feels a held force half a sample late
            f = derivatives.zoh_equivalent(record.f, fs, fc)
        else:
            f = derivatives.lowpass(record.f, fs, fc)
        f = np.asarray(f, dtype=float).reshape(record.n, n)
    keep = settled_samples(record.n, fs, fc, len(elements) + n * n + n)
    rows = keep if trim else slice(None)
    empty = np.empty((record.n, 0))[rows]
    out = StructureRegressionData(z[rows], v[rows], a[rows], f[rows], empty, fc, prov, keep, fs, (z_wide, v_wide), trim)
    return out.with_elements(elements)


def matrix_basis(n: int, form: str) -> list[tuple[int, int]]:
    """The free entries ``(i, j)`` of an ``n x n`` matrix: ``"symmetric"`` (``i <= j``), ``"full"``, ``"diagonal"``."""
    if form == "symmetric":
        return [(i, j) for i in range(n) for j in range(i, n)]
    if form == "full":
        return [(i, j) for i in range(n) for j in range(n)]
    if form == "diagonal":
        return [(i, i) for i in range(n)]
    raise InputError(f"matrix form must be 'symmetric', 'full' or 'diagonal', got {form!r}")


def matrix_labels(key: str, basis: Sequence[tuple[int, int]]) -> list[str]:
    """Names of a matrix's free entries, ``K[1,2]`` (1-based), as the design names its unknowns."""
    return [f"{key}[{i + 1},{j + 1}]" for i, j in basis]


def static_labels(n: int) -> list[str]:
    """Names of the static force per DOF, ``s[1]`` ... ``s[n]``."""
    return [f"s[{k + 1}]" for k in range(n)]


def unknown_names(elements: ElementSet, stiffness: str = "symmetric") -> tuple[str, ...]:
    """The unknowns :func:`linear_design` solves for with the mass given, in its order."""
    n = elements.n_dofs
    basis = matrix_basis(n, stiffness)
    names = [*elements.names, *matrix_labels("K", basis), *matrix_labels("C", basis)]
    return tuple(names + (static_labels(n) if elements.static else []))


def _block(x: np.ndarray, basis: Sequence[tuple[int, int]], symmetric: bool) -> np.ndarray:
    """Columns ``d(A x)/dA_ij`` of every DOF's equation, rows interleaved: shape ``(N n, len(basis))``."""
    N, n = x.shape
    out = np.zeros((N, n, len(basis)))
    for c, (i, j) in enumerate(basis):
        out[:, i, c] = x[:, j]
        if symmetric and i != j:
            out[:, j, c] = x[:, i]
    return out.reshape(N * n, len(basis))


def _assemble(basis: Sequence[tuple[int, int]], values: np.ndarray, n: int, symmetric: bool) -> np.ndarray:
    A = np.zeros((n, n))
    for (i, j), value in zip(basis, values, strict=True):
        A[i, j] = value
        if symmetric:
            A[j, i] = value
    return A


@dataclass(frozen=True)
class LinearDesign:
    """The joint least-squares problem of a structure's force balance.

    Attributes
    ----------
    X
        ``(N n, p)`` regressors, the DOFs' equations interleaved sample by sample.
    y
        ``(N n,)`` left-hand side: ``f - M a`` (mass known) or ``f`` (mass estimated).
    names
        The ``p`` unknowns: the elements' names, ``K[i,j]``, ``C[i,j]``, ``s[k]``, ``M[i,j]`` (1-based).
    parts
        ``{"theta" | "K" | "C" | "s" | "M": slice}`` of the unknowns.
    """

    X: np.ndarray
    y: np.ndarray
    names: tuple[str, ...]
    parts: dict[str, slice]
    bases: dict[str, list[tuple[int, int]]]
    symmetric: dict[str, bool]
    n_dofs: int

    def split(self, p: np.ndarray) -> dict[str, np.ndarray]:
        """Unknowns to ``{"theta": vector, "K", "C", "M": matrices or None, "s": vector or None}``."""
        n = self.n_dofs
        out: dict[str, np.ndarray | None] = {"theta": p[self.parts["theta"]]}
        for key in ("K", "C", "M"):
            out[key] = (
                _assemble(self.bases[key], p[self.parts[key]], n, self.symmetric[key]) if key in self.parts else None
            )
        out["s"] = p[self.parts["s"]] if "s" in self.parts else None
        return out  # type: ignore[return-value]


def linear_design(
    data: StructureRegressionData,
    elements: ElementSet,
    *,
    mass: np.ndarray | None,
    stiffness: str = "symmetric",
    mass_form: str = "diagonal",
    step: int = 1,
) -> LinearDesign:
    """The joint least squares of every DOF's force balance (module docstring).

    Parameters
    ----------
    data
        The balance samples.
    elements
        The elements (their regressors are ``data.G``).
    mass
        The known mass matrix (kg), or ``None``: its entries (``mass_form``) become unknowns.
    stiffness
        Form of ``K`` and ``C``: ``"symmetric"`` or ``"full"``.
    mass_form
        Form of an estimated mass matrix: ``"diagonal"`` (lumped) or ``"symmetric"``.
    step
        Keep every ``step``-th sample.
    """
    n = data.n_dofs
    rows = slice(None, None, step)
    z, v, a, f, G = (x[rows] for x in (data.z, data.v, data.a, data.f, data.G))
    N = z.shape[0]
    blocks, names, parts, bases, symmetric = [], [], {}, {}, {}
    start = 0

    def add(key: str, block: np.ndarray, labels: list[str]) -> None:
        nonlocal start
        blocks.append(block)
        names.extend(labels)
        parts[key] = slice(start, start + block.shape[1])
        start += block.shape[1]

    B = elements.B
    add("theta", (G[:, None, :] * B[None, :, :]).reshape(N * n, len(elements)), list(elements.names))
    for key, x in (("K", z), ("C", v)):
        basis = matrix_basis(n, stiffness)
        bases[key], symmetric[key] = basis, stiffness == "symmetric"
        add(key, _block(x, basis, symmetric[key]), matrix_labels(key, basis))
    if elements.static:
        S = np.zeros((N, n, n))
        S[:, np.arange(n), np.arange(n)] = 1.0
        add("s", S.reshape(N * n, n), static_labels(n))
    if mass is None:
        basis = matrix_basis(n, mass_form)
        bases["M"], symmetric["M"] = basis, mass_form == "symmetric"
        add("M", _block(a, basis, symmetric["M"]), matrix_labels("M", basis))
        y = f.reshape(-1)
    else:
        y = (f - a @ np.asarray(mass).T).reshape(-1)
    X = np.concatenate(blocks, axis=1) if blocks else np.empty((N * n, 0))
    return LinearDesign(X, y, tuple(names), parts, bases, symmetric, n)


def dof_weights(residual: np.ndarray, y: np.ndarray, n_dofs: int) -> np.ndarray:
    """Weight of each DOF's equations: the inverse of its residual RMS, the largest weight 1.

    ``residual`` and ``y`` are a first solution's residual and the left-hand
    side, interleaved as :func:`linear_design` builds them. A DOF whose
    residual vanishes (noise-free data) is floored at ``1e-12`` of the RMS of
    ``y``, so the weights stay finite.
    """
    rms = np.sqrt(np.mean(np.asarray(residual).reshape(-1, n_dofs) ** 2, axis=0))
    floor = 1e-12 * max(float(np.sqrt(np.mean(np.asarray(y) ** 2))), 1e-300)
    weights = 1.0 / np.maximum(rms, floor)
    return weights / weights.max()
