"""The tables of data files, read lazily and bounded by what each file holds.

:mod:`nlid.data.io` opens a file as a *table* (column or variable name -> array)
through :func:`open_file_table`; this module holds the readers and the bounds
they keep:

Only what is used is read
    A MATLAB file (v4 to v7.3), an NPZ archive, an HDF5 file and a Parquet
    file are opened lazily: their variables are listed from the file's
    headers, and a variable is read only when a column map (or the same-named
    channel) uses it.
Declared sizes are checked before anything is read
    Every lazy table says how many values each variable declares
    (``size_of``) without reading it, so :mod:`nlid.data.columnmap` compares the
    columns a record uses with each other before reading them; and a variable
    is read only if the file holds the bytes it declares: uncompressed, at
    least as many bytes as the values take; compressed (deflate), at least
    ``1 /`` :data:`MAX_COMPRESSION` of them (deflate cannot do better). A
    file that declares more than it holds is refused in one line naming both
    sizes, before a byte of the variable is allocated.
Text files are size-checked before pandas reads them
    A CSV with holes (a sparse file: its length is far more than the bytes
    it has on disk) is refused, and so is one whose table would not fit in
    the memory this process may use (:func:`memory_limit`).
"""

from __future__ import annotations

import contextlib
import math
import os
import struct
import zipfile
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import DataError

__all__ = [
    "SizeError",
    "MAX_COMPRESSION",
    "size_text",
    "memory_limit",
    "check_text_size",
    "open_file_table",
    "HDF5_SUFFIXES",
]


class SizeError(DataError):
    """A file declares more than it holds, or more than this process may hold in memory."""


#: Largest ratio of uncompressed to compressed bytes deflate can reach (1032:1; zlib's documented limit).
MAX_COMPRESSION = 1032
#: Smallest variable (bytes) read whatever its file holds (a scalar, a short vector stored with fill values).
SMALL = 1 << 20
#: Bytes of memory a CSV table takes per byte of text, at most (a 2-byte field ``"0,"`` becomes an 8-byte float).
TEXT_EXPANSION = 4
#: File types read as HDF5.
HDF5_SUFFIXES = (".h5", ".hdf5")

#: MATLAB classes whose values are numbers (``char`` is text, ``cell`` references; others are objects).
MATLAB_NUMERIC = frozenset(
    ("double", "single", "logical", "int8", "uint8", "int16", "uint16", "int32", "uint32", "int64", "uint64")
)
#: Bytes per value of each MATLAB class (``char``: UTF-16 code units).
_MATLAB_BYTES = {
    "double": 8,
    "single": 4,
    "logical": 1,
    "int8": 1,
    "uint8": 1,
    "int16": 2,
    "uint16": 2,
    "int32": 4,
    "uint32": 4,
    "int64": 8,
    "uint64": 8,
    "char": 2,
}
#: Groups of a MATLAB v7.3 file that hold MATLAB's own bookkeeping, not variables.
_MATLAB_INTERNAL = ("#refs#", "#subsystem#")


def size_text(n: float) -> str:
    """A number of bytes for a message: ``"2.4 GB"``, ``"3.6 kB"``, ``"12 bytes"``."""
    n = float(n)
    for unit, scale in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if n >= scale:
            return f"{n / scale:.3g} {unit}"
    return f"{int(n)} bytes"


def _count(n: int) -> str:
    return f"{n:,}".replace(",", " ")


def memory_limit() -> int | None:
    """Bytes of memory this process may use: its address-space limit (``ulimit -v``) or the machine's memory.

    ``None`` when neither is known.
    """
    limits = []
    try:
        import resource

        soft = resource.getrlimit(resource.RLIMIT_AS)[0]
        if soft not in (resource.RLIM_INFINITY, -1) and soft > 0:
            limits.append(int(soft))
    except (ImportError, OSError, ValueError):  # pragma: no cover - not POSIX
        pass
    with contextlib.suppress(AttributeError, OSError, ValueError):  # not POSIX
        limits.append(int(os.sysconf("SC_PAGE_SIZE")) * int(os.sysconf("SC_PHYS_PAGES")))
    return min(limits) if limits else None


