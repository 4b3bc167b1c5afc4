"""Sparse identification of the equation of motion with pysindy (SINDy with control).

The state is ``x = [z, v]`` and the force is the control input ``u = f``.
pysindy fits ``x' = Xi^T Theta(x, u)`` with the feature library ``Theta``
built from the user's terms (:class:`~nlid_sindy.library.TermLibrary`): the
model's columns ``g_i(z, v)`` and the force. The ``v'`` equation,

    ``a = xi_f f + sum_i xi_i g_i(z, v)``,

is Eq. 1/25 divided by the mass, so it maps back to physical coefficients as
``m = 1 / xi_f`` and ``theta_i = -m xi_i`` (every coefficient is that of its
term in ``R = f - m z''``). With the mass known, the force term is moved to the
left-hand side instead (its coefficient ``1/m`` is known, so it is fixed, not
fitted): pysindy fits ``a - f/m = sum_i xi_i g_i``, still in ``[z, v]``.
The ``z' = v`` equation is fitted too (it is part of the state-space model)
and reported as a check only.

Derivatives (default ``differentiation="nlid"``)
    pysindy is given ``x'`` estimated with nlid's shared filters
    (:func:`nlid.model.physics.regression_data`): measured channels are used as
    they are; otherwise the force, the acceleration and every library column
    are brought to the same zero-phase band and the unsettled ends are
    passed as missing (NaN rows, which pysindy drops). ``"pysindy"`` uses
    pysindy's ``SmoothedFiniteDifference`` on the unfiltered state instead
    (the velocity state is still measured or nlid-estimated: pysindy cannot
    produce a state). See ``docs/sindy.md`` for the comparison.

Sparsity threshold
    ``threshold`` is relative: a term is kept only if its RMS contribution to
    the ``v'`` equation is at least that fraction of the RMS of the left-hand
    side. By default it is chosen by K-fold cross-validation on contiguous
    segments with the one-standard-error rule (:mod:`nlid_sindy.threshold`).

Non-smooth friction
    ``sign(v)`` is discontinuous where the velocity changes sign: there, noise
    on an estimated velocity flips the column between -1 and +1, which is an
    error in a regressor (not in the equation) and biases the Coulomb
    coefficient towards zero, and on records dominated by one speed it is
    nearly collinear with ``v`` and ``v*|v|``. The plugin mitigates this by (1)
    evaluating every column on the velocity of the wide band and then
    low-passing it with the force (so the regressors are smooth and in phase
    with the force), (2) warning about near-collinear pairs by name, and (3)
    accepting the smooth ``tanh(v/c)`` of the term language when a Coulomb
    law should be regularised.
"""

from __future__ import annotations

import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from nlid.plugin import (
    CHANNEL_SOURCES,
    EDGE_PERIODS,
    ChannelSource,
    ElementSet,
    Estimate,
    IdentificationError,
    Identifier,
    Model,
    NlidError,
    Option,
    Record,
    StructureEstimate,
    collinearity_warnings,
    column_scale,
    derivatives,
    least_squares,
    nonsmooth_warnings,
    regression_data,
    source_entries,
)

if TYPE_CHECKING:
    import pysindy as ps

    from .library import TermLibrary

# pysindy (and scikit-learn, which it imports) is imported where it is used, never at import: loading the
# entry points (the registry, ``nlid methods``) must not pay its ~1-5 s.

__all__ = ["SparseIdentification", "SindyProblem", "build_problem"]


#: Names pysindy gives the inputs: the state [z, v], then the force.
FEATURE_NAMES = ("z", "v", "f")


@dataclass
class SindyProblem:
    """What pysindy is given, in the form :meth:`pysindy.SINDy.fit` takes it.

    Attributes
    ----------
    x
        State ``[z, v]``, shape ``(N, 2)`` (every sample of the record).
    x_dot
        Its derivative ``[v, a]`` (``[v, a - f/m]`` with the mass known),
        each column scaled to unit RMS over the rows used.
    u
        Control input ``f``, shape ``(N, 1)``; ``None`` with the mass known.
    force
        The force as filtered for the balance, shape ``(N,)``.
    scale
        RMS of the two columns of ``x_dot`` before scaling.
    library
        The :class:`TermLibrary` (with a cut-off it leaves the unsettled rows
        at each end NaN, and pysindy drops them).
    rows
        Indices of the rows pysindy uses.
    dt
        Sampling interval (s).
    filtered_at
        Equation band (Hz) or ``None``.
    provenance
        Where each channel came from.
    sources
        The same as plain data (:class:`nlid.plugin.ChannelSource`).
    """

    x: np.ndarray
    x_dot: np.ndarray
    u: np.ndarray | None
    force: np.ndarray
    scale: np.ndarray
    library: TermLibrary
    rows: np.ndarray
    dt: float
    filtered_at: float | None
    provenance: dict[str, str]
    sources: dict[str, ChannelSource] = field(default_factory=dict)

    @property
    def library_input(self) -> np.ndarray:
        """The columns pysindy passes to the library: ``[z, v]`` then ``f`` if it is an input."""
        return self.x if self.u is None else np.column_stack([self.x, self.u])

    @property
    def correlation_length(self) -> float:
        """Rows over which the filtered equation error stays correlated (``fs / fc``; 1 if unfiltered)."""
        return 1.0 if self.filtered_at is None else 1.0 / (self.dt * self.filtered_at)

    def library_matrix(self) -> np.ndarray:
        """The library evaluated on the rows used (what pysindy's optimizer sees, unscaled)."""
        theta = self.library.fit_transform(self.library_input)
        return np.asarray(theta)[self.rows]


