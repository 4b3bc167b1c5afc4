"""The posterior of a structure's coefficients (several DOFs): elements on connections, ``K``, ``C``.

The one-DOF posterior (:mod:`nlid.bayes.inference`) samples the coefficients
of Eq. 25's force balance. A structure's balance is the same regression per
DOF, solved jointly (:func:`nlid.estimation.structure_regression.linear_design`)::

    f_k - (M a)_k = (K z)_k + (C v)_k + s_k + sum_e B_ke theta_e g_e(x_e, x_e'),   k = 1..n,

with every element coefficient ``theta_e`` shared by the two DOFs its element
connects. The likelihood is built the same way, from the same pieces:

1. the balance samples in one equation band for every DOF
   (:func:`nlid.estimation.structure_regression.structure_regression_data`; the cut-off the
   identification's residual used, unless ``cutoff=`` is given);
2. each DOF's equations weighted by the inverse of its first-pass residual
   RMS (:func:`nlid.estimation.structure_regression.dof_weights`, as ``rfs`` does), so one
   noise scale serves every equation;
3. the sandwich covariance and effective sample size of
   :func:`nlid.bayes.likelihood.sandwich` with the DOFs of an instant kept
   together (``group = n``);
4. the Student-t likelihood of :class:`~nlid.bayes.likelihood.Likelihood`,
   its unsampled coefficients integrated out or fixed, the same priors and
   the same emcee run until converged.

Errors in variables (:func:`correct_bias`): with noise on the displacements
the regressors are not exact (and a velocity differentiated from them even
less), which biases the least-squares estimate. As for one DOF
(:mod:`nlid.bayes.bias`), the bias is found by simulation: the structure at
the current centre is run under the record's force, each DOF's displacement
gets white noise at the level of its noise floor
(:func:`nlid.signal.derivatives.noise_sd`; antithetic pairs), the same weighted least
squares is solved on every copy, and the centre is moved until the simulated
estimates average to the record's (a fixed point, ``iterations`` steps). The
Monte Carlo error of that average is added to the covariance. Noise on a
measured velocity is not simulated (the warning says so).
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import InputError
from .likelihood import Likelihood, SufficientStatistics, sandwich

if TYPE_CHECKING:  # pragma: no cover
    from ..data.record import Record
    from ..identified.structure import IdentifiedStructure

__all__ = [
    "ESTIMATED_VELOCITY",
    "StructureParameters",
    "structure_likelihood",
    "select_structure_params",
    "structure_warnings",
    "check_structure_names",
    "NO_CORRECTION",
]

#: The warning every structure posterior carries (module docstring).
NO_CORRECTION = (
    "no errors-in-variables correction (bias_correction=False): the intervals treat the displacements as exact, "
    "so with noise on them an element's interval can miss its true value (docs/posterior.md, Structures)"
)


#: With the correction: the noise of a measured velocity is not simulated.
NOISY_VELOCITY = (
    "the bias correction simulates the noise of the displacements only: noise on the measured velocities "
    "({channels}) would bias the velocity-dependent elements uncorrected"
)
#: The second warning, when a velocity is differentiated from the displacement (measured: docs/posterior.md).
ESTIMATED_VELOCITY = (
    "velocities estimated from the displacements ({channels}): with noise on z the velocity-dependent elements "
    "are biased by several standard deviations (with 2 % noise on z, 0-60 % of 90 % intervals covered the truth; "
    "docs/posterior.md, Structures)"
)


def structure_warnings(record: Record, corrected: bool) -> tuple[str, ...]:
    """What a structure posterior says about itself: :data:`NO_CORRECTION` and :data:`ESTIMATED_VELOCITY`
    without the correction, :data:`NOISY_VELOCITY` with it when a velocity is measured."""
    n = record.n_dofs
    if corrected:
        measured = [f"v{k}" for k in range(1, n + 1) if record.v is not None and record.is_measured(f"v{k}")]
        return (NOISY_VELOCITY.format(channels=", ".join(measured)),) if measured else ()
    estimated = [f"v{k}" for k in range(1, n + 1) if not record.is_measured(f"v{k}")]
    if not estimated:
        return (NO_CORRECTION,)
    return (NO_CORRECTION, ESTIMATED_VELOCITY.format(channels=", ".join(estimated)))


class StructureParameters:
    """The unknowns of a structure's balance, in the role a :class:`~nlid.model.terms.Model` has for one DOF.

    Names are the elements' canonical names, then ``K[i,j]``, ``C[i,j]`` and
    ``s[k]`` (1-based). :meth:`index` accepts any spelling of an element in
    its canonical orientation.

    Parameters
    ----------
    names
        The unknowns, in the order of the likelihood's coefficient vector.
    elements
        The structure's :class:`~nlid.model.elements.ElementSet`.
    """

    def __init__(self, names: Sequence[str], elements: Any) -> None:
        self.names = tuple(names)
        self.elements = elements
        self._position = {n: i for i, n in enumerate(self.names)}

    def __len__(self) -> int:
        return len(self.names)

    def __contains__(self, name: object) -> bool:
        try:
            self.index(str(name))
        except InputError:
            return False
        return True

    def canonical(self, name: str) -> str:
        """The canonical name of an unknown (an element in any spelling of its orientation, or ``K[1,2]``...)."""
        text = "".join(str(name).split())
        if text in self._position:
            return text
        if text[:2] in ("K[", "C[", "M[", "s["):
            raise InputError(f"{name} is not an unknown of this structure's balance ({', '.join(self.names)})")
        k, sign = self.elements.locate(name)
        canonical = self.elements.names[k]
        if sign < 0:
            raise InputError(f"{name} is {canonical} with the opposite sign: name it as {canonical}")
        return canonical

    def index(self, name: str) -> int:
        """Position of an unknown (any spelling)."""
        return self._position[self.canonical(name)]

    def vector(self, values: Mapping[str, float]) -> np.ndarray:
        """``{name: value}`` to a vector in this order (names absent from the mapping are 0)."""
        out = np.zeros(len(self.names))
        for name, value in values.items():
            out[self.index(name)] = float(value)
        return out

    def as_dict(self, values: Sequence[float] | np.ndarray) -> dict[str, float]:
        """A vector in this order to ``{name: value}``."""
        return {n: float(x) for n, x in zip(self.names, values, strict=True)}

    def unit(self, name: str) -> str:
        """SI unit of an unknown's coefficient."""
        name = self.canonical(name)
        if name.startswith("K["):
            return "N/m"
        if name.startswith("C["):
            return "N*s/m"
        if name.startswith("s["):
            return "N"
        return self.elements.elements[self.elements.index(name)].coefficient_unit

    def is_damping(self, name: str) -> bool:
        """True for a ``C`` entry or an element whose term depends on the velocity."""
        name = self.canonical(name)
        if name.startswith("C["):
            return True
        if name[:2] in ("K[", "s["):
            return False
        return self.elements.elements[self.elements.index(name)].term.family == "damping"

    def __str__(self) -> str:
        return ", ".join(self.names)