def check_text_size(path: Path) -> None:
    """Refuse a CSV or text file that holds holes or whose table would not fit in memory (before pandas reads it).

    Raises
    ------
    DataError
        A sparse file (its length is more than 64 times the bytes it has on disk), or a file whose table
        needs more than the memory this process may use (:data:`TEXT_EXPANSION` times its size).
    """
    st = path.stat()
    size = st.st_size
    on_disk = getattr(st, "st_blocks", None)
    if on_disk is not None and size > SMALL and on_disk * 512 * 64 < size:
        raise SizeError(
            f"{path} is {size_text(size)} long but holds only {size_text(on_disk * 512)} on disk (a sparse file: "
            "its holes read as zero bytes, which are no text)"
        )
    limit = memory_limit()
    if limit is not None and size * TEXT_EXPANSION > limit:
        raise SizeError(
            f"{path} is {size_text(size)}: read as a table it needs up to {size_text(size * TEXT_EXPANSION)}, more "
            f"than the {size_text(limit)} this process may use (save it as HDF5 or Parquet, read column by column)"
        )


def _bounded(name: str, source: str, count: int, itemsize: int, held: int, compressed: bool) -> None:
    """Refuse to read ``count`` values of ``itemsize`` bytes from ``held`` bytes of a file (``compressed``: deflate).

    Raises
    ------
    SizeError
        The values take more bytes than ``held`` can give (and more than :data:`SMALL`).
    """
    declared = count * itemsize
    if declared > max(held * (MAX_COMPRESSION if compressed else 1), SMALL):
        how = f"{size_text(held)} compressed" if compressed else size_text(held)
        raise SizeError(
            f"variable {name!r} in {source} declares {_count(count)} values ({size_text(declared)}) but the file "
            f"holds {how} for it (a damaged or forged file; nothing was read)"
        )


class LazyTable(Mapping):
    """A table whose columns are read when asked for; ``shape_of(name)`` is the shape a column declares."""

    def __init__(self, source: str, shapes: Mapping[str, tuple[int, ...] | None]) -> None:
        self.source = source
        self.shapes = {k: (None if v is None else tuple(int(n) for n in v)) for k, v in shapes.items()}
        self.sizes = {k: (None if v is None else math.prod(v)) for k, v in self.shapes.items()}
        self._cache: dict[str, np.ndarray] = {}

    def shape_of(self, key: str) -> tuple[int, ...] | None:
        """The shape ``key`` declares (from the file's headers, not its data); ``None``: not an array."""
        return self.shapes[key]

    def read(self, key: str) -> np.ndarray:  # pragma: no cover - every reader defines it
        raise NotImplementedError

    def __getitem__(self, key: str) -> np.ndarray:
        if key not in self.sizes:
            raise KeyError(key)
        if key not in self._cache:
            self._cache[key] = self.read(key)
        return self._cache[key]

    def __contains__(self, key: object) -> bool:
        return key in self.sizes

    def __iter__(self) -> Iterator[str]:
        return iter(self.sizes)

    def __len__(self) -> int:
        return len(self.sizes)


# --------------------------------------------------------------------------- MATLAB v4 to v7
def _mat5_extents(path: Path) -> list[tuple[int, bool]] | None:
    """``(bytes on disk, compressed)`` of each top-level element of a MAT v5 file (``None``: not v5).

    Read from the 8-byte tags alone (type and byte count), never from the data.
    """
    size = path.stat().st_size
    with open(path, "rb") as fh:
        header = fh.read(128)
        if len(header) < 128 or header[126:128] not in (b"IM", b"MI"):
            return None
        order = "<" if header[126:128] == b"IM" else ">"
        out = []
        position = 128
        while position + 8 <= size:
            fh.seek(position)
            kind, nbytes = struct.unpack(order + "II", fh.read(8))
            if kind >> 16:  # a small data element: not a variable
                position += 8
                continue
            held = min(nbytes, size - position - 8)
            out.append((held, kind == 15))  # 15: miCOMPRESSED, 14: miMATRIX
            position += 8 + nbytes + (0 if kind == 15 else (-nbytes) % 8)
    return out


