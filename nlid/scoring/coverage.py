"""Where a record leaves the range a model was fitted on: the extrapolation a score silently includes.

A restoring force fitted on one record is known only over the displacements that record visited. A
test record that goes further asks every polynomial term to extrapolate, and its free-run error then
measures the extrapolation as much as the model (Silverbox's arrow head is the classic case: its
"full" test reaches 20 % of the estimation range beyond it, over 0.14 % of its samples).
:func:`range_excess` measures how far, so that a leaderboard, a validation report or a notebook can say
so next to the figure instead of leaving the reader to guess.

The same measure serves every caller (``nlid bench``'s test sets, ``nlid discover``'s validation
records), so one record gets one sentence.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import InputError

__all__ = ["RANGE_TOLERANCE", "RangeExcess", "beyond_range", "range_excess", "value_range"]

#: A record counts as leaving the fitted range when it reaches further beyond it than this fraction of the
#: range's width. Measured against nlid's estimation parts: a held-out period of Bouc-Wen's multisine
#: reaches 0.1 % beyond, EMPS's last quarter 0.0 %, and the two Silverbox tests its authors publish as
#: within the estimation amplitude (the multisine, the arrow head "without extrapolation") 3.5 and 4.3 %,
#: each over fewer than 0.04 % of their samples; the arrow head in full reaches 20 % beyond.
RANGE_TOLERANCE = 0.05


@dataclass(frozen=True)
class RangeExcess:
    """How far a record's displacement leaves the range a model was fitted on.

    Attributes
    ----------
    beyond
        The furthest excursion beyond the fitted range, as a fraction of the range's width (0 inside it).
    outside
        The share of the record's samples outside the fitted range (0 to 1); ``None`` when only the record's
        ``(min, max)`` is known (:meth:`from_ranges`).
    fitted, reached
        The fitted range and the record's own ``(min, max)``, in the unit of the displacement (for a
        structure: of the DOF that goes furthest).
    dof
        That DOF's index (0 for one DOF).
    """

    beyond: float
    outside: float | None
    fitted: tuple[float, float]
    reached: tuple[float, float]
    dof: int = 0

    @classmethod
    def from_ranges(cls, fitted: Sequence[float], reached: Sequence[float]) -> RangeExcess:
        """The excess of a record of which only its ``(min, max)``, ``reached``, is known (no share outside)."""
        lo, hi = float(min(fitted)), float(max(fitted))
        return cls(beyond_range((lo, hi), reached), None, (lo, hi), (float(min(reached)), float(max(reached))))

    @property
    def extrapolates(self) -> bool:
        """Whether the record goes further beyond the fitted range than :data:`RANGE_TOLERANCE` of its width."""
        return self.beyond > RANGE_TOLERANCE

    def describe(self, what: str = "the record", range_name: str = "the estimation range") -> str:
        """One sentence, empty when the record stays within :data:`RANGE_TOLERANCE` of the range."""
        if not self.extrapolates:
            return ""
        share = "" if self.outside is None else f" ({100 * self.outside:.3g} % of its samples lie outside)"
        reach = f"{what} reaches {100 * self.beyond:.3g} % of {range_name} beyond it"
        return f"{reach}{share}: the models extrapolate there"


def beyond_range(fitted: Sequence[float], reached: Sequence[float]) -> float:
    """The furthest excursion of ``reached = (min, max)`` beyond ``fitted = (min, max)``, per width of ``fitted``.

    0 when ``reached`` lies within ``fitted``; ``inf`` when ``fitted`` has no width but is left.
    """
    lo, hi = float(min(fitted)), float(max(fitted))
    out = max(lo - float(min(reached)), float(max(reached)) - hi, 0.0)
    span = hi - lo
    if out == 0.0:
        return 0.0
    return out / span if span > 0 else float("inf")


def value_range(z: np.ndarray) -> np.ndarray:
    """``(min, max)`` of a displacement: shape ``(2,)`` for one DOF, ``(n_dofs, 2)`` for a structure's ``z``."""
    z = np.asarray(z, dtype=float)
    return np.stack([z.min(axis=0), z.max(axis=0)], axis=-1)


def range_excess(fitted: Sequence[float] | np.ndarray, z: np.ndarray) -> RangeExcess:
    """How far the displacement ``z`` leaves the range ``fitted`` (see the module docstring).

    Parameters
    ----------
    fitted
        ``(min, max)`` of the displacement the model was fitted on, or, for a structure, one such pair per
        DOF (shape ``(n_dofs, 2)``).
    z
        The record's displacement: shape ``(n,)``, or ``(n, n_dofs)`` for a structure.

    Returns
    -------
    RangeExcess
        For a structure, that of the DOF that goes furthest beyond its range.
    """
    ranges = np.atleast_2d(np.asarray(fitted, dtype=float))
    z = np.asarray(z, dtype=float)
    columns = z.reshape(-1, 1) if z.ndim == 1 else z
    if z.ndim not in (1, 2) or ranges.shape != (columns.shape[1], 2) or columns.shape[0] == 0:
        raise InputError(
            f"range_excess needs one (min, max) pair per DOF of z, got ranges of shape {ranges.shape} "
            f"for z of shape {z.shape}"
        )
    if not (np.isfinite(ranges).all() and np.isfinite(columns).all()):
        raise InputError("range_excess needs finite ranges and displacements")
    found = []
    for dof in range(columns.shape[1]):
        col, (lo, hi) = columns[:, dof], sorted(ranges[dof])
        reached = (float(col.min()), float(col.max()))
        share = float(np.mean((col < lo) | (col > hi)))
        found.append(RangeExcess(beyond_range((lo, hi), reached), share, (lo, hi), reached, dof))
    return max(found, key=lambda r: (r.beyond, r.outside))