def build_problem(
    record: Record,
    model: Model,
    mass: float | None,
    *,
    cutoff: float | None = None,
    differentiation: str = "nlid",
) -> SindyProblem:
    """Prepare the arrays and the library pysindy is fitted on.

    Parameters
    ----------
    record, model, mass
        The data, the library's terms and the known mass (or ``None``).
    cutoff
        Equation band of nlid's filters (Hz); default from the noise floor.
    differentiation
        ``"nlid"`` (shared filters, :func:`nlid.model.physics.regression_data`) or
        ``"pysindy"`` (``pysindy.SmoothedFiniteDifference``).
    """
    import pysindy as ps

    from .library import TermLibrary

    fs = record.fs
    if differentiation == "nlid":
        # the force balance without the model's columns (the library evaluates those): the state
        # always needs a velocity, so ask for the velocity term only
        data = regression_data(
            record, Model.from_spec("v", defaults=False), cutoff=cutoff, trim=False, regressors=False
        )
        z, v, a, f = data.z, data.v, data.a, data.f
        fc = data.filtered_at
        library = TermLibrary(model, fs=fs, cutoff=fc)
        rows = np.arange(record.n)[data.kept]
        sources = dict(data.sources)
    else:
        z, f = record.z, record.f
        sources = {c: record.channel_source(c) for c in record.channels}
        if record.is_measured("v"):
            v = record.v
        else:
            v, used = derivatives.differentiate(record.z, fs, order=1, cutoff=cutoff)
            sources["v"] = ChannelSource.differentiated(used, "z")
        a = np.asarray(ps.SmoothedFiniteDifference(axis=0)(np.column_stack([z, v]), t=1.0 / fs))[:, 1]
        sources["a"] = ChannelSource(
            False,
            "estimated from v by pysindy.SmoothedFiniteDifference (Savitzky-Golay smoothing, differences)",
            "v",
            "differentiated",
            "pysindy.SmoothedFiniteDifference (Savitzky-Golay smoothing, differences)",
        )
        fc, library, rows = None, TermLibrary(model), np.arange(record.n)
    lhs = a if mass is None else a - f / mass
    x_dot = np.column_stack([v, lhs])
    scale = np.sqrt(np.mean(x_dot[rows] ** 2, axis=0))
    if not np.all(scale > 0):
        raise IdentificationError("sindy: the velocity or the acceleration is identically zero on this record")
    return SindyProblem(
        x=np.column_stack([z, v]),
        x_dot=x_dot / scale,
        u=f.reshape(-1, 1) if mass is None else None,
        force=f,
        scale=scale,
        library=library,
        rows=rows,
        dt=1.0 / fs,
        filtered_at=fc,
        provenance={c: source.text for c, source in sources.items()},
        sources=sources,
    )


@contextmanager
def _pysindy_errors() -> Iterator[None]:
    """Report any failure inside pysindy as an IdentificationError naming the plugin."""
    try:
        yield
    except NlidError:
        raise
    except Exception as exc:  # noqa: BLE001 - whatever pysindy raises is reported as the plugin's
        import pysindy as ps

        raise IdentificationError(f"sindy: pysindy {ps.__version__} failed: {type(exc).__name__}: {exc}") from exc


def fit_sindy(problem: SindyProblem, threshold: float) -> tuple[ps.SINDy, list[str]]:
    """Fit pysindy's SINDy (STLSQ, relative ``threshold``) on a problem; return it and its warnings."""
    import pysindy as ps

    from .threshold import stlsq

    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        fitted = ps.SINDy(optimizer=stlsq(threshold, problem.rows.size), feature_library=problem.library)
        names = list(FEATURE_NAMES[: 2 if problem.u is None else 3])
        fitted.fit(problem.x, t=problem.dt, x_dot=problem.x_dot, u=problem.u, feature_names=names)
    return fitted, list(dict.fromkeys(f"pysindy: {w.message}" for w in seen))


