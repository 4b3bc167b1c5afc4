"""What an identifier of several degrees of freedom returns: :class:`StructureEstimate`, and its check.

An identifier that declares ``dofs = "multi"`` (:class:`nlid.plugin.Identifier`)
receives an indexed :class:`~nlid.data.record.Record`, the
:class:`~nlid.model.elements.ElementSet` to identify and the mass matrix (or ``None``:
estimate it), and returns a :class:`StructureEstimate`: the coefficient of
every element and the underlying linear system it estimated. The core
(:func:`nlid.identify`) checks it (:func:`check_structure_estimate`) and
completes it into an :class:`~nlid.identified.structure.IdentifiedStructure` with what it
computes the same way for every method: equilibria, linearised modes, the
residual per DOF, the wall time.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import IdentificationError, InputError, PluginError, brief
from ..model.elements import ElementSet
from ..model.modes import StructureModes
from .estimate import checked_parts, read_guarded

__all__ = ["StructureEstimate", "check_structure_estimate"]


@dataclass(frozen=True)
class StructureEstimate:
    """An identifier's estimates for a structure: nothing the core computes.

    Attributes
    ----------
    coefficients
        ``{canonical element name: coefficient}`` for every element of the
        :class:`~nlid.model.elements.ElementSet` it was given (SI units, each the
        coefficient of its element's term in ``R = f - M z''``).
    K, C
        Stiffness (N/m) and damping (N s/m) matrices of the underlying linear system, ``(n, n)``.
    static
        Constant force per DOF (N), when the element set asks for it (:attr:`ElementSet.static`).
    M
        The mass matrix (kg) when the method estimated it; ``None`` when it was given.
    standard_errors
        Standard error of each element's coefficient, when the method gives them.
    modes
        Linearised modes the method measured itself at the stable equilibria
        (:class:`~nlid.model.modes.StructureModes` or their dictionaries); ``None``:
        the core computes them from the estimate.
    linear_modes
        The underlying linear system's modes as the method measured them (e.g.
        from the eigenvalues of an identified state-space model); ``None``:
        computed from ``M``, ``C``, ``K``.
    diagnostics
        Method-specific, JSON-serialisable details.
    warnings
        Things the user should know.
    arrays
        Large numeric outputs (FRF matrices, coefficient spectra...), kept out of JSON.
    elements
        The element set with shape parameters the method refined, when it
        fitted them (the same elements otherwise); ``None``: the set given.
    """

    coefficients: Mapping[str, float]
    K: Any
    C: Any
    static: Any = None
    M: Any = None
    standard_errors: Mapping[str, float] | None = None
    modes: Sequence[Any] | None = None
    linear_modes: Any = None
    diagnostics: Mapping[str, Any] = field(default_factory=dict)
    warnings: Sequence[str] = ()
    arrays: Mapping[str, np.ndarray] = field(default_factory=dict, repr=False)
    elements: ElementSet | None = None


def _matrix(value: Any, n: int, what: str, who: str) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=float) if value is not None else None
    except (TypeError, ValueError):
        arr = None
    if arr is None or arr.shape != (n, n):
        raise PluginError(f"{who} returned {what} of shape {np.shape(value)}, not ({n}, {n})")
    if not np.all(np.isfinite(arr)):
        raise IdentificationError(f"{who} produced a {what} that is not finite")
    return arr


def check_structure_estimate(
    estimate: Any, elements: ElementSet, name: str, mass: np.ndarray | None
) -> StructureEstimate:
    """Check an identifier's return value against the contract; the estimate as the core uses it.

    The coefficients, standard errors, warnings, diagnostics and arrays are checked by the one check
    every estimate shares (:func:`nlid.contract.estimate.checked_parts`): a hostile return gets the
    same one-line message as on one DOF, an unserialisable diagnostic or a runaway warning is dropped
    or cut the same way. Then what only a structure has: the matrices, the static forces, the modes.

    Returns
    -------
    StructureEstimate
        The same content, normalised: coefficients and standard errors as floats in element order,
        diagnostics and arrays without the dropped entries, warnings with the notes of what was
        dropped, and :attr:`~StructureEstimate.elements` the element set the coefficients belong to.

    Raises
    ------
    PluginError
        Not a :class:`StructureEstimate`, coefficients that are not exactly the elements or not
        numbers, matrices of the wrong shape, malformed standard errors, warnings or modes.
    IdentificationError
        Values that are not finite; an estimated mass matrix that is not symmetric positive definite.
    """
    return read_guarded(name, _check_structure_estimate, estimate, elements, name, mass)


def _check_structure_estimate(
    estimate: Any, elements: ElementSet, name: str, mass: np.ndarray | None
) -> StructureEstimate:
    who = f"identifier {brief(name, 60)}"
    if not isinstance(estimate, StructureEstimate):
        raise PluginError(
            f"{who} returned {type(estimate).__name__} for a structure, not nlid.plugin.StructureEstimate"
        )
    used = elements
    if estimate.elements is not None:
        refined = estimate.elements
        same = (
            isinstance(refined, ElementSet)
            and refined.n_dofs == elements.n_dofs
            and len(refined) == len(elements)
            and all(
                r.connection == e.connection
                and (r.term == e.term or (r.term.shapes and e.term.with_shapes(r.term.shapes) == r.term))
                for r, e in zip(refined, elements, strict=True)
            )
        )
        if not same:
            raise PluginError(f"{who} returned elements ({refined}) that are not those given ({elements})")
        used = refined
    coefficients, errors, notes, diagnostics, arrays = checked_parts(estimate, list(used.names), who)
    n = elements.n_dofs
    K = _matrix(estimate.K, n, "K", who)
    C = _matrix(estimate.C, n, "C", who)
    static = None
    if estimate.static is not None:
        try:
            static = np.asarray(estimate.static, dtype=float)
        except (TypeError, ValueError):
            static = np.empty(0)
        if static.shape != (n,):
            raise PluginError(f"{who} returned static forces of shape {np.shape(estimate.static)}, not ({n},)")
        if not np.all(np.isfinite(static)):
            raise IdentificationError(f"{who} produced static forces that are not finite")
    M = None
    if mass is None and estimate.M is not None:
        M = _matrix(estimate.M, n, "mass matrix", who)
        try:
            np.linalg.cholesky(0.5 * (M + M.T))
        except np.linalg.LinAlgError:
            raise IdentificationError(f"{who} estimated a mass matrix that is not positive definite") from None
    for entry in [*(estimate.modes or ()), *([] if estimate.linear_modes is None else [estimate.linear_modes])]:
        try:
            StructureModes.from_dict(entry)
        except InputError as exc:
            raise PluginError(f"{who} returned malformed modes: {brief(str(exc), 200)[1:-1]}") from None
    return dataclasses.replace(
        estimate,
        coefficients=coefficients,
        K=K,
        C=C,
        static=static,
        M=M,
        standard_errors=errors,
        diagnostics=diagnostics,
        warnings=tuple(notes),
        arrays=arrays,
        elements=used,
    )
