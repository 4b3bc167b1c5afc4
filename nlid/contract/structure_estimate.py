"""What an identifier of several degrees of freedom returns: :class:`StructureEstimate`, and its check.

An identifier that declares ``dofs = "multi"`` (:class:`nlid.plugin.Identifier`)
receives a :class:`~nlid.data.structure_record.StructureRecord`, the
:class:`~nlid.model.elements.ElementSet` to identify and the mass matrix (or ``None``:
estimate it), and returns a :class:`StructureEstimate`: the coefficient of
every element and the underlying linear system it estimated. The core
(:func:`nlid.identify`) checks it (:func:`check_structure_estimate`) and
completes it into an :class:`~nlid.identified.structure.IdentifiedStructure` with what it
computes the same way for every method: equilibria, linearised modes, the
residual per DOF, the wall time.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import IdentificationError, InputError, PluginError
from ..model.elements import ElementSet
from ..model.modes import StructureModes

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


def _matrix(value: Any, n: int, what: str, name: str) -> np.ndarray:
    arr = np.asarray(value, dtype=float) if value is not None else None
    if arr is None or arr.shape != (n, n):
        raise PluginError(f"identifier {name!r} returned {what} of shape {np.shape(value)}, not ({n}, {n})")
    if not np.all(np.isfinite(arr)):
        raise IdentificationError(f"identifier {name!r} produced a {what} that is not finite")
    return arr


def check_structure_estimate(estimate: Any, elements: ElementSet, name: str, mass: np.ndarray | None) -> ElementSet:
    """Check an identifier's return value against the contract; the element set its coefficients belong to.

    Raises
    ------
    PluginError
        Not a :class:`StructureEstimate`, coefficients that are not exactly
        the elements, matrices of the wrong shape, malformed modes.
    IdentificationError
        Values that are not finite; an estimated mass matrix that is not
        symmetric positive definite.
    """
    if not isinstance(estimate, StructureEstimate):
        raise PluginError(
            f"identifier {name!r} returned {type(estimate).__name__} for a structure, not nlid.plugin.StructureEstimate"
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
            raise PluginError(
                f"identifier {name!r} returned elements ({refined}) that are not those given ({elements})"
            )
        used = refined
    keys = list(estimate.coefficients)
    if sorted(keys) != sorted(used.names):
        raise PluginError(
            f"identifier {name!r} returned coefficients for {sorted(keys)} but the elements are {list(used.names)}"
        )
    bad = [k for k in used.names if not np.isfinite(float(estimate.coefficients[k]))]
    if bad:
        raise IdentificationError(f"identifier {name!r} produced non-finite coefficients for {', '.join(bad)}")
    n = elements.n_dofs
    _matrix(estimate.K, n, "K", name)
    _matrix(estimate.C, n, "C", name)
    if estimate.static is not None:
        static = np.asarray(estimate.static, dtype=float)
        if static.shape != (n,):
            raise PluginError(f"identifier {name!r} returned static forces of shape {static.shape}, not ({n},)")
        if not np.all(np.isfinite(static)):
            raise IdentificationError(f"identifier {name!r} produced static forces that are not finite")
    if mass is None and estimate.M is not None:
        M = _matrix(estimate.M, n, "mass matrix", name)
        try:
            np.linalg.cholesky(0.5 * (M + M.T))
        except np.linalg.LinAlgError:
            raise IdentificationError(
                f"identifier {name!r} estimated a mass matrix that is not positive definite"
            ) from None
    unknown = [k for k in (estimate.standard_errors or {}) if k not in used.names]
    if unknown:
        raise PluginError(f"identifier {name!r} returned standard errors for elements not in the model: {unknown}")
    for entry in [*(estimate.modes or ()), *([] if estimate.linear_modes is None else [estimate.linear_modes])]:
        try:
            StructureModes.from_dict(entry)
        except InputError as exc:
            raise PluginError(f"identifier {name!r} returned malformed modes: {exc}") from None
    return used
