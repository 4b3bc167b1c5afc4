"""SHA-256 of a record's samples: what identifies the data a model was identified on.

The bytes hashed, in this order: :data:`RECORD_HASH_PREFIX`; ``fs`` and ``t0``
as little-endian float64; then, for each channel present in
:data:`nlid.data.checks.CHANNELS` order, its name in ASCII, a zero byte and its
samples as little-endian float64. The same samples give the same digest
whatever file, frame or array they came from (:mod:`nlid.identification.provenance`).
An indexed record (a structure's channels ``f1``, ``z1``, ``z2``...) starts with
:data:`STRUCTURE_HASH_PREFIX` instead and hashes each channel of
:attr:`~nlid.data.record.Record.channels` the same way.
"""

from __future__ import annotations

import hashlib
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # pragma: no cover
    from .record import Record

__all__ = ["record_sha256", "RECORD_HASH_PREFIX", "STRUCTURE_HASH_PREFIX"]

#: The first bytes hashed by :func:`record_sha256` (names the byte layout).
RECORD_HASH_PREFIX = b"nlid.Record/1\n"
#: The first bytes hashed by :func:`record_sha256` for an indexed record.
STRUCTURE_HASH_PREFIX = b"nlid.StructureRecord/1\0"


def record_sha256(record: Record) -> str:
    """SHA-256 of a record's samples in the canonical byte order of the module docstring (hexadecimal)."""
    digest = hashlib.sha256(STRUCTURE_HASH_PREFIX if record.indexed else RECORD_HASH_PREFIX)
    digest.update(np.array([record.fs, record.t0], dtype="<f8").tobytes())
    for name in record.channels:
        digest.update(name.encode("ascii") + b"\0")
        digest.update(np.ascontiguousarray(record.channel(name), dtype="<f8").tobytes())
    return digest.hexdigest()
