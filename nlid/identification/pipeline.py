"""Running an identifier the same way for every method.

:func:`identify` resolves the identifier, validates its options, runs it
(timing it and isolating its failures), iterates on the ``px(z)`` roots when
the model needs them from the identified stiffness, and completes the result
with what the core computes identically for every method: equilibria, modal
parameters (unless the method measured them), the residual epsilon of Eq. 26
(always from the data) and the wall time.

The ``px(z)`` fixed point (paper Sec. 4: "the coefficients alpha, beta,
gamma, delta are completely defined provided that the roots z+- of p_zeta are
known"): start from the roots of the stiffness identified without the
``px`` terms, then repeat identify -> roots of the identified ``p_zeta`` ->
rebuild ``px`` until the roots move by less than ``px_tol`` (relative). The
iteration stops with an :class:`~nlid.errors.IdentificationError` when it
returns to the roots of two steps before (oscillating), when the change has
not shrunk over four iterations (not contracting: diverging), or after
``px_max_iter`` iterations.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np

from ..base import numerics
from ..base.validate import ESTIMATE, check_cutoff, check_mass
from ..contract.estimate import Estimate, check_estimate, refined_terms, timed_call
from ..contract.methods import choose_method
from ..contract.registry import Registry, make_identifier
from ..contract.structure_estimate import check_structure_estimate
from ..data.record import Record
from ..data.sources import as_record
from ..errors import IdentificationError, InputError, NlidError, describe_exception
from ..estimation.inputpath import InputPath
from ..estimation.inputpath import input_path as to_input_path
from ..identified.model import IdentifiedModel
from ..identified.structure import IdentifiedStructure
from ..model import physics
from ..model.elements import ElementSet
from ..model.structure import structure_mass
from ..model.terms import Model, Term
from ..signal.glitches import glitch_warnings
from .provenance import identify_provenance, structure_provenance
from .structure_fit import as_elements, check_dofs

__all__ = [
    "identify",
    "as_model",
]


def _estimated_model(estimate: Estimate, model: Model) -> Model:
    """The model the estimate's coefficients belong to: ``model``, or its shape-refined version."""
    return model if estimate.model is None else estimate.model


def as_model(
    terms: str | Iterable[str | Term] | Model,
    *,
    without: str | Iterable[str] | None = (),
    px_roots: Sequence[float] | None = None,
) -> Model:
    """A :class:`Model` from a term list (defaults added) or a model.

    Raises
    ------
    InputError
        ``terms`` missing (``None``) or of another type; :class:`~nlid.errors.TermError` for a bad term.
    """
    if terms is None:
        raise InputError("terms are missing: give the model's terms, e.g. 'z^3, v*|v|' ('' for just 1, z, v)")
    without = () if without is None else without  # None: nothing removed
    if isinstance(terms, Model):
        model = terms.with_terms(remove=without) if without else terms
        return model if px_roots is None else model.with_px_roots(px_roots)
    if not isinstance(terms, (str, Iterable)):
        raise InputError(
            f"terms must be a string such as 'z^3, v*|v|', a list of terms or a Model, got {type(terms).__name__}"
        )
    return Model.from_spec(terms, without=without, px_roots=px_roots)


def _name(identifier: Any) -> str:
    return str(getattr(identifier, "name", type(identifier).__name__))


def _run(identifier: Any, record: Record, model: Model, mass: float | None) -> tuple[Estimate, float]:
    """Call the plugin, time it, and check what it returned (:func:`~nlid.contract.estimate.check_estimate`).

    The estimate returned is the checked one (numbers as floats, unusable diagnostics dropped with a
    warning); nothing modifies it afterwards.

    When the estimate carries a model with refined shape parameters (:attr:`Estimate.model`), it is
    checked against ``model`` and the coefficients against its names; use :func:`_estimated_model`.
    """
    name = _name(identifier)
    estimate, elapsed = timed_call(name, identifier.identify, record, model, mass=mass)
    return check_estimate(estimate, model, name, mass), elapsed


