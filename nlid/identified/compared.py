"""What a comparison of a fit with a reference gives, as typed values (:class:`nlid.identified.reference.Comparison`).

The core returns these; a study flattens them into its row's columns (:mod:`nlid.study.row`), so that no
core package knows a study column.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

from ..model.physics import Modal

__all__ = ["CoefficientComparison", "WellComparison", "EquilibriumComparison", "equilibrium_label"]

NAN = float("nan")


@dataclass(frozen=True)
class CoefficientComparison:
    """The identified coefficients and mass against the reference's (:meth:`Comparison.coefficients`).

    Attributes
    ----------
    coefficients
        ``{term: value}`` of the fit, in its term order.
    errors
        ``{term: signed error %}`` (``100 (x - x_ref) / |x_ref|``), only for terms with a non-zero reference.
    mass
        The fit's mass (NaN when it has none).
    mass_error
        The signed error % of an estimated mass against a known one; ``None`` otherwise (a given mass).
    """

    coefficients: Mapping[str, float]
    errors: Mapping[str, float]
    mass: float
    mass_error: float | None = None


@dataclass(frozen=True)
class WellComparison:
    """One stable equilibrium of the reference against the fit (:attr:`EquilibriumComparison.wells`).

    Attributes
    ----------
    found
        The identified stable equilibrium matched to it (nearest first, each used once); ``None``: missing.
    error
        ``100 |z - z_ref| / |z_ref|`` (NaN when missing or for a zero reference).
    mode
        The identified mode matched to it on its own, by position (module documentation); ``None``: none.
    fn_error, zeta_error
        Signed errors % of that mode against the reference's modes; ``None`` when either is unknown.
    """

    found: float | None = None
    error: float = NAN
    mode: Modal | None = None
    fn_error: float | None = None
    zeta_error: float | None = None


@dataclass(frozen=True)
class EquilibriumComparison:
    """The identified stable equilibria and modes against the reference's (:meth:`Comparison.equilibria`).

    Attributes
    ----------
    found
        How many stable equilibria the fit has.
    wells
        One :class:`WellComparison` per reference stable equilibrium, in the reference's order (empty when the
        reference gives none: then only :attr:`modes` is reported).
    modes
        The fit's modes, in its order (what is reported without reference equilibria).
    """

    found: int
    wells: tuple[WellComparison, ...] = ()
    modes: tuple[Modal, ...] = ()

    @property
    def missing(self) -> int:
        """Reference equilibria with no identified one matched to them."""
        return sum(w.found is None for w in self.wells)

    @property
    def error_max(self) -> float:
        """The largest equilibrium error % (NaN when a well is missing, or without reference equilibria)."""
        errors = [w.error for w in self.wells]
        return max(errors) if errors and not any(math.isnan(e) for e in errors) else NAN


def equilibrium_label(index: int) -> str:
    """The label of the ``index``-th (from 0) reference stable equilibrium: ``s1``, ``s2``..."""
    return f"s{index + 1}"
