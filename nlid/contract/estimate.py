"""What an identifier returns (:class:`Estimate`) and the core's one check of it (:func:`check_estimate`).

An identifier's ``identify()`` returns an :class:`Estimate`: its own estimates,
nothing the core computes. Before anything uses it, :func:`check_estimate`
checks it against the contract and normalises it (the coefficients in model
order, as floats; entries that do not serialise to JSON by
:func:`to_jsonable` dropped with a warning saying so); a refined model is
paired with the given one by :func:`refined_terms`. The rest of the contract
(:class:`~nlid.contract.identifier.Identifier`, :class:`~nlid.contract.identifier.Option`) is in
:mod:`nlid.contract.identifier`, which re-exports these names.
"""

from __future__ import annotations

import math
import numbers
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, TypeVar

import numpy as np

from ..base.jsonable import to_jsonable
from ..errors import (
    PASS_THROUGH,
    IdentificationError,
    InputError,
    NlidError,
    PluginError,
    brief,
    describe_exception,
    listing,
    one_line,
)
from ..model.terms import Model

__all__ = [
    "Estimate",
    "check_estimate",
    "checked_parts",
    "read_guarded",
    "timed_call",
    "refined_terms",
    "MAX_WARNING",
]

T = TypeVar("T")


@dataclass(frozen=True)
class Estimate:
    """What an identifier returns: its own estimates, nothing the core computes.

    The core (:func:`nlid.identify`) checks it and builds the
    :class:`~nlid.identified.model.IdentifiedModel` from it: equilibria, modal
    parameters (unless the method measured them), the residuals (always from
    the data), the wall time and the options are the core's job, done the
    same way for every method. Nothing mutates an estimate after the plugin
    returned it.

    Attributes
    ----------
    coefficients
        ``{canonical term: coefficient}`` for every term of the model (in
        any order: the core puts them in model order); each a real number,
        the coefficient of its term in ``R(z, v) = f - m z''`` (SI units).
        The core checks every field before using it (:func:`check_estimate`).
    mass
        The mass in kg when the method estimated it; ``None`` when the mass
        was given (``identify(..., mass=m)``).
    standard_errors
        Standard error of each coefficient, when the method provides them.
    mass_standard_error
        Standard error of an estimated mass.
    modal
        Modal parameters the method measured itself (e.g. from the
        eigenvalues of an identified linear system), as
        :class:`~nlid.model.physics.Modal` or dictionaries with ``equilibrium``,
        ``fn_hz``, ``zeta`` (and optionally ``stiffness``, ``damping``,
        ``source`` and further figures); ``None`` lets the core compute them
        from the identified ``K`` and ``D`` (Eq. 8, 22).
    diagnostics
        Method-specific, JSON-serialisable details (an entry that does not
        serialise is dropped, with a warning saying so).
    warnings
        Things the user should know (collinear terms, extrapolation...).
    arrays
        Large numeric outputs for plots, kept out of JSON and saved as
        ``.npz``. Keys that reports understand: ``singular_values``
        (subspace methods), ``frf_frequency_hz`` and ``frf`` (complex
        underlying-linear receptance, m/N), ``coef_frequency_hz`` and
        ``coef_spectrum:<term>`` (complex frequency-dependent coefficient
        estimates, NSI Eq. 20); an identifier that keeps such arrays under
        other keys declares them with :meth:`nlid.contract.identifier.Identifier.figure_arrays`.
    model
        The model with the shape parameters the method refined (the same
        terms, in the same number, each differing from the given model's at
        most in its shape parameters, :attr:`nlid.model.terms.Term.shapes`; the
        ``px(z)`` roots unchanged), when it fitted them; the coefficients
        and standard errors are then keyed by its canonical names. ``None``:
        the model given.
    """

    coefficients: Mapping[str, float]
    mass: float | None = None
    standard_errors: Mapping[str, float] | None = None
    mass_standard_error: float | None = None
    modal: Sequence[Any] | None = None
    diagnostics: Mapping[str, Any] = field(default_factory=dict)
    warnings: Sequence[str] = ()
    arrays: Mapping[str, np.ndarray] = field(default_factory=dict, repr=False)
    model: Model | None = None


def refined_terms(given: Model, refined: Model) -> dict[str, str]:
    """Pair each term of ``given`` with the term of ``refined`` it became by changing its shape parameters.

    Returns
    -------
    dict
        ``{given canonical name: refined canonical name}`` for every term (equal names when unchanged).

    Raises
    ------
    ValueError
        If ``refined`` is not ``given`` with (at most) other shape parameters: a term added, removed or
        changed otherwise, or other ``px(z)`` roots.
    """
    if len(refined.terms) != len(given.terms) or refined.px_roots != given.px_roots:
        raise ValueError(f"the refined model ({refined}) does not have the terms of the model ({given})")
    pairs: dict[str, str] = {}
    left = list(refined.terms)
    for term in given.terms:
        match = next((t for t in left if t == term), None)
        if match is None:
            match = next(
                (t for t in left if len(t.shapes) == len(term.shapes) and t.shapes and term.with_shapes(t.shapes) == t),
                None,
            )
        if match is None:
            raise ValueError(
                f"term {term.name!r} has no counterpart in the refined model ({refined}) that differs "
                "only in its shape parameters"
            )
        left.remove(match)
        pairs[term.name] = match.name
    return pairs