def _px_fixed_point(
    identifier: Any,
    record: Record,
    model: Model,
    mass: float | None,
    tol: float,
    max_iter: int,
) -> tuple[Estimate, Model, float, dict[str, Any]]:
    z_range = (float(record.z.min()), float(record.z.max()))
    base = model.with_terms(remove=[t for t in model.terms if t.uses_px])
    first, total = _run(identifier, record, base, mass)
    try:
        roots = physics.stiffness_roots(base, dict(first.coefficients), z_range)
    except InputError as exc:
        raise IdentificationError(f"px(z) iteration could not start: {exc}") from None
    history: list[dict[str, float]] = [{"z_minus": roots[0], "z_plus": roots[1], "change": float("nan")}]
    changes: list[float] = []
    for iteration in range(1, max_iter + 1):
        current = model.with_px_roots(roots)
        estimate, seconds = _run(identifier, record, current, mass)
        total += seconds
        current = _estimated_model(estimate, current)
        try:
            new = physics.stiffness_roots(current, dict(estimate.coefficients), z_range)
        except InputError as exc:
            raise IdentificationError(f"px(z) iteration {iteration}: {exc}") from None
        change = max(abs(new[0] - roots[0]), abs(new[1] - roots[1])) / max(abs(roots[0]), abs(roots[1]))
        changes.append(change)
        history.append({"z_minus": new[0], "z_plus": new[1], "change": change})
        if change < tol:
            info = {"converged": True, "iterations": iteration, "tolerance": tol, "history": history}
            return estimate, current.with_px_roots(new), total, {"px_iteration": info}
        if len(history) >= 3:
            two_back = history[-3]
            back = max(abs(new[0] - two_back["z_minus"]), abs(new[1] - two_back["z_plus"]))
            if back / max(abs(new[0]), abs(new[1])) < tol and change > 10 * tol:
                raise IdentificationError(
                    f"px(z) iteration is oscillating between roots {tuple(round(x, 6) for x in roots)} and "
                    f"{tuple(round(x, 6) for x in new)}; give the roots explicitly (px_roots=)"
                )
        if len(changes) >= 4 and changes[-1] >= changes[-4]:
            raise IdentificationError(
                "px(z) iteration is not contracting (diverging): the roots changed by "
                f"{', '.join(f'{c:.2e}' for c in changes[-4:])} in the last iterations; "
                "give the roots explicitly (px_roots=) or check the stiffness terms"
            )
        roots = new
    raise IdentificationError(
        f"px(z) iteration did not converge in {max_iter} iterations (last relative change {changes[-1]:.2e}, "
        f"tolerance {tol:g}); raise px_max_iter= or give the roots explicitly (px_roots=)"
    )


