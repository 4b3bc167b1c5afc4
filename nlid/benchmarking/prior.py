"""What each leaderboard row knew before it saw the data: its prior knowledge, derived from what it was given.

A row's error means little without what the model was told. ``rfs`` on Bouc-Wen is given the
benchmark's true hysteresis shape ``bouc_wen(800, -1100)`` and the true mass and fits 3
coefficients; PNLSS is told nothing and fits 217. :class:`Prior` says so in three short fields,
each derived from the pipeline's inputs (the benchmark file's ``[pipelines]`` settings and
what the pipeline kind does with them), never typed by hand:

``mass``
    ``"given"`` (the benchmark file gives it: ``mass = 2.0``), ``"estimated"`` (fitted from the
    estimation part) or ``"none"`` (the model has no mass: a black box or a state-space library).
``structure``
    ``"declared"`` (the terms were given; only coefficients were fitted), ``"discovered"``
    (started from the declared terms, effects chosen from the estimation part), ``"library"``
    (a generic library, sparsified from data: pysindy, polynomial NARX), ``"black box"``
    (a generic model class: linear state space, neural networks), ``"true model"`` (the system's
    own equations and parameters, where the benchmark's truth is known).
``shape``
    ``"given"`` (nonlinear shape parameters were fixed in the terms given, e.g. the numbers of
    ``bouc_wen(800, -1100)`` or ``tanh(v/0.01)``), ``"fitted"`` (chosen from the data) or ``"none"``.

:meth:`Prior.badges` is the compact form a table shows (one badge per piece of knowledge the row
was given); :data:`LEGEND` explains the badges once per table.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

__all__ = ["Prior", "LEGEND", "MASS", "STRUCTURES", "SHAPES", "given_shapes", "prior_from_row"]

#: Values of :attr:`Prior.mass`.
MASS = ("given", "estimated", "none")
#: Values of :attr:`Prior.structure`.
STRUCTURES = ("true model", "declared", "discovered", "library", "black box")
#: Values of :attr:`Prior.shape`.
SHAPES = ("given", "fitted", "none")

#: The badges a table shows and what each means (said once per table).
LEGEND = {
    "true model": "the system's own equations and parameters (known for a simulated benchmark)",
    "mass given": "the mass was given, not estimated",
    "terms given": "the model's terms were declared; only their coefficients were fitted",
    "shape given": "nonlinear shape parameters were given in the terms (not fitted)",
    "discovered": "started from the declared terms; the added effects were chosen on the estimation part",
    "library": "a generic library of candidate terms, sparsified on the estimation part",
    "black box": "a generic model class: no physics, no terms given",
}


@dataclass(frozen=True)
class Prior:
    """A row's prior knowledge (see the module docstring).

    Attributes
    ----------
    mass
        One of :data:`MASS`.
    structure
        One of :data:`STRUCTURES`.
    shape
        One of :data:`SHAPES`.
    detail
        What exactly was given, in words (the terms, the shape, the library).
    """

    mass: str = "none"
    structure: str = "black box"
    shape: str = "none"
    detail: str = ""

    def __post_init__(self) -> None:
        for name, value, allowed in (
            ("mass", self.mass, MASS),
            ("structure", self.structure, STRUCTURES),
            ("shape", self.shape, SHAPES),
        ):
            if value not in allowed:
                raise ValueError(f"Prior.{name} must be one of {', '.join(allowed)}, got {value!r}")

    def badges(self) -> list[str]:
        """The knowledge given, as badges (keys of :data:`LEGEND`), the most telling first."""
        if self.structure == "true model":
            return ["true model"]
        out = []
        if self.mass == "given":
            out.append("mass given")
        if self.structure == "declared":
            out.append("terms given")
        elif self.structure in ("discovered", "library", "black box"):
            out.append(self.structure)
        if self.shape == "given":
            out.append("shape given")
        return out

    def text(self) -> str:
        """The badges joined (``"mass given · terms given · shape given"``)."""
        return " · ".join(self.badges())

    def to_row(self) -> dict[str, str]:
        """The leaderboard's prior-knowledge columns."""
        return {
            "prior_mass": self.mass,
            "prior_structure": self.structure,
            "prior_shape": self.shape,
            "prior": self.text(),
            "prior_detail": self.detail,
        }


def given_shapes(terms: str | Iterable[Any]) -> list[str]:
    """Names of the terms (a comma-separated spelling, or terms) that carry shape parameters."""
    from ..model.terms import Model

    model = Model.from_spec(terms if isinstance(terms, str) else list(terms), defaults=False)
    return [t.name for t in model.terms if t.shapes]


def prior_from_row(row: Mapping[str, Any]) -> Prior:
    """The :class:`Prior` of a leaderboard row (its ``prior_*`` columns; a black box when they are missing)."""
    mass = str(row.get("prior_mass") or "none")
    structure = str(row.get("prior_structure") or "black box")
    shape = str(row.get("prior_shape") or "none")
    return Prior(
        mass if mass in MASS else "none",
        structure if structure in STRUCTURES else "black box",
        shape if shape in SHAPES else "none",
        str(row.get("prior_detail") or ""),
    )