# --------------------------------------------------------------------------- the check of what a plugin returns
#: Longest warning the core keeps from a plugin (characters): a runaway message is cut (:func:`nlid.errors.one_line`).
MAX_WARNING = 2000


def _kind(value: Any) -> str:
    """What a value is, in a few words, for a message: ``"a string 'abc'"``, ``"an array of shape (3,)"``."""
    if isinstance(value, (bool, np.bool_)):
        return f"a bool ({value})"
    if isinstance(value, (str, bytes)):
        return f"a {'string' if isinstance(value, str) else 'bytes value'} {brief(value, 40)}"
    if isinstance(value, np.ndarray):
        return f"an array of shape {value.shape}"
    if isinstance(value, complex | np.complexfloating):
        return f"a complex number {brief(value, 40)}"
    if isinstance(value, (list, tuple, dict, set)):
        return f"a {type(value).__name__} {brief(value, 40)}"
    if value is None:
        return "None"
    if isinstance(value, numbers.Number):
        return f"a number ({brief(value, 40)})"
    return f"an object of type {type(value).__name__}"


def _real(value: Any) -> float | None:
    """``value`` as a float if it is a real number (not a bool, an array, a string...), else ``None``.

    A number too large for a float (``10**400``) comes back as ``inf``.
    """
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        return None
    try:
        return float(value)
    except OverflowError:
        return math.inf if value > 0 else -math.inf
    except Exception:  # noqa: BLE001 - a hostile number type whose __float__ raises is not a number
        return None


def _jsonable(value: Any) -> str | None:
    """``None`` when ``value`` serialises to JSON (after :func:`to_jsonable`), else why not."""
    import json

    try:
        json.dumps(to_jsonable(value), allow_nan=False)
    except RecursionError:
        return "nested too deeply (or refers to itself)"
    except Exception as exc:  # noqa: BLE001 - TypeError, ValueError, or a hostile __str__/__iter__
        return f"{type(exc).__name__}: {brief(str(exc), 60)}" if str(exc) else type(exc).__name__
    return None


def _standard_error(value: Any, what: str, who: str) -> float | None:
    """A plugin's standard error as a float (``None`` when not given); a NaN or negative one is kept.

    Such a figure is refused with every other one that cannot be trusted, by
    :meth:`nlid.identified.model.IdentifiedModel.problems`.
    """
    if value is None:
        return None
    se = _real(value)
    if se is None:
        raise PluginError(f"{who} returned {_kind(value)} as the standard error of {what}, not a number")
    return se