def identify(
    record: Record,
    terms: str | Iterable[str | Term] | Model,
    method: str | Any | None = None,
    *,
    mass: float | str | Any | None = None,
    options: Mapping[str, Any] | None = None,
    without: str | Iterable[str] | None = (),
    px_roots: Sequence[float] | None = None,
    px_tol: float = 1e-4,
    px_max_iter: int = 30,
    cutoff: float | None = None,
    registry: Registry | None = None,
    timeout: float | None = None,
    input_path: InputPath | str | Mapping[str, Any] | None = None,
) -> IdentifiedModel | IdentifiedStructure:
    """Identify the coefficients of a model from a record.

    A record of several degrees of freedom (indexed :class:`~nlid.data.record.Record`): ``terms`` are
    then elements on connections (``"(z1-z2)^3, z3^3"``, or an :class:`~nlid.model.elements.ElementSet`;
    :func:`nlid.identification.structure_fit.as_elements`), ``mass`` the mass matrix, and the method must
    declare ``dofs = "multi"`` (it is given the record, the elements and the mass matrix, and returns a
    :class:`~nlid.contract.structure_estimate.StructureEstimate`); the result is an
    :class:`~nlid.identified.structure.IdentifiedStructure`, with the residual per DOF.

    Parameters
    ----------
    record
        The data: a :class:`Record`, or what :func:`nlid.load` reads without
        a column map (a pandas DataFrame or xarray Dataset with columns named
        ``t, f, z, v, a``, a mapping of arrays, a file path); see
        :func:`nlid.data.sources.as_record`.
    terms
        The user's terms (``"z^3, z^2, v*|v|"``); ``1``, ``z`` and ``v`` are
        added unless listed in ``without``. A :class:`Model` is used as is.
    method
        Identifier name (entry-point name) or an identifier instance;
        default: the installed identifier with the best ``preference``
        (:func:`nlid.contract.methods.choose_method`: ``"rfs"`` with nlid's own
        plugins).
    mass
        Known mass in kg; ``None`` (or ``"estimate"``) asks the method to estimate it. For a structure,
        the mass matrix (kg; array-like, a vector is lumped, or text such as ``"diag(1,1,2)"``:
        :func:`nlid.base.validate.parse_mass`); ``None`` takes the record's (``meta['mass']``, a file's
        ``.meta.json`` sidecar), as ``discover`` does, and ``"estimate"`` asks the method to estimate it.
    options
        Identifier options (validated against its declaration).
    without
        Default terms to remove (``None``: none); of a structure, ``"1"`` leaves out the constant force per DOF.
    px_roots
        ``(z-, z+)`` for ``px(z)``; default: iterate on the identified
        stiffness (see module docstring). Of a structure, ``{(i, j): (z-, z+)}`` for elements using ``px``.
    px_tol, px_max_iter
        Convergence tolerance (relative change of the roots) and iteration cap.
    cutoff
        Differentiating-filter cut-off (Hz) used by the core for epsilon (of a structure, for the residual per DOF).
    registry
        Where to find ``method``; default: the installed plugins.
    timeout
        Run the identifier in a child process (:func:`nlid.runtime.isolation.run_in_child`,
        as studies and ``nlid identify`` do) and stop it after this many
        seconds (``math.inf``: in a child, without a time limit): a hanging
        or crashing identifier becomes one error instead of a hang or a dead
        process, what it prints goes to stderr, its warnings come back as
        :class:`~nlid.runtime.outcome.PluginWarning` naming it, and nothing
        it started outlives it. ``None`` (default) runs it in this process:
        fastest, and a debugger can step into it. The identifier (a name, or
        an instance of a class defined in a module) and the record are sent
        to the child pickled.
    input_path
        What happens to the force before it acts (:class:`~nlid.estimation.inputpath.InputPath`, or its spelling
        ``"delay=3ms, lag=1ms"``): the identifier is given the record with the acting force, and the model
        keeps the path (:attr:`IdentifiedModel.input_path`), so every score on another record applies it too.
        Default: the force acts as recorded.

    Returns
    -------
    IdentifiedModel or IdentifiedStructure
        The model with its coefficients, mass, equilibria, modal parameters
        and scores on ``record``.

    Raises
    ------
    InputError
        A record of a type nlid cannot read; missing or bad terms, options
        or mass; unknown method.
    PluginError
        The identifier is broken (raised an unexpected exception).
    IdentificationError
        The identification ran but its answer cannot be trusted, or did not
        finish within ``timeout``.
    IsolationError
        With ``timeout``: no child process could be started
        (:class:`nlid.runtime.outcome.IsolationError`).
    """
    record = as_record(record)
    if isinstance(mass, str) and mass.strip().lower() == ESTIMATE and not record.indexed:
        mass = None  # one DOF: None already asks the method to estimate it
    without = () if without is None else without  # None: nothing removed
    path = to_input_path(input_path, getattr(record, "fs", None))
    if method is None:
        method = choose_method(None if isinstance(mass, str) and mass == ESTIMATE else mass, registry)[0]
    if timeout is not None:
        return _identify_isolated(
            timeout,
            record,
            terms,
            method,
            dict(
                mass=mass,
                options=options,
                without=without,
                px_roots=px_roots,
                px_tol=px_tol,
                px_max_iter=px_max_iter,
                cutoff=cutoff,
                registry=registry,
                input_path=path,
            ),
        )
    if record.indexed and not path.identity:
        raise InputError("input_path= is for a record of one degree of freedom")
    model = None if record.indexed else as_model(terms, without=without, px_roots=px_roots)
    identifier = make_identifier(method, options, registry)
    if record.indexed:  # several degrees of freedom: elements on connections, a mass matrix
        check_dofs(identifier, record)
        elements = as_elements(terms, record.n_dofs, without=without, px_roots=px_roots)
        mass = structure_mass(mass, record)
    else:
        mass = check_mass(mass)
    check_cutoff(cutoff, getattr(record, "fs", None))  # before a long identification, not after it
    if mass is None and getattr(identifier, "needs_mass", False):
        if record.indexed:
            raise InputError(
                f"method {_name(identifier)!r} cannot estimate the mass matrix: give mass= (kg; a vector for a "
                "lumped mass) or the record's meta['mass']"
            )
        raise InputError(f"method {_name(identifier)!r} cannot estimate the mass: give mass= (in kg)")
    if record.indexed:
        return _with_data_warnings(_identify_structure(identifier, record, elements, mass, cutoff), record)
    assert model is not None
    extra: dict[str, Any] = {}
    given = model
    measured, record = record, path.apply(record)  # the identifier sees the force that acts
    with numerics.collect_warnings() as numerical:
        try:
            if model.uses_px and model.px_roots is None:
                estimate, model, seconds, extra = _px_fixed_point(identifier, record, model, mass, px_tol, px_max_iter)
            else:
                estimate, seconds = _run(identifier, record, model, mass)
                model = _estimated_model(estimate, model)
        except IdentificationError as exc:
            failed: IdentificationError | None = exc
        else:
            failed = None
    if failed is not None:
        if numerical:
            why = f" (numpy: {numerics.describe_warnings(numerical)}){numerics.overflow_hint(numerical)}"
            raise IdentificationError(f"{failed}{why}") from None
        raise failed
    if model.terms != given.terms:  # the identifier refined shape parameters: say which terms became which
        pairs = refined_terms(given.with_px_roots(model.px_roots), model)
        extra["refined_terms"] = {old: new for old, new in pairs.items() if old != new}
    settings = dict(getattr(identifier, "settings", None) or {})
    result = IdentifiedModel.from_estimate(
        estimate,
        model=model,
        record=record,
        method=_name(identifier),
        mass=mass,
        options=settings,
        seconds=seconds,
        cutoff=cutoff,
        diagnostics=extra,
        numerical=numerical,
    )
    provenance = identify_provenance(
        measured,
        given,
        method=_name(identifier),
        mass=mass,
        options=settings,
        px_tol=px_tol,
        px_max_iter=px_max_iter,
        cutoff=cutoff,
    )
    if not path.identity:
        provenance["identify"]["input_path"] = path.to_spec()
    return _with_data_warnings(dataclasses.replace(result, provenance=provenance, input_path=path), measured)


