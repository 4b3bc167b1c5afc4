"""What every identified result shares, for any number of DOFs: :class:`Identified`.

:func:`nlid.identify` returns an :class:`~nlid.identified.model.IdentifiedModel` on one DOF's record and
an :class:`~nlid.identified.structure.IdentifiedStructure` on an indexed one. Both derive from
:class:`Identified`, which holds what they do the same way: the form (:attr:`Identified.indexed`, as
:attr:`nlid.data.record.Record.indexed`) and the number of DOFs, the freezing of the method's options,
diagnostics, warnings, arrays and provenance, the check of the standard errors, the fields every JSON
layout ends with and the check that a loaded result's stored figures are those of its coefficients, the
tail of the summary and the responses. Code that must tell the two forms apart
reads ``fit.indexed``, never the result's class, so that the two can become one type (issue 32).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from ..base import numerics
from ..base.frozen import FrozenDict, freeze
from ..errors import NlidError
from .plausibility import Flag

if TYPE_CHECKING:  # pragma: no cover
    from ..report.summary import Summary

__all__ = ["Identified", "STALE_RTOL"]

#: Relative difference beyond which a stored equilibrium or modal figure is not the one its coefficients give
#: (a coefficient edited after the fit); far above the last bits a root finder moves by across machines.
STALE_RTOL = 1e-6
#: What a result recomputes from its coefficients (:meth:`Identified._recomputed`).
Recomputed = tuple[Any, list[tuple[Sequence[Any], Sequence[Any]]], dict[str, Any], str]


class Identified:
    """The base of every identified result (one DOF or a structure); not built on its own.

    The subclasses are frozen dataclasses that declare the fields below (each in its own order, which
    their constructors keep); this class declares none, so that neither constructor changes.
    """

    method: str
    standard_errors: Mapping[str, float] | None
    options: Mapping[str, Any]
    diagnostics: Mapping[str, Any]
    warnings: tuple[str, ...]
    flags: tuple[Flag, ...]
    seconds: float | None
    z_range: Any
    arrays: Mapping[str, np.ndarray]
    provenance: Mapping[str, Any]

    # ------------------------------------------------------------------ the form
    @property
    def indexed(self) -> bool:
        """``True`` for a structure's result (elements on connections, a mass matrix), ``False`` for one DOF's.

        The same word as :attr:`nlid.data.record.Record.indexed`: a fit identified on an indexed record is
        indexed.
        """
        return False

    @property
    def n_dofs(self) -> int:
        """Number of DOFs (1 for one DOF's result)."""
        return 1

    # ------------------------------------------------------------------ shared by the constructors
    def _freeze_shared(self) -> None:
        """Freeze the fields every result has (flags as :class:`Flag`, mappings read-only, warnings as text)."""
        set_ = object.__setattr__
        set_(self, "flags", tuple(Flag.from_dict(f) for f in self.flags))
        set_(self, "options", freeze(dict(self.options)))
        set_(self, "diagnostics", freeze(dict(self.diagnostics)))
        set_(self, "warnings", tuple(str(w) for w in self.warnings))
        set_(self, "arrays", FrozenDict(self.arrays))
        set_(self, "provenance", freeze(dict(self.provenance or {})))

    def _standard_error_problems(self) -> list[str]:
        """The standard errors that are not finite, or negative, as :meth:`problems` reports them."""
        se = dict(self.standard_errors or {})
        found = numerics.nonfinite("standard errors", se)
        out = [found] if found else []
        negative = [n for n, x in se.items() if numerics.is_finite(x) and x < 0]
        if negative:
            out.append(f"standard errors of {', '.join(negative)} are negative")
        return out

    # ------------------------------------------------------------------ plain data
    def _recomputed(self) -> Recomputed | None:
        """What :meth:`_fresh` compares and replaces: ``(equilibria, [(stored modes, computed modes)...],
        replacement fields, warning)``, computed from the coefficients; ``None`` when they cannot be."""
        raise NotImplementedError(type(self).__name__)  # pragma: no cover - each form computes its own

    def _fresh(self) -> Any:
        """``self``, or when its stored equilibria or modes are not what its coefficients give (edited in the JSON),
        the same result with them recomputed, its scores on the original record dropped and a warning saying so.

        Modes a method measured itself (``source`` set, e.g. NSI's) are not compared; they are replaced when the
        equilibria or the computed modes show an edit. A result without the data range, or whose figures cannot
        be recomputed, is returned as it is.
        """
        stored = getattr(self, "equilibria", None)
        if self.z_range is None or stored is None:
            return self
        try:
            with numerics.collect_warnings():  # a figure that cannot be recomputed quietly leaves it as stored
                found = self._recomputed()
        except (NlidError, np.linalg.LinAlgError, ValueError, FloatingPointError):
            return self
        if found is None:
            return self
        eq, modes, replacement, note = found
        same = len(stored.stable) == len(eq.stable) and len(stored.unstable) == len(eq.unstable)
        same = same and all(_close(a, b) for a, b in zip(stored.all, eq.all, strict=True))
        same = same and all(_same_modes(old, new) for old, new in modes if old)
        if same:
            return self
        return dataclasses.replace(self, **replacement, warnings=(*self.warnings, note))  # type: ignore[type-var]

    def _shared_dict(self) -> dict[str, Any]:
        """The fields every JSON layout ends with, in their order (passed through ``to_jsonable`` by the caller)."""
        return {
            "options": dict(self.options),
            "diagnostics": dict(self.diagnostics),
            "warnings": list(self.warnings),
            # written only when a check of what physics forbids failed (the layout of other results is unchanged)
            **({"flags": [f.to_dict() for f in self.flags]} if self.flags else {}),
            "seconds": self.seconds,
            "z_range": self.z_range,
            "provenance": dict(self.provenance) or None,
        }

    @staticmethod
    def _shared_fields(data: Mapping[str, Any]) -> dict[str, Any]:
        """The constructor's arguments read from the fields every JSON layout has (the layout checked already)."""
        return {
            "method": str(data.get("method", "")),
            "mass_estimated": bool(data.get("mass_estimated", False)),
            "standard_errors": data.get("standard_errors"),
            "options": data.get("options") or {},
            "diagnostics": data.get("diagnostics") or {},
            "warnings": tuple(data.get("warnings") or ()),
            "flags": tuple(data.get("flags") or ()),
            "seconds": data.get("seconds"),
            "z_range": data.get("z_range"),
            "provenance": data.get("provenance") or {},
        }

    # ------------------------------------------------------------------ text and HTML
    def _summary_tail(self, out: Summary) -> Summary:
        """The summary's last lines: the wall time, the warnings and what makes the result not trusted."""
        tail = [] if self.seconds is None else [("time", f"{self.seconds:.3g} s")]
        out.add_fields(tail + [("warning", w) for w in self.warnings])
        out.add_fields([("NOT TRUSTED", str(f)) for f in self.flags])
        return out

    def _flagged(self) -> str:
        """The end of the repr of a result that is not trusted (empty otherwise)."""
        return f"; NOT TRUSTED: {', '.join(f.code for f in self.flags)}" if self.flags else ""

    def _repr_html_(self) -> str:
        """The summary as HTML (what Jupyter shows)."""
        return self.summary().as_html()  # type: ignore[attr-defined]  # each form has its own summary()

    # ------------------------------------------------------------------ what it predicts
    def frequency_response(self, force: Any, band: Any, *, harmonics: int = 7, **options: Any) -> Any:
        """The periodic response to ``F cos(2 pi f t)`` over a band, by harmonic balance and continuation.

        ``force``: amplitudes (N); ``band``: ``(low, high)`` Hz; ``options``: those of
        :func:`nlid.response.frequency_response` (``starts``, ``backbone``, ``settings``; on a structure
        ``dof=``, the driven DOF, default 1). Returns a :class:`~nlid.response.FrequencyResponse`
        (``to_frame()``, ``plot(ax=)``, ``verify()``...).
        """
        from ..response import frequency_response

        return frequency_response(self, force, band, harmonics=harmonics, **options)

    def backbone(self, amplitude: float, *, harmonics: int = 7, modes: Sequence[int] | None = None) -> Any:
        """The backbone curves of the conservative part up to ``amplitude`` (m) (:func:`nlid.response.backbone`).

        One per linear mode (``modes=``, 1-based, default all) at each stable equilibrium.
        """
        from ..response import backbone

        return backbone(self, amplitude, harmonics=harmonics, modes=modes)


def _close(a: Any, b: Any) -> bool:
    """Two stored and computed figures (numbers or arrays) agree: within :data:`STALE_RTOL` where finite, equal
    (NaN to NaN) where not."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if a.shape != b.shape:
        return False
    finite = np.isfinite(a)
    if not np.array_equal(finite, np.isfinite(b)) or not np.array_equal(a[~finite], b[~finite], equal_nan=True):
        return False
    a, b = a[finite], b[finite]
    return bool(np.all(np.abs(a - b) <= STALE_RTOL * np.maximum(np.maximum(np.abs(a), np.abs(b)), 1e-300)))


def _same_modes(stored: Sequence[Any], computed: Sequence[Any]) -> bool:
    """Stored modes (each with ``equilibrium``, ``fn_hz``, ``zeta``) are the computed ones, one for one."""
    return len(stored) == len(computed) and all(
        _close(a.equilibrium, b.equilibrium) and _close(a.fn_hz, b.fn_hz) and _close(a.zeta, b.zeta)
        for a, b in zip(stored, computed, strict=True)
    )