def checked_parts(
    estimate: Any, names: Sequence[str], who: str
) -> tuple[dict[str, float], dict[str, float] | None, list[str], dict[str, Any], dict[str, np.ndarray]]:
    """The parts every estimate shares, checked one way for one DOF and for a structure.

    The coefficients (one real, finite number per name: a term of the model, or an element of a
    structure), the standard errors, the warnings, the diagnostics and the arrays; the same hostile
    return gets the same one-line message whichever kind of estimate carries it.

    Parameters
    ----------
    estimate
        An :class:`Estimate` or a :class:`~nlid.contract.structure_estimate.StructureEstimate`.
    names
        The canonical names the coefficients must be keyed by, in model order.
    who
        ``"identifier 'name'"``, the start of every message.

    Returns
    -------
    tuple
        ``(coefficients, standard_errors, notes, diagnostics, arrays)``: floats in model order, the
        standard errors given (or ``None``), the warnings cut to :data:`MAX_WARNING` characters plus a
        note for every dropped diagnostic or array, the diagnostics that serialise to JSON, the arrays of
        numbers under string keys.

    Raises
    ------
    PluginError
        Coefficients that are not a mapping of exactly ``names`` to real numbers; standard errors
        for other names or not numbers; warnings that are not a list of strings.
    IdentificationError
        A coefficient that is not finite.
    """
    names = list(names)
    given = estimate.coefficients
    if not isinstance(given, Mapping):
        raise PluginError(f"{who} returned coefficients as {_kind(given)}, not a mapping {{term: value}}")
    by_name = {str(k): v for k, v in given.items()}
    if sorted(by_name) != sorted(names) or len(given) != len(names):
        raise PluginError(
            f"{who} returned coefficients for {listing(sorted(by_name), quote=True)} but the model is {names}"
        )
    coefficients: dict[str, float] = {}
    for term in names:
        value = _real(by_name[term])
        if value is None:
            raise PluginError(f"{who} returned {_kind(by_name[term])} as the coefficient of {term}, not a real number")
        coefficients[term] = value
    bad = [n for n, x in coefficients.items() if not math.isfinite(x)]
    if bad:
        shown = ", ".join(f"{n} ({coefficients[n]})" for n in bad)
        raise IdentificationError(f"{who} produced non-finite coefficients for {shown}")

    errors: dict[str, float] | None = None
    if estimate.standard_errors is not None:
        if not isinstance(estimate.standard_errors, Mapping):
            raise PluginError(f"{who} returned standard errors as {_kind(estimate.standard_errors)}, not a mapping")
        unknown = [k for k in estimate.standard_errors if k not in names]
        if unknown:
            raise PluginError(
                f"{who} returned standard errors for terms not in the model: {listing(unknown, quote=True)}"
            )
        raw = {n: estimate.standard_errors[n] for n in names if n in estimate.standard_errors}
        errors = {n: se for n, v in raw.items() if (se := _standard_error(v, n, who)) is not None}

    warnings = estimate.warnings
    if isinstance(warnings, (str, bytes)) or not isinstance(warnings, (list, tuple)):
        raise PluginError(f"{who} returned warnings as {_kind(warnings)}, not a list of strings")
    odd = next((w for w in warnings if not isinstance(w, str)), None)
    if odd is not None:
        raise PluginError(f"{who} returned {_kind(odd)} among its warnings, not a string")
    notes = [one_line(w, MAX_WARNING) for w in warnings]

    diagnostics: dict[str, Any] = {}
    if isinstance(estimate.diagnostics, Mapping):
        dropped = []
        for key, value in estimate.diagnostics.items():
            why = _jsonable({key: value})
            if why is None:
                diagnostics[str(key)] = value
            else:
                dropped.append(f"{brief(str(key), 40)} ({why})")
        if dropped:
            notes.append(f"diagnostics dropped (they do not serialise to JSON): {listing(dropped, width=120)}")
    elif estimate.diagnostics is not None:
        notes.append(f"diagnostics dropped: {_kind(estimate.diagnostics)}, not a mapping")

    arrays: dict[str, np.ndarray] = {}
    if isinstance(estimate.arrays, Mapping):
        dropped = []
        for key, value in estimate.arrays.items():
            try:
                array = np.asarray(value)
                ok = isinstance(key, str) and array.dtype.kind in "biufc"
            except Exception:  # noqa: BLE001 - an object numpy cannot read is dropped like the others
                ok = False
            if ok:
                arrays[key] = array
            else:
                dropped.append(brief(key, 40))
        if dropped:
            notes.append(f"arrays dropped (not arrays of numbers under a string key): {listing(dropped)}")
    elif estimate.arrays is not None:
        notes.append(f"arrays dropped: {_kind(estimate.arrays)}, not a mapping")
    return coefficients, errors, notes, diagnostics, arrays


def check_estimate(estimate: Any, model: Model, name: str, mass: float | None = None) -> Estimate:
    """Check what an identifier returned, before anything uses it; the estimate as the core uses it.

    The one check of the contract, used by :func:`nlid.identify` (and studies, discovery and
    posteriors through it) and by the compliance checks of :mod:`nlid.testing`:

    * an :class:`Estimate`, whose :attr:`~Estimate.model`, when set, is ``model`` with refined shape
      parameters (:func:`refined_terms`);
    * one coefficient per term of the model, each a real number (not a bool, an array, a string...),
      finite. Their order is free: the result is in model order;
    * the mass: ``None`` or the given mass when ``mass`` is given, otherwise ``None`` (not estimated)
      or a finite positive number (kg);
    * standard errors: ``None`` or, per term of the model, ``None`` or a number; the same for the mass's
      standard error (one that is not finite, or negative, is refused with every other figure that
      is not, by :meth:`nlid.identified.model.IdentifiedModel.problems`);
    * ``modal``: ``None`` or modal parameters (:class:`~nlid.model.physics.Modal` or mappings);
    * ``warnings``: a list or tuple of strings (each cut to :data:`MAX_WARNING` characters, one line);
    * ``diagnostics`` and ``arrays``: an entry that does not serialise to JSON, or an array that does not
      hold numbers, is dropped, and a warning in the result says which and why.

    Parameters
    ----------
    estimate
        What ``identify()`` returned.
    model
        The model the identifier was given.
    name
        The identifier's name (messages say ``identifier 'rfs' ...``).
    mass
        The mass given to the identifier (kg), ``None`` when it was asked to estimate it.

    Returns
    -------
    Estimate
        The same content, normalised: coefficients, standard errors and masses as floats (in model
        order), diagnostics and arrays without the dropped entries, warnings with the notes of what was
        dropped.

    Raises
    ------
    PluginError
        A broken contract: not an Estimate, other terms, a coefficient or mass that is not a number,
        malformed standard errors, modal parameters or warnings. One line naming the identifier and the
        term.
    IdentificationError
        The numbers are of the right kind but cannot be trusted: a coefficient or mass that is not
        finite, a mass that is not positive.
    """
    return read_guarded(name, _check_estimate, estimate, model, name, mass)