def _identify_structure(
    identifier: Any, record: Record, elements: ElementSet, mass: np.ndarray | None, cutoff: float | None
) -> IdentifiedStructure:
    """Run a ``dofs = "multi"`` identifier on an indexed record, check its estimate and complete the result."""
    name = _name(identifier)
    # an Identifier takes a structure in identify_structure; a class of its own may take it in identify
    estimate, seconds = timed_call(
        name, getattr(identifier, "identify_structure", identifier.identify), record, elements, mass=mass
    )
    estimate = check_structure_estimate(estimate, elements, name, mass)
    settings = dict(getattr(identifier, "settings", None) or {})
    result = IdentifiedStructure.from_estimate(
        estimate,
        elements=estimate.elements,
        record=record,
        method=name,
        mass=mass,
        options=settings,
        seconds=seconds,
        cutoff=cutoff,
    )
    provenance = structure_provenance(record, elements, method=name, mass=mass, options=settings)
    return dataclasses.replace(result, provenance=provenance)


def _with_data_warnings(result: Any, record: Record) -> Any:
    """``result`` with a warning for each glitch of ``record`` (:mod:`nlid.signal.glitches`)."""
    found = glitch_warnings(record)
    if not found:
        return result
    return dataclasses.replace(result, warnings=(*result.warnings, *found))


