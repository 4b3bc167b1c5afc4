"""The identified structure: :class:`IdentifiedStructure`, what :func:`nlid.identify` returns for several DOFs.

A sibling of :class:`nlid.IdentifiedModel` with the same habits (immutable,
``summary()`` -> :class:`nlid.report.summary.Summary`, ``to_dict``/``from_dict`` with
its own schema, ``to_frame``, plots with ``ax=``), not an optional part of it:
every field of an ``IdentifiedModel`` is one-DOF shaped (a scalar mass, one
coefficient per term, equilibria as numbers) and every consumer of it (scores,
studies, discovery, the posterior) relies on that; a structure has a mass
matrix, a coefficient per element on a connection, equilibria as vectors and
modes with shapes.

It binds the identified :class:`~nlid.model.structure.StructuralModel` (``M``, ``C``,
``K``, the static force, the elements and their coefficients) to what the core
computed from it the same way for every method: the equilibria in the
record's range, the linearised modes at each stable one, the underlying
linear system's modes, and the residual per DOF on the estimation record
(:mod:`nlid.estimation.structure_balance`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from ..base import numerics
from ..base.frozen import FrozenDict
from ..base.jsonable import to_jsonable
from ..contract.structure_estimate import StructureEstimate
from ..errors import IdentificationError, InputError, NlidError, brief
from ..estimation.structure_balance import StructureResidual, residual
from ..model.modes import StructureModes, linear_modes
from ..model.statics import StructureEquilibria
from ..model.structure import StructuralModel
from ..report.summary import Summary
from .fileformat import check_structure
from .plausibility import Flag, trusted
from .plausibility import check_structure as check_plausible
from .result import Identified, Recomputed
from .tables import coefficient_table

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd

    from ..data.record import Record
    from ..model.elements import ElementSet

__all__ = ["IdentifiedStructure", "SCHEMA"]

#: Identifies the JSON layout of :meth:`IdentifiedStructure.to_dict`.
SCHEMA = "nlid.IdentifiedStructure/1"
#: The warning of a structure whose stored figures did not match its coefficients (they are recomputed).
STALE_NOTE = (
    "the coefficients and matrices do not give the stored equilibria and modes (edited after the fit?): both "
    "recomputed, and the residuals of the original fit dropped (fit.residual(record) computes them)"
)


@dataclass(frozen=True, eq=False)
class IdentifiedStructure(Identified):
    """A structure with its identified coefficients and everything derived from them.

    Build it with :func:`nlid.identify` on an indexed :class:`~nlid.data.record.Record`
    (or :meth:`from_dict`).

    Attributes
    ----------
    structure
        The identified :class:`~nlid.model.structure.StructuralModel`.
    method
        The identifier's name.
    mass_estimated
        ``True`` when the method estimated the mass matrix.
    standard_errors
        Standard error of each element's coefficient, when the method gives them.
    equilibria
        Stable and unstable equilibria in (about) the estimation record's range.
    modes
        Linearised modes at each stable equilibrium (:class:`~nlid.model.modes.StructureModes`).
    linear_modes
        The modes of the underlying linear system (``M``, ``C``, ``K``).
    eps_percent, force_residual_percent
        The residual per DOF on the estimation record (:mod:`nlid.estimation.structure_balance`).
    options, diagnostics, warnings, seconds, arrays, provenance
        As for :class:`nlid.IdentifiedModel`.
    z_range
        ``(min, max)`` displacement of each DOF in the estimation record (m).
    flags
        What physics forbids that the structure shows (:func:`nlid.identified.plausibility.check_structure`):
        ``nlid identify`` exits with status 1 on one.
    """

    structure: StructuralModel
    method: str
    mass_estimated: bool = False
    standard_errors: Mapping[str, float] | None = None
    equilibria: StructureEquilibria | None = None
    modes: tuple[StructureModes, ...] = ()
    linear_modes: StructureModes | None = None
    eps_percent: tuple[float, ...] | None = None
    force_residual_percent: tuple[float, ...] | None = None
    options: Mapping[str, Any] = field(default_factory=FrozenDict)
    diagnostics: Mapping[str, Any] = field(default_factory=FrozenDict)
    warnings: tuple[str, ...] = ()
    seconds: float | None = None
    z_range: tuple[tuple[float, float], ...] | None = None
    arrays: Mapping[str, np.ndarray] = field(default_factory=FrozenDict, repr=False)
    provenance: Mapping[str, Any] = field(default_factory=FrozenDict, repr=False)
    flags: tuple[Flag, ...] = ()

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        if not isinstance(self.structure, StructuralModel):
            raise InputError(f"structure must be an nlid StructuralModel, got {type(self.structure).__name__}")
        if self.standard_errors is not None:
            se = {self.elements.names[self.elements.index(k)]: float(v) for k, v in dict(self.standard_errors).items()}
            set_(self, "standard_errors", FrozenDict(se))
        set_(self, "modes", tuple(StructureModes.from_dict(m) for m in self.modes))
        if self.linear_modes is not None:
            set_(self, "linear_modes", StructureModes.from_dict(self.linear_modes))
        for name in ("eps_percent", "force_residual_percent"):
            value = getattr(self, name)
            if value is not None:
                set_(self, name, tuple(float("nan") if x is None else float(x) for x in value))
        self._freeze_shared()
        if self.z_range is not None:
            set_(self, "z_range", tuple((float(min(r)), float(max(r))) for r in self.z_range))

    # ------------------------------------------------------------------ built by the core
    @classmethod
    def from_estimate(
        cls,
        estimate: StructureEstimate,
        *,
        elements: ElementSet,
        record: Record,
        method: str,
        mass: np.ndarray | None = None,
        options: Mapping[str, Any] | None = None,
        seconds: float | None = None,
        cutoff: float | None = None,
        diagnostics: Mapping[str, Any] | None = None,
    ) -> IdentifiedStructure:
        """Complete an identifier's :class:`~nlid.contract.structure_estimate.StructureEstimate` (what
        :func:`nlid.identify` does).

        Parameters
        ----------
        estimate
            What the identifier returned (checked already).
        elements
            The element set its coefficients belong to.
        record
            The estimation record.
        method
            The identifier's name.
        mass
            The given mass matrix (kg), ``None`` when the method estimated it.
        options, seconds, cutoff, diagnostics
            The identifier's settings, the wall time, the balance's filter cut-off (Hz), the core's diagnostics.

        Raises
        ------
        IdentificationError
            A reported figure that is not finite (:meth:`problems`).
        """
        with numerics.collect_warnings() as caught:
            warnings = list(estimate.warnings)
            M = estimate.M if mass is None else mass
            if M is None:
                raise IdentificationError(
                    f"identifier {method!r} did not estimate the mass matrix and none was given: give mass="
                )
            static = estimate.static if elements.static else None
            structure = StructuralModel(M, estimate.C, estimate.K, elements, dict(estimate.coefficients), static)
            z_range = tuple(
                (float(lo), float(hi)) for lo, hi in zip(record.z.min(axis=0), record.z.max(axis=0), strict=True)
            )
            try:
                eq: StructureEquilibria | None = structure.equilibria(z_range)
            except NlidError as exc:
                eq, _ = None, warnings.append(f"equilibria not computed: {exc}")
            if estimate.modes is not None:
                modes = tuple(StructureModes.from_dict(m) for m in estimate.modes)
            else:
                modes = () if eq is None else structure.modes(points=eq.stable)
            linear = estimate.linear_modes
            if linear is None:
                linear = linear_modes(structure.M, structure.C, structure.K, [0.0] * structure.n_dofs)
            fit = residual(structure, record, cutoff=cutoff)
            draft = cls(
                structure=structure,
                method=method,
                mass_estimated=mass is None,
                standard_errors=estimate.standard_errors,
                equilibria=eq,
                modes=modes,
                linear_modes=linear,
                eps_percent=fit.eps_percent,
                force_residual_percent=fit.force_residual_percent,
                options=options or {},
                diagnostics={
                    **dict(estimate.diagnostics),
                    **dict(diagnostics or {}),
                    "balance_cutoff_hz": fit.data.filtered_at,
                },
                warnings=tuple(warnings),
                seconds=seconds,
                z_range=z_range,
                arrays=estimate.arrays,
            )
        return trusted(draft, method, caught, check_plausible)

    def problems(self) -> list[str]:
        """The reported figures that are not finite, or contradict each other (empty when all is well).

        Checked: the standard errors (finite, not negative, as on one DOF), the modes (positive natural
        frequencies, finite damping ratios) and epsilon per DOF.
        """
        out = self._standard_error_problems()
        for m in (*self.modes, *([self.linear_modes] if self.linear_modes is not None else [])):
            if not (np.all(np.isfinite(m.fn_hz)) and np.all(m.fn_hz > 0) and np.all(np.isfinite(m.zeta))):
                out.append(
                    f"the modes at z* = {m.equilibrium} have fn = {m.fn_hz.tolist()} Hz, zeta = {m.zeta.tolist()}"
                )
        eps = [x for x in (self.eps_percent or ()) if not np.isfinite(x)]
        if eps:
            out.append("epsilon is not finite")
        return out

    # ------------------------------------------------------------------ plain views
    @property
    def elements(self) -> ElementSet:
        """The elements (with their ``px`` roots)."""
        return self.structure.elements

    @property
    def coefficients(self) -> Mapping[str, float]:
        """``{canonical element name: coefficient}``."""
        return self.structure.coefficients

    @property
    def indexed(self) -> bool:
        """``True``: a structure's result (:attr:`nlid.identified.result.Identified.indexed`)."""
        return True

    @property
    def n_dofs(self) -> int:
        """Number of DOFs."""
        return self.structure.n_dofs

    @property
    def M(self) -> np.ndarray:
        """The mass matrix (kg), given or estimated."""
        return self.structure.M

    @property
    def C(self) -> np.ndarray:
        """The underlying linear damping matrix (N s/m)."""
        return self.structure.C

    @property
    def K(self) -> np.ndarray:
        """The underlying linear stiffness matrix (N/m)."""
        return self.structure.K

    def coefficient(self, term: str) -> float:
        """The coefficient of an element written in any spelling (its sign follows the orientation written)."""
        return self.structure.coefficient(term)

    # ------------------------------------------------------------------ meeting data
    def residual(self, record: Record, *, cutoff: float | None = None) -> StructureResidual:
        """The residual ``f - M a - R(z, v)`` per DOF on a record
        (:func:`nlid.estimation.structure_balance.residual`)."""
        return residual(self.structure, record, cutoff=cutoff)

    def frf(self, frequency_hz: Sequence[float], *, at: Sequence[float] | None = None) -> np.ndarray:
        """The receptance matrix ``(F, n, n)`` of the underlying linear system, or linearised at ``at`` (m/N)."""
        return self.structure.frf(frequency_hz, at)

    def simulate(
        self,
        force: np.ndarray,
        fs: float,
        *,
        x0: Sequence[Sequence[float]] | None = None,
        force_hold: str = "sampled",
        oversample: int | None = None,
    ) -> Record:
        """Free run driven by a force ``(N, n)`` (:func:`nlid.simulation.structure.free_run`), as a record.

        Returns
        -------
        Record
            ``f``, ``z``, ``v``, ``a`` with the identified structure as ``meta["reference"]``.
        """
        from ..data.record import Record
        from ..simulation import FREE_RUN_OVERSAMPLE
        from ..simulation.structure import free_run

        q = FREE_RUN_OVERSAMPLE if oversample is None else oversample
        f = np.asarray(force, dtype=float)
        z, v, a = free_run(self.structure, f, fs, force_hold=force_hold, x0=x0, oversample=q)
        meta = {
            "mass": self.M.tolist(),
            "source": f"simulated: {self.method} structure ({', '.join(self.elements.names)})",
            "force_hold": force_hold,
            "reference": self.structure.to_dict(),
        }
        return Record(f=f.reshape(len(z), -1), z=z, v=v, a=a, fs=float(fs), meta=meta, indexed=True)

    # ------------------------------------------------------------------ plain data
    def _recomputed(self) -> Recomputed | None:
        structure = self.structure
        eq = structure.equilibria(self.z_range)
        modes = structure.modes(points=eq.stable)
        linear = linear_modes(structure.M, structure.C, structure.K, [0.0] * structure.n_dofs)
        stored_linear = [] if self.linear_modes is None or self.linear_modes.source else [self.linear_modes]
        pairs: list[tuple[Sequence[Any], Sequence[Any]]] = [
            ([m for m in self.modes if not m.source], modes),
            (stored_linear, [linear]),
        ]
        replacement: dict[str, Any] = {
            "equilibria": eq,
            "modes": modes,
            "linear_modes": linear,
            "eps_percent": None,
            "force_residual_percent": None,
        }
        return eq, pairs, replacement, STALE_NOTE

    def to_dict(self) -> dict[str, Any]:
        """JSON-serialisable dictionary (without :attr:`arrays`); :meth:`from_dict` reverses it."""
        return to_jsonable(
            {
                "schema": SCHEMA,
                "method": self.method,
                "structure": self.structure.to_dict(),
                "units": {n: e.coefficient_unit for n, e in zip(self.elements.names, self.elements, strict=True)},
                "standard_errors": None if self.standard_errors is None else dict(self.standard_errors),
                "mass_estimated": self.mass_estimated,
                "equilibria": None if self.equilibria is None else self.equilibria.to_dict(),
                "modes": [m.to_dict() for m in self.modes],
                "linear_modes": None if self.linear_modes is None else self.linear_modes.to_dict(),
                "eps_percent": None if self.eps_percent is None else list(self.eps_percent),
                "force_residual_percent": None
                if self.force_residual_percent is None
                else list(self.force_residual_percent),
                **self._shared_dict(),  # options ... provenance, as every result's layout ends
            }
        )

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> IdentifiedStructure:
        """Rebuild an identified structure from :meth:`to_dict`.

        Stored equilibria and modes that its coefficients and matrices no longer give (edited in the JSON) are
        recomputed, as :meth:`nlid.IdentifiedModel.from_dict` does (:meth:`~nlid.identified.result.Identified._fresh`).

        Raises
        ------
        InputError
            Another schema, or a missing or inconsistent structure.
        """
        if not isinstance(data, Mapping):
            raise InputError(f"expected a dictionary from IdentifiedStructure.to_dict(), got {type(data).__name__}")
        schema = data.get("schema")
        if schema != SCHEMA:
            raise InputError(f"unknown identified-structure layout {brief(schema, 60)}; this nlid reads {SCHEMA!r}")
        if not isinstance(data.get("structure"), Mapping):
            raise InputError("an identified structure needs 'structure'")
        check_structure(data)  # every field against the layout's schema (nlid.identified.fileformat)
        eq = data.get("equilibria")
        fit = cls(
            structure=StructuralModel.from_dict(data["structure"]),
            equilibria=None if eq is None else StructureEquilibria.from_dict(eq),
            modes=tuple(data.get("modes") or ()),
            linear_modes=data.get("linear_modes"),
            eps_percent=data.get("eps_percent"),
            force_residual_percent=data.get("force_residual_percent"),
            **cls._shared_fields(data),
        )
        return fit._fresh()

    def to_frame(self) -> pd.DataFrame:
        """One row per element (the index): ``connection``, ``coefficient``, ``std_error``, ``unit``, ``family``."""
        import pandas as pd

        se = self.standard_errors or {}
        rows = [
            {
                "element": e.name,
                "connection": f"{e.i}-{e.j}" if e.j else f"{e.i}-ground",
                "coefficient": self.coefficients[e.name],
                "std_error": se.get(e.name, float("nan")),
                "unit": e.coefficient_unit,
                "family": e.family,
            }
            for e in self.elements
        ]
        columns = ["element", "connection", "coefficient", "std_error", "unit", "family"]
        return pd.DataFrame(rows, columns=columns).set_index("element")

    # ------------------------------------------------------------------ text and HTML
    def summary(self) -> Summary:
        """The elements, the underlying linear system's modes, equilibria, modes per well and residuals."""
        out = Summary()
        how = "estimated" if self.mass_estimated else "given"
        out.add_fields([("method", self.method), ("degrees of freedom", str(self.n_dofs)), ("mass matrix", how)])
        se = self.standard_errors or {}
        rows = [(e.name, self.coefficients[e.name], se.get(e.name), e.coefficient_unit) for e in self.elements]
        coefficient_table(out, "element", rows)
        if self.linear_modes is not None:
            lm = self.linear_modes
            text = ", ".join(f"{f:.4g} Hz ({100 * z:.3g} %)" for f, z in zip(lm.fn_hz, lm.zeta, strict=True))
            out.add_fields([("underlying linear modes", text or "none")], gap=True)
        if self.equilibria is not None:
            fmt = lambda p: "(" + ", ".join(f"{x:.4g}" for x in p) + ")"  # noqa: E731
            st = "; ".join(fmt(p) for p in self.equilibria.stable) or "none"
            un = "; ".join(fmt(p) for p in self.equilibria.unstable) or "none"
            out.add_fields([("equilibria (m)", f"stable {st}; unstable {un}")])
        out.add_text(
            *(
                f"at z* = ({', '.join(f'{x:.4g}' for x in m.equilibrium)}): "
                + ", ".join(f"{f:.4g} Hz ({100 * z:.3g} %)" for f, z in zip(m.fn_hz, m.zeta, strict=True))
                for m in self.modes
            ),
            indent="  ",
        )
        scores = []
        if self.eps_percent is not None:
            scores.append(("epsilon per DOF", ", ".join(f"{x:.3g} %" for x in self.eps_percent)))
        out.add_fields(scores, gap=True)
        return self._summary_tail(out)

    def __repr__(self) -> str:
        mass = "mass estimated" if self.mass_estimated else "mass given"
        names = ", ".join(self.elements.names)
        return f"<IdentifiedStructure {self.method!r}: {self.n_dofs} DOFs; {names}; {mass}{self._flagged()}>"

    # ------------------------------------------------------------------ figures
    def plot_elements(self, record: Record | None = None, ax: Any = None) -> Any:
        """Restoring force of each element against its relative coordinate
        (:func:`nlid.identified.structure_plots.plot_elements`)."""
        from .structure_plots import plot_elements

        return plot_elements(self.structure, record, ax=ax, z_range=self.z_range)

    def plot_frf(
        self, ax: Any = None, *, at: Sequence[float] | None = None, frequency_hz: Sequence[float] | None = None
    ) -> Any:
        """Magnitude of the receptance matrix of the linear(ised) system
        (:func:`nlid.identified.structure_plots.plot_frf`)."""
        from .structure_plots import plot_frf

        return plot_frf(self.structure, ax=ax, at=at, frequency_hz=frequency_hz)