def select_structure_params(parameters: StructureParameters, params: str | Sequence[str]) -> list[int]:
    """Indices of the sampled unknowns.

    ``"elements"`` (every element coefficient), ``"damping"`` (the velocity
    dependent elements and the entries of ``C``), ``"all"``, or names (a
    comma-separated string or a list; elements in any spelling, ``K[i,j]``,
    ``C[i,j]``, ``s[k]``).
    """
    names = parameters.names
    n_elements = len(parameters.elements)
    if isinstance(params, str):
        key = params.strip().lower()
        if key == "elements":
            if not n_elements:
                raise InputError("the structure has no elements to sample; name K or C entries (params=)")
            return list(range(n_elements))
        if key in ("damping", "friction"):
            idx = [i for i, n in enumerate(names) if parameters.is_damping(n)]
            if not idx:
                raise InputError("the structure's balance has no damping (velocity-dependent) unknowns to sample")
            return idx
        if key == "all":
            return list(range(len(names)))
        params = _split_names(params)
    idx = sorted({parameters.index(p) for p in params})
    if not idx:
        raise InputError("params= names no unknown to sample")
    return idx


def check_structure_names(text: str) -> None:
    """Refuse a list of names none of which a structure could have (before the model is known).

    Each comma-separated name is a term on a connection (``(z1-z2)^3``,
    ``sign(v2-v1)``) or a linear unknown ``K[i,j]``, ``C[i,j]``, ``s[k]``.
    """
    from ..model.spelling import rewrite

    for name in _split_names(text):
        compact = "".join(name.split())
        if _LINEAR.fullmatch(compact):
            continue
        rewrite(name)