# --------------------------------------------------------------------------- isolated
#: Longest finite time limit of an isolated identification (s): a week (``math.inf``: no limit).
MAX_TIMEOUT = 7 * 24 * 3600.0


def _identify_in_child(
    record: Record, terms: Any, method: Any, kwargs: dict[str, Any], progress: bool = False
) -> tuple:
    """The child's side of :func:`_identify_isolated`: the result, or the error's class names, message and traceback.

    ``progress``: the caller's :func:`nlid.runtime.progress.active` (a long identifier then shows its progress
    line on a terminal). A ``KeyboardInterrupt`` here can only come from the plugin (the child does
    not hear the terminal's Ctrl-C), so it is the plugin's failure like any other.
    """
    import traceback

    from ..runtime.progress import showing

    try:
        with showing(progress):
            return ("ok", identify(record, terms, method, **kwargs))
    except NlidError as exc:
        return ("error", [c.__name__ for c in type(exc).__mro__], str(exc), traceback.format_exc())
    except BaseException as exc:  # noqa: BLE001 - reported in the parent as one line
        name = method if isinstance(method, str) else _name(method)
        return ("error", ["PluginError"], f"identifier {name!r} {describe_exception(exc)}", traceback.format_exc())


def check_timeout(timeout: Any) -> float:
    """A time limit in seconds: a number in (0, :data:`MAX_TIMEOUT`], or ``math.inf`` for none.

    Raises
    ------
    InputError
        Anything else (``0``, negative, NaN, a string, a bool).
    """
    bad = isinstance(timeout, bool) or not isinstance(timeout, (int, float, np.integer, np.floating))
    if not bad and float(timeout) == float("inf"):
        return float("inf")
    if bad or not numerics.is_finite(timeout) or not 0 < float(timeout) <= MAX_TIMEOUT:
        raise InputError(
            f"timeout= must be a number of seconds between 0 and {MAX_TIMEOUT:g} (math.inf: no limit), got {timeout!r}"
        )
    return float(timeout)


def _defined_in_main(method: Any) -> bool:
    return not isinstance(method, str) and getattr(type(method), "__module__", "") == "__main__"


def _identify_isolated(
    timeout: float, record: Record, terms: Any, method: Any, kwargs: dict[str, Any]
) -> IdentifiedModel:
    from ..runtime.isolation import run_in_child
    from ..runtime.outcome import IsolationError
    from ..runtime.progress import active

    timeout = check_timeout(timeout)
    name = method if isinstance(method, str) else _name(method)
    if _defined_in_main(method):
        raise InputError(
            f"identifier {name!r} is a class of your script (__main__), which a child process cannot import: "
            "give timeout=None to run it in this process, or move it to a module (or a plugin)"
        )
    label = f"identifier {name!r}"
    try:
        outcome = run_in_child(_identify_in_child, (record, terms, method, kwargs, active()), timeout=timeout)
    except IsolationError as exc:
        raise IsolationError(f"cannot isolate {label} (timeout=): {exc}") from None
    outcome.reissue_warnings(label, stacklevel=4)
    return outcome.answer(label, timeout, "raise timeout=")