class MatTable(LazyTable):
    """The variables of a MATLAB v4 to v7 file (scipy), each read alone when used.

    Logical arrays are read as booleans (refused as channels, as every other format's booleans are).
    """

    def __init__(self, path: Path) -> None:
        from scipy import io as sio

        listed = sio.whosmat(str(path))  # v7.3 (HDF5) raises NotImplementedError
        super().__init__(str(path), {name: shape for name, shape, _ in listed})
        self.path = path
        self.classes = {name: cls for name, _, cls in listed}
        extents = _mat5_extents(path)
        size = path.stat().st_size
        if extents is not None and len(extents) == len(listed):
            self.held = {name: extent for (name, _, _), extent in zip(listed, extents, strict=True)}
        else:  # MAT v4 (never compressed): the file as a whole
            self.held = {name: (size, False) for name, _, _ in listed}

    def read(self, key: str) -> np.ndarray:
        from scipy import io as sio

        cls = self.classes[key]
        if cls != "sparse":  # a sparse matrix holds only its non-zeros; every other class at least a byte a value
            held, compressed = self.held[key]
            _bounded(key, self.source, int(self.sizes[key] or 0), _MATLAB_BYTES.get(cls, 1), held, compressed)
        value = np.asarray(sio.loadmat(str(self.path), variable_names=[key])[key])
        value = value.squeeze() if value.ndim > 1 else value
        if cls == "logical":
            return value.astype(bool)
        return value