def _equation(lhs: str, coefficients: np.ndarray, names: list[str]) -> str:
    terms = [f"{c:+.6g} {n}" for c, n in zip(coefficients, names, strict=True) if c != 0]
    return f"{lhs} = " + (" ".join(terms) if terms else "0")


class SparseIdentification(Identifier):
    """SINDy with control (pysindy) on the equation of motion, in nlid's terms."""

    name = "sindy"
    summary = "sparse identification (pysindy STLSQ) of v' = (f - R(z, v)) / m with state [z, v] and input f"
    options = (
        Option(
            "threshold",
            "float",
            None,
            "relative sparsity threshold: drop terms contributing less than this fraction of the RMS of v' "
            "(auto: K-fold cross-validation on contiguous segments, one-standard-error rule)",
            nullable=True,
            minimum=0.0,
        ),
        Option(
            "library",
            "str",
            "terms",
            "candidate library: the model's terms, or 'automatic' = the terms plus 1, z..z^degree, v, v*|v|, v^3, "
            "sign(v), z*v, z^2*v (extra terms kept are reported, not returned as coefficients)",
            choices=("terms", "automatic"),
        ),
        Option("degree", "int", 5, "highest stiffness power of the automatic library", minimum=1, maximum=9),
        Option("folds", "int", 5, "contiguous folds of the threshold cross-validation", minimum=2, maximum=50),
        Option(
            "cutoff",
            "float",
            None,
            "low-pass cut-off (Hz) of nlid's differentiating filter for estimated channels",
            nullable=True,
            minimum=0.0,
        ),
        Option(
            "differentiation",
            "str",
            "nlid",
            "derivatives given to pysindy: nlid's shared zero-phase filters, or pysindy's SmoothedFiniteDifference",
            choices=("nlid", "pysindy"),
        ),
    )
    needs_mass = False
    dofs = "multi"
    preference = 30
    advice = (
        "unsure which terms belong in the model: sparse selection from the model's terms plus a "
        "polynomial/friction library (--set library=automatic) by cross-validation, reporting what it kept; "
        "fragile with sign(v) on an estimated velocity"
    )
    advice_order = 20
    docs = "docs/sindy.md"

    def identify_structure(
        self, record: Record, elements: ElementSet, *, mass: np.ndarray | None = None
    ) -> StructureEstimate:
        """Fit every DOF's sparse equation of a structure (:mod:`nlid_sindy.structure`)."""
        from .structure import identify_structure

        return identify_structure(record, elements, mass, self.settings)

    def identify(self, record: Record, model: Model, *, mass: float | None = None) -> Estimate:
        """Fit the sparse model and map its ``v'`` equation to the coefficients of ``R``."""
        from .library import auto_candidates
        from .threshold import choose_threshold

        s = self.settings
        library_model = model
        if s["library"] == "automatic":
            library_model = model.with_terms(add=[t for t in auto_candidates(s["degree"]) if t not in model])
        problem = build_problem(record, library_model, mass, cutoff=s["cutoff"], differentiation=s["differentiation"])
        columns = [*library_model.names, *(["f"] if mass is None else [])]
        choice = None
        with _pysindy_errors():
            if s["threshold"] is None:
                theta = problem.library_matrix()
                column_scale(theta, columns, "sindy: ")
                # held-out folds lose the rows a filter's response spans at each end (as the record's ends do)
                gap = int(np.ceil(EDGE_PERIODS * problem.correlation_length)) if problem.filtered_at else 0
                protected = (len(columns) - 1,) if mass is None else ()
                choice = choose_threshold(
                    theta, problem.x_dot[problem.rows, 1], columns, folds=s["folds"], gap=gap, protected=protected
                )
                threshold = choice.threshold
            else:
                threshold = s["threshold"]
            fitted, caught = fit_sindy(problem, threshold)
            theta = np.asarray(fitted.optimizer.Theta_)
        if theta.shape != (problem.rows.size, len(columns)):
            raise IdentificationError(
                f"sindy: pysindy fitted a {theta.shape} library matrix, expected {(problem.rows.size, len(columns))}"
            )
        column_scale(theta, columns, "sindy: ")
        return self._result(model, library_model, mass, problem, fitted, theta, threshold, choice, caught)

    def _result(self, model, library_model, mass, problem, fitted, theta, threshold, choice, caught):
        import pysindy as ps

        coef = np.asarray(fitted.coefficients(), dtype=float) * problem.scale[:, None]
        xi = coef[1]
        p = len(library_model)
        if mass is None:
            if not xi[p] > 0:
                raise IdentificationError(
                    f"sindy: the coefficient 1/m of the force in the v' equation is {xi[p]:.4g}, so no positive mass "
                    "can be estimated; give the mass or lower the threshold"
                )
            m = 1.0 / xi[p]
        else:
            m = float(mass)
            if not np.any(xi[:p]):
                raise IdentificationError(
                    f"sindy: the threshold {threshold:g} dropped every term of the v' equation; lower 'threshold'"
                )
        all_coeffs = library_model.as_dict(-m * xi[:p])
        coefficients = {n: all_coeffs[n] for n in model.names}
        extra = {n: c for n, c in all_coeffs.items() if n not in model and c != 0}
        support = [j for j in range(p) if xi[j] != 0]
        kept_cols = [*support, *([p] if mass is None else [])]
        columns = [*library_model.names, *(["f"] if mass is None else [])]
        # pysindy's unbiasing step solved least squares on the kept columns: reuse its coefficients
        fit = least_squares(
            theta[:, kept_cols],
            problem.x_dot[problem.rows, 1] * problem.scale[1],
            [columns[j] for j in kept_cols],
            correlation_length=problem.correlation_length,
            context="sindy: ",
            coefficients=xi[kept_cols],
        )
        se, mass_se = _standard_errors(fit, library_model, support, mass, m)
        notes = list(caught)
        if extra:
            notes.append(
                "the automatic library kept terms that are not in the model: "
                + ", ".join(f"{n} = {c:.4g}" for n, c in extra.items())
                + " (coefficients in R; see diagnostics['extra_terms']); consider adding them"
            )
        notes += collinearity_warnings(theta[:, kept_cols], [columns[j] for j in kept_cols])
        sign_fraction = None
        if support:
            kept_model = Model(tuple(library_model.terms[j] for j in support), library_model.px_roots)
            sign_fraction, nonsmooth = nonsmooth_warnings(
                kept_model, problem.x[problem.rows, 1], 1.0 / problem.dt, problem.filtered_at
            )
            notes += nonsmooth
        rule = (
            "given" if choice is None else f"{choice.folds}-fold contiguous cross-validation, one-standard-error rule"
        )
        feature_names = [*library_model.names, *(["f"] if mass is None else [])]
        return Estimate(
            coefficients=coefficients,
            mass=None if mass is not None else float(m),
            standard_errors={n: se[n] for n in model.names if se.get(n) is not None},
            mass_standard_error=mass_se,
            warnings=notes,
            diagnostics={
                "threshold": float(threshold),
                "threshold_rule": rule,
                "threshold_table": None if choice is None else choice.table,
                "library": list(library_model.names),
                "kept_terms": [library_model.names[j] for j in support],
                "dropped_terms": [n for n in model.names if coefficients[n] == 0.0],
                "extra_terms": extra,
                "equation": _equation("v'" if mass is None else f"v' - f/{m:.6g}", xi, feature_names),
                "kinematic_check": _equation("z'", coef[0], feature_names),
                "condition_number": fit.condition_number,
                "force_residual_percent_of_sparse_equation": float(
                    100 * m * np.sqrt(np.mean(fit.residual**2)) / np.sqrt(np.mean(problem.force[problem.rows] ** 2))
                ),
                "samples_used": int(theta.shape[0]),
                "filtered_at_hz": problem.filtered_at,
                "channels": problem.provenance,
                CHANNEL_SOURCES: source_entries(problem.sources),
                "differentiation": self.settings["differentiation"],
                "mass_standard_error": mass_se,
                "velocity_sign_disagreement": sign_fraction,
                "pysindy_version": ps.__version__,
            },
        )


def _standard_errors(fit, library_model: Model, support: list[int], mass: float | None, m: float):
    """Standard errors of the kept coefficients of R (and of the mass).

    Least squares on the kept columns is pysindy's own unbiasing step, so its
    batch-means covariance (:func:`nlid.estimation.regression.least_squares`) is that of
    ``xi``; ``theta_i = -m xi_i`` with the mass known, and with the mass
    estimated ``theta_i = -xi_i / xi_f``, ``m = 1 / xi_f`` (delta method).
    """
    cov, xi = fit.covariance, fit.coefficients
    out: dict[str, float] = {}
    if mass is not None:
        for i, j in enumerate(support):
            out[library_model.names[j]] = float(m * np.sqrt(cov[i, i]))
        return out, None
    k = len(support)
    xf = xi[k]
    for i, j in enumerate(support):
        grad = np.zeros(k + 1)
        grad[i], grad[k] = -1.0 / xf, xi[i] / xf**2
        out[library_model.names[j]] = float(np.sqrt(grad @ cov @ grad))
    return out, float(np.sqrt(cov[k, k]) / xf**2)
