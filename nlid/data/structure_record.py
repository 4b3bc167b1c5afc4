"""``StructureRecord``: the earlier name of a :class:`~nlid.data.record.Record` in its indexed form (deprecated).

A structure's record is a :class:`~nlid.data.record.Record` whose channels
are indexed by DOF (``z1 .. zn``; :attr:`Record.indexed <nlid.data.record.Record.indexed>`),
built by ``Record(f=..., z=...)`` from ``(N, n)`` arrays, with ``force_dofs=``
or with ``indexed=True``. ``StructureRecord`` stays importable from here and
from :mod:`nlid.plugin` until nlid 0.3 (CHANGELOG.md): calling it builds the
indexed record, its ``from_record``, ``from_table``, ``from_frame`` and
``from_time`` do what they did, and ``isinstance(record, StructureRecord)`` is
true of every indexed record (and of no other object), so that code written
against the two classes keeps working.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from ..errors import InputError
from .record import Record

if TYPE_CHECKING:  # pragma: no cover
    import numpy as np
    import pandas as pd

__all__ = ["StructureRecord"]


class _IndexedRecordType(type):
    """``isinstance(x, StructureRecord)``: ``x`` is a :class:`Record` in its indexed form."""

    def __instancecheck__(cls, obj: object) -> bool:
        return isinstance(obj, Record) and bool(obj.indexed)


class StructureRecord(metaclass=_IndexedRecordType):
    """Deprecated alias: ``StructureRecord(f, z, fs, ...)`` is ``Record(f, z, fs, ..., indexed=True)``.

    The parameters are those of :class:`~nlid.data.record.Record` (``force_dofs`` in its old place, after
    ``t0``); what it returns is a :class:`~nlid.data.record.Record` of indexed channels.
    """

    def __new__(  # type: ignore[misc]
        cls,
        f: np.ndarray,
        z: np.ndarray,
        fs: float,
        v: np.ndarray | None = None,
        a: np.ndarray | None = None,
        t0: float = 0.0,
        force_dofs: Any = None,
        units: Mapping[str, str] | None = None,
        meta: Mapping[str, Any] | None = None,
        provenance: Mapping[str, str] | None = None,
    ) -> Record:
        given = (units or {}, meta or {}, provenance or {})
        return Record(f, z, fs, v, a, t0, *given, force_dofs=force_dofs, indexed=True)

    @staticmethod
    def from_record(record: Record) -> Record:
        """A one-DOF record as a structure record of one DOF (``z1``, ``f1``...): :meth:`Record.as_indexed`."""
        if not isinstance(record, Record):
            raise InputError(f"from_record needs an nlid Record, got {type(record).__name__}")
        return record.as_indexed()

    @staticmethod
    def from_table(
        table: Mapping[str, Any],
        columns: str | Mapping[str, str] | None = None,
        *,
        fs: float | None = None,
        force_hold: str | None = None,
        meta: Mapping[str, Any] | None = None,
        units: Mapping[str, str] | None = None,
        source: str | os.PathLike[str] = "mapping",
    ) -> Record:
        """``Record.from_table(..., indexed=True)``."""
        return Record.from_table(
            table, columns, fs=fs, force_hold=force_hold, meta=meta, units=units, source=source, indexed=True
        )

    @staticmethod
    def from_frame(frame: pd.DataFrame, columns: str | Mapping[str, str] | None = None, **kwargs: Any) -> Record:
        """``Record.from_frame(..., indexed=True)``."""
        import pandas as pd

        if not isinstance(frame, pd.DataFrame):
            raise InputError(f"StructureRecord.from_frame needs a pandas DataFrame, got {type(frame).__name__}")
        return Record.from_frame(frame, columns, indexed=True, **kwargs)

    @staticmethod
    def from_time(t: np.ndarray, f: np.ndarray, z: np.ndarray, **kwargs: Any) -> Record:
        """``Record.from_time(..., indexed=True)``."""
        return Record.from_time(t, f, z, indexed=True, **kwargs)