# --------------------------------------------------------------------------- NPZ
class NpzTable(LazyTable):
    """The arrays of an NPZ archive (read without pickle), each read alone when used."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.headers: dict[str, tuple[tuple[int, ...], np.dtype, zipfile.ZipInfo]] = {}
        with zipfile.ZipFile(path) as archive:
            for info in archive.infolist():
                if not info.filename.endswith(".npy"):
                    continue
                with archive.open(info) as member:
                    version = np.lib.format.read_magic(member)
                    reader = {
                        (1, 0): np.lib.format.read_array_header_1_0,
                        (2, 0): np.lib.format.read_array_header_2_0,
                    }.get(version)
                    if reader is None:
                        raise DataError(f"{path}: {info.filename} is an .npy of version {version}, unknown to nlid")
                    shape, _, dtype = reader(member)
                self.headers[info.filename[:-4]] = (tuple(shape), np.dtype(dtype), info)
        super().__init__(str(path), {k: shape for k, (shape, _, _) in self.headers.items()})

    def read(self, key: str) -> np.ndarray:
        shape, dtype, info = self.headers[key]
        if dtype.hasobject:
            raise DataError(f"{self.path}: contains pickled objects, which nlid never loads")
        stored = info.compress_type == zipfile.ZIP_STORED
        _bounded(key, self.source, math.prod(shape), dtype.itemsize, info.compress_size, not stored)
        with zipfile.ZipFile(self.path) as archive, archive.open(info) as member:
            return np.lib.format.read_array(member, allow_pickle=False)


# --------------------------------------------------------------------------- Parquet
class ParquetTable(LazyTable):
    """The columns of a Parquet file (pyarrow), each read alone when used."""

    def __init__(self, path: Path) -> None:
        import pyarrow.parquet as pq

        self.file = pq.ParquetFile(str(path))
        rows = int(self.file.metadata.num_rows)
        names = [n for n in self.file.schema_arrow.names if not str(n).startswith("__index_level_")]
        super().__init__(str(path), {str(n).strip(): (rows,) for n in names})
        self.names = {str(n).strip(): n for n in names}

    def read(self, key: str) -> np.ndarray:
        from .columnmap import frame_table

        limit = memory_limit()
        rows = int(self.sizes[key] or 0)
        declared = rows * 8
        if limit is not None and declared > limit:
            raise SizeError(
                f"column {key!r} in {self.source} declares {_count(rows)} rows ({size_text(declared)}), "
                f"more than the {size_text(limit)} this process may use"
            )
        frame = self.file.read(columns=[self.names[key]]).to_pandas()
        return frame_table(frame, self.source)[key]

    def close(self) -> None:
        """Close the file."""
        self.file.close()


# --------------------------------------------------------------------------- HDF5 and MATLAB v7.3
def _attr(obj: Any, name: str) -> Any:
    value = obj.attrs.get(name)
    return value.decode() if isinstance(value, bytes) else value


class HDF5Table(LazyTable):
    """The datasets of an open HDF5 file (a MATLAB v7.3 file among them), read when asked for.

    Keys are paths without the leading ``/``. A dataset with a ``MATLAB_class``
    attribute is MATLAB's: transposed back to MATLAB's shape, text decoded,
    and a struct's fields keyed ``struct/field``.
    """

    def __init__(self, handle: Any, source: str) -> None:
        import h5py

        items: dict[str, Any] = {}
        skip = list(_MATLAB_INTERNAL)  # and the insides of sparse matrices

        def visit(name: str, obj: Any) -> None:
            if any(name == k or name.startswith(k + "/") for k in skip):
                return
            if isinstance(obj, h5py.Dataset):
                items[name] = obj
            elif _attr(obj, "MATLAB_sparse") is not None:
                items[name] = obj
                skip.append(name)

        handle.visititems(visit)
        self.items = items
        super().__init__(source, {k: (v.shape if isinstance(v, h5py.Dataset) else None) for k, v in items.items()})

    def read(self, key: str) -> np.ndarray:
        return _read_dataset(self.items[key], key, self.source)


def _read_dataset(obj: Any, name: str, source: str) -> np.ndarray:
    """One dataset as an array in the orientation its writer meant (MATLAB's arrays transposed back)."""
    import h5py

    matlab = _attr(obj, "MATLAB_class")
    if _attr(obj, "MATLAB_sparse") is not None:
        raise DataError(f"variable {name!r} in {source} is a sparse matrix; save it with full() first")
    if not isinstance(obj, h5py.Dataset):
        raise DataError(f"{name!r} in {source} is not an array")
    if _attr(obj, "MATLAB_empty"):
        return np.zeros(0)
    if h5py.check_dtype(ref=obj.dtype) is not None:
        return np.empty(obj.shape, dtype=object)  # a cell array (references): refused as objects when used
    if h5py.check_dtype(vlen=obj.dtype) is None:  # fixed-size values: the file must hold what the shape declares
        filtered = obj.id.get_create_plist().get_nfilters() > 0
        _bounded(name, source, int(obj.size), obj.dtype.itemsize, obj.id.get_storage_size(), filtered)
    if h5py.check_string_dtype(obj.dtype) is not None:
        return np.asarray(obj.asstr()[()], dtype=str)
    if matlab is not None and matlab not in MATLAB_NUMERIC and matlab != "char":
        raise DataError(f"variable {name!r} in {source} is a MATLAB {matlab}, not an array of numbers")
    data = np.asarray(obj[()])
    if data.dtype.names and {"real", "imag"} <= set(data.dtype.names):
        data = data["real"] + 1j * data["imag"]
    if matlab is None:
        return data
    data = data.T  # MATLAB writes column-major arrays: HDF5 holds them transposed
    if matlab == "char":
        return np.asarray("".join(map(chr, data.ravel(order="F"))))
    if matlab == "logical":
        return data.astype(bool)
    return data


def _open_hdf5(path: Path, what: str) -> tuple[Any, LazyTable]:
    try:
        import h5py
    except ImportError:
        raise DataError(
            f"cannot read {path}: {what} need the optional package h5py (pip install 'nlid[hdf5]')"
        ) from None
    handle = h5py.File(path, "r")
    try:
        return handle, HDF5Table(handle, str(path))
    except BaseException:
        handle.close()
        raise


# --------------------------------------------------------------------------- by suffix
def open_file_table(path: Path, suffixes: tuple[str, ...]) -> tuple[Any, Mapping[str, Any]]:
    """``(open handle or None, table)`` of a checked path, by its suffix (the readers above).

    Raises
    ------
    DataError
        An unknown suffix, a missing optional package, a file declaring more than it holds.
    """
    suffix = path.suffix.lower()
    if suffix in (".csv", ".txt"):
        import pandas as pd

        from .columnmap import frame_table

        check_text_size(path)
        frame = pd.read_csv(path, sep=None if suffix == ".txt" else ",", engine="python" if suffix == ".txt" else "c")
        return None, frame_table(frame, str(path))
    if suffix == ".npz":
        if not zipfile.is_zipfile(path):
            raise DataError(f"cannot read {path}: not an NPZ (zip) archive")
        return None, NpzTable(path)
    if suffix == ".mat":
        try:
            return None, MatTable(path)
        except NotImplementedError:  # v7.3: HDF5
            return _open_hdf5(path, "MATLAB v7.3 (HDF5) .mat files")
    if suffix in HDF5_SUFFIXES:
        return _open_hdf5(path, "HDF5 files")
    if suffix in (".parquet", ".pq"):
        try:
            import pyarrow.parquet  # noqa: F401
        except ImportError:
            raise DataError(
                f"cannot read {path}: Parquet files need the optional package pyarrow (pip install 'nlid[parquet]')"
            ) from None
        table = ParquetTable(path)
        return table.file, table
    raise DataError(f"cannot read {path}: unknown file type {suffix!r} (use {', '.join(suffixes)})")