def read_guarded(name: str, check: Callable[..., T], *args: Any) -> T:
    """``check(*args)``, where anything but an :class:`~nlid.errors.NlidError` is the plugin's broken estimate.

    A mapping or number type of the plugin's that breaks when read (a hostile ``__iter__`` or ``__float__``)
    becomes one :class:`~nlid.errors.PluginError` naming the identifier, for one DOF and structures alike.
    """
    try:
        return check(*args)
    except NlidError:
        raise
    except Exception as exc:  # noqa: BLE001 - a value that breaks when read is a broken plugin too
        raise PluginError(
            f"identifier {brief(name, 60)} returned an estimate that cannot be read: {describe_exception(exc)}"
        ) from None


def timed_call(name: str, call: Callable[..., T], *args: Any, **kwargs: Any) -> tuple[T, float]:
    """``call(*args, **kwargs)`` (an identifier's method) and its wall time in s, one DOF and structures alike.

    An :class:`~nlid.errors.NlidError` (and ``KeyboardInterrupt``...) passes; anything else the plugin raises,
    ``SystemExit`` too, becomes one :class:`~nlid.errors.PluginError` naming identifier ``name``.
    """
    start = time.perf_counter()
    try:
        answer = call(*args, **kwargs)
    except (NlidError, *PASS_THROUGH):
        raise
    except BaseException as exc:  # noqa: BLE001 - a plugin bug (sys.exit too) is reported by name
        raise PluginError(f"identifier {name!r} {describe_exception(exc)}") from exc
    return answer, time.perf_counter() - start


def _check_estimate(estimate: Any, model: Model, name: str, mass: float | None) -> Estimate:
    who = f"identifier {brief(name, 60)}"
    if not isinstance(estimate, Estimate):
        raise PluginError(
            f"{who} returned {type(estimate).__name__}, not nlid.Estimate (identify() must return nlid.plugin.Estimate)"
        )
    if estimate.model is not None:
        if not isinstance(estimate.model, Model):
            raise PluginError(f"{who} returned a refined model (Estimate.model) that is not an nlid Model")
        try:
            refined_terms(model, estimate.model)
        except ValueError as exc:
            raise PluginError(f"{who}: {exc}") from None
        model = estimate.model
    names = list(model.names)
    coefficients, errors, notes, diagnostics, arrays = checked_parts(estimate, names, who)

    est_mass = estimate.mass
    if est_mass is not None:
        value = _real(est_mass)
        if value is None:
            raise PluginError(f"{who} returned {_kind(est_mass)} as the mass, not a number of kg")
        if mass is not None and not math.isclose(value, mass, rel_tol=1e-12):
            raise PluginError(
                f"{who} returned a mass of {value:g} kg although the mass was given ({mass:g} kg): "
                "Estimate.mass is for an estimated mass only"
            )
        if not (math.isfinite(value) and value > 0):
            raise IdentificationError(f"{who} estimated a mass that is not positive ({value} kg)")
        est_mass = None if mass is not None else value

    mass_se = _standard_error(estimate.mass_standard_error, "the mass", who) if est_mass is not None else None

    modal = estimate.modal
    if modal is not None:
        from ..model.physics import Modal

        if isinstance(modal, (str, bytes, Mapping)) or not isinstance(modal, Sequence):
            raise PluginError(f"{who} returned modal parameters as {_kind(modal)}, not a list")
        checked = []
        for entry in modal:
            try:
                if not isinstance(entry, (Modal, Mapping)):
                    raise InputError(f"expected a mapping, got {_kind(entry)}")
                item = Modal.from_dict(entry)
                why = _jsonable(item.to_dict())
                if why:
                    raise InputError(f"they do not serialise to JSON ({why})")
            except InputError as exc:
                raise PluginError(f"{who} returned malformed modal parameters: {brief(str(exc), 200)[1:-1]}") from None
            checked.append(item)
        modal = tuple(checked)

    return Estimate(
        coefficients=coefficients,
        mass=est_mass,
        standard_errors=errors,
        mass_standard_error=mass_se,
        modal=modal,
        diagnostics=diagnostics,
        warnings=tuple(notes),
        arrays=arrays,
        model=estimate.model,
    )