_LINEAR = re.compile(r"(K|C)\[\d+,\d+\]|s\[\d+\]")


def _split_names(text: str) -> list[str]:
    """Comma-separated names; commas inside brackets (``K[1,2]``) do not split."""
    out, depth, current = [], 0, ""
    for ch in text:
        if ch in "[(":
            depth += 1
        elif ch in "])":
            depth -= 1
        if ch == "," and depth == 0:
            out.append(current)
            current = ""
        else:
            current += ch
    out.append(current)
    return [p.strip() for p in out if p.strip()]


def _balance_design(record: Any, elements: Any, M: np.ndarray, form: str, cutoff: float | None) -> Any:
    from ..estimation.structure_regression import linear_design, structure_regression_data

    data = structure_regression_data(record, elements, cutoff=cutoff)
    return data, linear_design(data, elements, mass=M, stiffness=form)


def correct_bias(
    record: Record,
    design: Any,
    elements: Any,
    M: np.ndarray,
    form: str,
    cutoff: float | None,
    weights: np.ndarray,
    theta_hat: np.ndarray,
    *,
    pairs: int = 4,
    iterations: int = 3,
    rng: np.random.Generator | None = None,
) -> tuple[np.ndarray, np.ndarray, dict[str, Any]]:
    """The bias-corrected centre of a structure's unknowns and the Monte Carlo covariance of the correction.

    See the module docstring. Returns ``(centre, covariance, info)``; ``info`` holds the noise level
    simulated on each DOF's displacement (m), the pairs and iterations.

    Raises
    ------
    IdentificationError
        The fitted structure's free run under the record's force diverged.
    """
    from ..data.record import Record as _Record
    from ..errors import IdentificationError, NlidError
    from ..model.structure import StructuralModel
    from ..signal import derivatives
    from ..simulation.structure import free_run

    rng = rng if rng is not None else np.random.default_rng(0)
    n, fs = record.n_dofs, record.fs
    sd = np.array([derivatives.noise_sd(record.z[:, k], fs) for k in range(n)])
    measured = {g: getattr(record, g) is not None and all(record.is_measured(f"{g}{k}") for k in range(1, n + 1))
                for g in ("v", "a")}  # fmt: skip
    z0 = record.z[0]
    v0 = record.v[0] if measured["v"] else (record.z[1] - record.z[0]) * fs
    w = np.tile(weights, design.y.size // n)

    def estimate(z: np.ndarray, v: np.ndarray, a: np.ndarray) -> np.ndarray:
        copy = _Record(
            f=record.f,
            z=z,
            fs=fs,
            v=v if measured["v"] else None,
            a=a if measured["a"] else None,
            force_dofs=record.force_dofs,
            meta={"force_hold": record.force_hold},
        )
        _, d = _balance_design(copy, elements, M, form, cutoff)
        return SufficientStatistics.from_arrays(d.X * w[:, None], d.y * w).solve()

    centre = theta_hat.copy()
    draws = np.empty((pairs, theta_hat.size))
    for _ in range(iterations):
        parts = design.split(centre)
        model = StructuralModel(M, parts["C"], parts["K"], elements, parts["theta"], parts["s"])
        try:
            z, v, a = free_run(model, record.f, fs, force_hold=record.force_hold, x0=(z0, v0))
        except NlidError as exc:
            raise IdentificationError(
                f"the bias correction's free run of the fitted structure failed ({exc}); "
                "sample without it (bias_correction=False)"
            ) from None
        for p in range(pairs):
            e = rng.standard_normal(z.shape) * sd
            draws[p] = 0.5 * (estimate(z + e, v, a) + estimate(z - e, v, a))
        bias = draws.mean(axis=0) - centre
        centre = theta_hat - bias
    spread = np.cov(draws, rowvar=False) / pairs if pairs > 1 else np.zeros((centre.size, centre.size))
    info = {"noise_sd": sd.tolist(), "pairs": pairs, "iterations": iterations}
    return centre, np.atleast_2d(spread), info


def structure_likelihood(
    record: Record,
    fit: IdentifiedStructure,
    *,
    cutoff: float | None = None,
    bias_correction: bool = True,
    pairs: int = 4,
    iterations: int = 3,
    rng: np.random.Generator | None = None,
    check: Callable[[np.ndarray, StructureParameters], None] | None = None,
) -> tuple[Likelihood, StructureParameters, np.ndarray, dict[str, float]]:
    """The adjusted likelihood of a structure's unknowns (module docstring, steps 1-3).

    Parameters
    ----------
    record
        The data the identification used.
    fit
        The identified structure: its elements, mass matrix (taken as exact,
        given or estimated) and the form of ``K`` (symmetric unless the
        identification's ``K`` is not).
    cutoff
        Equation band in Hz (default: the one the identification's residual used).
    bias_correction, pairs, iterations, rng
        The errors-in-variables correction by simulation (:func:`correct_bias`) and its settings.
    check
        Called with the weighted Gram matrix and the unknowns before the (slower) correction, e.g. to refuse
        collinear sampled unknowns at once.

    Returns
    -------
    tuple
        The likelihood, its unknowns, the DOF weights, and the identification's
        estimate of every unknown (the walkers' start).
    """
    from ..estimation.structure_regression import dof_weights

    structure = fit.structure
    elements = structure.elements
    if record.n_dofs != structure.n_dofs:
        raise InputError(f"the record has {record.n_dofs} DOFs but the identified structure {structure.n_dofs}")
    if cutoff is None:
        cutoff = fit.diagnostics.get("balance_cutoff_hz")
    symmetric = np.allclose(structure.K, structure.K.T) and np.allclose(structure.C, structure.C.T)
    form = "symmetric" if symmetric else "full"
    data, design = _balance_design(record, elements, structure.M, form, cutoff)
    n = record.n_dofs
    parameters = StructureParameters(design.names, elements)
    # the unweighted first pass needs the estimate only (the sandwich's own solve, without its covariance)
    residual = design.y - design.X @ SufficientStatistics.from_arrays(design.X, design.y).solve()
    weights = dof_weights(residual, design.y, n)
    w = np.tile(weights, design.y.size // n)
    stats, theta_hat, cov, dof, info = sandwich(design.X * w[:, None], design.y * w, design.names, group=n)
    info = {
        "samples": stats.n,
        "band_hz": data.filtered_at,
        **{k: v for k, v in info.items() if k != "samples"},
        "bias_correction": bool(bias_correction),
        "dofs": n,
        "dof_weights": weights.tolist(),
        "stiffness_form": form,
    }
    start = dict(elements.as_dict(structure.theta)) if len(elements) else {}
    for key, matrix in (("K", structure.K), ("C", structure.C)):
        for name in design.names:
            if name.startswith(f"{key}["):
                i, j = (int(x) - 1 for x in name[2:-1].split(","))
                start[name] = float(matrix[i, j])
    if structure.static is not None:
        for k, value in enumerate(np.asarray(structure.static, dtype=float)):
            start[f"s[{k + 1}]"] = float(value)
    start = {name: float(start.get(name, theta_hat[i])) for i, name in enumerate(design.names)}
    if check is not None:
        check(stats.gtg, parameters)
    centre = theta_hat
    if bias_correction:
        cutoff_used = data.filtered_at if data.filtered_at is not None else cutoff
        centre, spread, corr = correct_bias(
            record, design, elements, structure.M, form, cutoff_used, weights, theta_hat,
            pairs=pairs, iterations=iterations, rng=rng,
        )  # fmt: skip
        cov = cov + spread  # the Monte Carlo error of the simulated average
        sd = np.sqrt(np.diag(cov))
        info.update(
            noise_sd=corr["noise_sd"],
            bias_pairs=corr["pairs"],
            bias_iterations=corr["iterations"],
            bias=dict(zip(design.names, (theta_hat - centre).tolist(), strict=True)),
            bias_shift_sd=dict(zip(design.names, ((centre - theta_hat) / sd).tolist(), strict=True)),
        )
    lik = Likelihood(tuple(design.names), stats, theta_hat, centre, cov, dof, info)
    return lik, parameters, weights, start
