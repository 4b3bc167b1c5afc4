"""Where nlid writes: output folders it owns, files the user named, one writer at a time.

Every command that writes goes through this module, so no user file is lost:

Folders (:func:`output_folder`)
    nlid writes only into folders it created, or that were empty: it marks
    them with :data:`MARKER`, a small JSON manifest of the entries (files
    and sub-folders) it wrote there. A folder that holds anything else is
    refused unless ``force=True``, and even then nlid never replaces an
    entry it did not write: each writer declares every entry it writes up
    front (:data:`STUDY_OUTPUTS`, :data:`POSTERIOR_OUTPUTS`,
    :data:`DISCOVERY_OUTPUTS`), and an existing one missing from the
    manifest stops it, naming the file, before anything is written (it is
    not written beside under another name: the report's links and the
    user's scripts expect the declared names). While a writer works, the
    folder is locked (``filelock``: ``flock`` on POSIX, ``msvcrt`` locking on
    Windows, released by the operating system even when the process is
    killed) on :data:`LOCK`; the writer names itself in :data:`WRITER`,
    which it removes when done. A second writer is refused at once, naming
    the process that holds the folder.

Files (:func:`check_new_file`)
    A file the user named (``simulate --out x.csv``) is replaced only with
    ``force=True``; its metadata sidecar (``x.csv.meta.json``) is replaced
    only if nlid wrote it (:func:`check_sidecar`).

Study folders written before the manifest existed are recognised by their
``runs/`` records and adopted, so interrupted studies still resume.

Temporary files (:func:`temporary`, :func:`atomic_write`)
    A file nlid replaces is written beside it as ``.<name>.<pid>.tmp`` and
    renamed over it. An error or a signal between the write and the rename
    removes the temporary file; one left by a process that was killed
    outright (``SIGKILL``) is removed by the next writer of the folder, under
    its lock (:func:`sweep_temporary`).

Links
    An output folder or file that is a dangling symbolic link is refused (its
    target would be created wherever it points), and so is a metadata sidecar
    that is a link (nlid would write through it into a file nobody named).
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import time
from collections.abc import Iterable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

from ..errors import InputError

__all__ = [
    "MARKER",
    "LOCK",
    "WRITER",
    "STUDY_OUTPUTS",
    "POSTERIOR_OUTPUTS",
    "DISCOVERY_OUTPUTS",
    "RESPONSE_OUTPUTS",
    "output_folder",
    "check_new_file",
    "check_sidecar",
    "sidecar_path",
    "META_KEYS",
    "FolderBusyError",
    "temporary",
    "atomic_write",
    "sweep_temporary",
]

#: The manifest nlid writes into every folder it owns.
MARKER = ".nlid-output.json"
#: The lock file of a folder (empty; locked while a writer works in the folder).
LOCK = ".nlid-lock"
#: Names the process writing into the folder (removed when it is done).
WRITER = ".nlid-writer"
#: Entries a study writes at the top of its folder (every one: tests/runtime/test_promises.py checks).
STUDY_OUTPUTS = (
    "study.toml",
    "runs",
    "arrays",
    "results.csv",
    "summary.md",
    "summary.txt",
    "summary.csv",
    "report.html",
    "figures",
)
#: Files :meth:`nlid.bayes.Posterior.save` writes.
POSTERIOR_OUTPUTS = (
    "posterior_table.csv",
    "posterior.json",
    "posterior_samples.npz",
    "posterior.nc",
    "posterior_corner.png",
    "posterior_trace.png",
    "posterior_damping.png",
)
#: Entries :func:`nlid.discovery.write_report` writes.
DISCOVERY_OUTPUTS = ("figures", "report.md", "report.html", "result.json", "models.csv")
#: Files :meth:`nlid.response.FrequencyResponse.save` writes.
RESPONSE_OUTPUTS = ("response.json", "response.csv", "response.md", "response.png", "measured.csv")
#: Metadata keys written to and read from the ``.meta.json`` sidecar of a data file (:mod:`nlid.data.io`).
META_KEYS = (
    "source",
    "force_hold",
    "mass",
    "g",
    "excitation",
    "preset",
    "seed",
    "noise",
    "reference",
    "truth",
    "periodic",
    "signal",
)

_OWN = (MARKER, LOCK, WRITER)
#: The name of a temporary file nlid writes before renaming it: ``.<name>.<pid>.tmp`` (``.tmp.npz`` for arrays).
_TEMPORARY = re.compile(r"^\..+\.(?P<pid>[0-9]+)\.tmp(\.npz)?$")


@contextmanager
def temporary(path: str | os.PathLike[str], suffix: str = "") -> Iterator[Path]:
    """A temporary name beside ``path`` (``.<name>.<pid>.tmp<suffix>``), removed if the block does not end normally.

    The block writes the temporary file and renames it over ``path`` (``os.replace``); an exception or a
    signal turned into one (``KeyboardInterrupt``: nlid's ``SIGTERM`` handlers raise it) removes it.
    """
    path = Path(path)
    stem = path.stem if suffix else path.name
    tmp = path.with_name(f".{stem}.{os.getpid()}.tmp{suffix}")
    try:
        yield tmp
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise


def atomic_write(path: str | os.PathLike[str], data: bytes) -> None:
    """Write ``data`` to ``path`` atomically: a temporary file, flushed to disk, renamed over it."""
    with temporary(path) as tmp:
        with open(tmp, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)


def _alive(pid: int) -> bool:
    if pid == os.getpid():
        return False  # our own are stale too: this writer has not started writing
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # not ours to signal: it exists
        return True
    return True


def sweep_temporary(folder: str | os.PathLike[str], entries: Iterable[str] = ()) -> list[Path]:
    """Remove the temporary files nlid left in ``folder`` and in its sub-folders ``entries`` (killed writers').

    Only names of nlid's own pattern (``.<name>.<pid>.tmp``) whose process is gone are removed; call it
    holding the folder's lock. Returns what was removed.
    """
    folder = Path(folder)
    places = [folder] + [folder / e for e in entries if (folder / e).is_dir() and not (folder / e).is_symlink()]
    removed = []
    for place in places:
        try:
            names = list(place.iterdir())
        except OSError:
            continue
        for path in names:
            m = _TEMPORARY.match(path.name)
            if m and not _alive(int(m.group("pid"))) and path.is_file() and not path.is_symlink():
                with contextlib.suppress(OSError):
                    path.unlink()
                    removed.append(path)
    return removed


class FolderBusyError(InputError):
    """Another process is writing into the output folder."""


def _read_manifest(folder: Path) -> dict | None:
    path = folder / MARKER
    if not path.is_file():
        return None
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError, RecursionError):
        return None
    if not isinstance(data, dict) or not isinstance(data.get("entries"), list):
        return None
    return data


def _write_manifest(folder: Path, entries: Iterable[str]) -> None:
    data = {
        "written_by": "nlid",
        "note": "nlid owns the entries listed here and may replace them; it never touches anything else",
        "entries": sorted(set(entries)),
        "updated": time.strftime("%Y-%m-%dT%H:%M:%S"),
    }
    with temporary(folder / MARKER) as tmp:
        tmp.write_text(json.dumps(data, indent=1) + "\n", encoding="utf-8")
        os.replace(tmp, folder / MARKER)


def _legacy_study(folder: Path) -> bool:
    """A study folder from before the manifest: ``runs/`` holds run records (``run_id`` and ``digest``)."""
    runs = folder / "runs"
    if not runs.is_dir():
        return False
    for path in sorted(runs.glob("*.json"))[:1]:
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError, RecursionError):
            return False
        return isinstance(data, dict) and "run_id" in data and "digest" in data
    return False


def _owned(folder: Path, outputs: Sequence[str], force: bool) -> set[str]:
    """What nlid owns in an existing ``folder`` if it may write ``outputs`` there; raises otherwise.

    Nothing is created or changed.
    """
    manifest = _read_manifest(folder)
    present = sorted(p.name for p in folder.iterdir() if p.name not in _OWN)
    owned: set[str] = set()
    if manifest is not None:
        owned = {str(e) for e in manifest["entries"]}
    elif set(outputs) == set(STUDY_OUTPUTS) and _legacy_study(folder):
        owned = set(present) & set(STUDY_OUTPUTS)
    elif present and not force:
        shown = ", ".join(present[:5]) + (f" and {len(present) - 5} more" if len(present) > 5 else "")
        raise InputError(
            f"the output folder {folder} holds files nlid did not write ({shown}); choose a new or empty "
            "folder, or give force=True to write beside them (nlid never replaces them)"
        )
    foreign = [name for name in outputs if (folder / name).exists() and name not in owned]
    if foreign:
        raise InputError(
            f"the output folder {folder} already holds {', '.join(foreign)}, which nlid did not write and would "
            "replace; move them away or choose another folder"
        )
    return owned


def _record(folder: Path, entries: set[str]) -> None:
    try:
        _write_manifest(folder, entries)
    except OSError as exc:
        raise InputError(f"cannot write into the output folder {folder}: {exc.strerror or exc}") from None


@contextmanager
def _lock(folder: Path) -> Iterator[None]:
    """Hold the folder's lock for the block, naming this process in :data:`WRITER`."""
    import socket

    from filelock import FileLock, Timeout

    lock = FileLock(str(folder / LOCK), timeout=0)
    try:
        lock.acquire()
    except Timeout:
        try:
            holder = (folder / WRITER).read_text(encoding="utf-8").strip()
        except (OSError, UnicodeDecodeError):
            holder = ""
        raise FolderBusyError(
            f"the output folder {folder} is being written by {holder or 'another process'}; wait for it to finish "
            "or choose another folder"
        ) from None
    except OSError as exc:
        raise InputError(f"cannot write into the output folder {folder}: {exc.strerror or exc}") from None
    writer = folder / WRITER
    try:
        try:
            writer.write_text(
                f"nlid process {os.getpid()} on {socket.gethostname()} since {time.strftime('%Y-%m-%d %H:%M:%S')}\n",
                encoding="utf-8",
            )
        except OSError as exc:
            raise InputError(f"cannot write into the output folder {folder}: {exc.strerror or exc}") from None
        yield
    finally:
        with contextlib.suppress(OSError):
            writer.unlink(missing_ok=True)
        lock.release()


@contextmanager
def output_folder(folder: str | os.PathLike[str], outputs: Sequence[str], *, force: bool = False) -> Iterator[Path]:
    """Claim and lock an output folder for the block (see the module docstring).

    Parameters
    ----------
    folder
        Created (with its parents) if missing.
    outputs
        The top-level files and sub-folders the writer will create or replace.
    force
        Write into a folder that holds files nlid did not write. nlid never
        replaces them: if one has the name of an entry in ``outputs``, it
        stops before writing anything, naming it.

    Yields
    ------
    Path
        The folder.

    Raises
    ------
    InputError
        The folder holds files nlid did not write (without ``force``), one
        of ``outputs`` exists and was not written by nlid, or the folder
        cannot be created or written.
    FolderBusyError
        Another process is writing into it.
    """
    path = Path(folder)
    _refuse_dangling(path, "output folder")
    if path.exists() and not path.is_dir():
        raise InputError(f"the output folder {path} exists and is not a folder")
    if path.exists():
        _owned(path, outputs, force)  # refuse before creating anything in a folder that is not ours
    else:
        try:
            path.mkdir(parents=True)
        except FileExistsError:
            pass  # created meanwhile by another writer: checked under the lock below
        except OSError as exc:
            raise InputError(f"cannot create the output folder {path}: {exc.strerror or exc}") from None
        else:
            _record(path, set(outputs))
    with _lock(path):
        owned = _owned(path, outputs, force) | set(outputs)
        sweep_temporary(path, owned)  # what a killed writer left between a write and its rename
        _record(path, owned)
        yield path


def _refuse_dangling(path: Path, what: str) -> None:
    """Refuse a symbolic link whose target does not exist: writing there would create the target, wherever it is."""
    if path.is_symlink() and not path.exists():
        raise InputError(
            f"the {what} {path} is a symbolic link to {os.readlink(path)}, which does not exist; nlid does not "
            "create a link's target: remove the link or give the target's path"
        )


def check_new_file(path: str | os.PathLike[str], *, force: bool = False) -> Path:
    """Check that a file the user named may be written (replaced only with ``force=True``).

    Raises
    ------
    InputError
        The path is a folder, its folder does not exist, or the file exists
        and ``force`` is not given.
    """
    path = Path(path)
    _refuse_dangling(path, "output file")
    if path.is_dir():
        raise InputError(f"{path} is a folder; give a file name")
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise InputError(f"cannot write {path}: the folder {parent} does not exist")
    if path.exists() and not force:
        raise InputError(f"{path} already exists; give force=True to replace it")
    check_sidecar(path)
    return path


def sidecar_path(path: str | os.PathLike[str]) -> Path:
    """``<file>.meta.json`` beside a data file."""
    path = Path(path)
    return path.with_name(path.name + ".meta.json")


def check_sidecar(path: str | os.PathLike[str]) -> None:
    """Refuse to replace a metadata sidecar ``<file>.meta.json`` that nlid did not write.

    A sidecar is nlid's when it is a JSON object whose keys are all keys
    nlid writes (:data:`META_KEYS`). A sidecar that is a symbolic link, or not
    a regular file, is refused: nlid would write through it into another file.
    """
    side = sidecar_path(path)
    if side.is_symlink():
        raise InputError(
            f"{side} is a symbolic link (to {os.readlink(side)}); nlid does not write through it: remove it before "
            f"writing {Path(path).name}"
        )
    if not side.exists():
        return
    if not side.is_file():
        raise InputError(f"{side} exists and is not a regular file; move it away before writing {Path(path).name}")
    try:
        data = json.loads(side.read_text(encoding="utf-8"))
    except (OSError, ValueError, RecursionError):
        data = None
    if not (isinstance(data, dict) and set(data) <= set(META_KEYS)):
        raise InputError(f"{side} exists and was not written by nlid; move it away before writing {Path(path).name}")
