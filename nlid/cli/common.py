"""Helpers shared by the subcommands: argument parsing, data loading, output."""

from __future__ import annotations

import argparse
import json
import os
import re
import sys
import textwrap
import time
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from ..data.names import describe as describe_datasets
from ..errors import InputError, brief, one_line

if TYPE_CHECKING:
    from ..data.record import Record

__all__ = [
    "Parser",
    "describe_os_error",
    "parse_settings",
    "load_data",
    "print_json",
    "untrusted",
    "with_wall_time",
    "add_data_arguments",
    "DATA_HELP",
    "to_cli",
    "FLAGS",
    "identify_command",
    "add_mass_argument",
    "mass_argument",
]

#: Python parameter names in library messages -> the command-line flag that sets them.
FLAGS: dict[str, str] = {
    "mass": "--mass",
    "params": "--params",
    "priors": "--prior",
    "max_steps": "--steps",
    "walkers": "--walkers",
    "bias_pairs": "--bias-pairs",
    "bias_correction=False": "--no-bias-correction",
    "noise": "--noise-level",
    "columns": "--columns",
    "units": "--units",
    "fs": "--fs",
    "force_hold": "--force-hold",
    "px_roots": "--px-roots",
    "px_max_iter": "--set px_max_iter",
    "cutoff": "--cutoff",
    "holdout": "--holdout",
    "rule": "--rule",
    "methods": "--methods",
    "reference": "--reference",
    "jobs": "--jobs",
    "scheduler": "--scheduler",
    "executor": "--executor",
    "options": "--set",
    "force=True": "--force",
    "timeout": "--timeout",
    "files": "--test-file",
    "band": "--band",
    "harmonics": "--harmonics",
    "draws": "--draws",
    "dof": "--dof",
}
_PARAM = re.compile(
    r"(?<![\w.-])(" + "|".join(sorted(map(re.escape, FLAGS), key=len, reverse=True)) + r")=(?=[\s),;:]|$)"
)
_PARAM_VALUE = re.compile(
    r"(?<![\w.-])(" + "|".join(sorted(map(re.escape, FLAGS), key=len, reverse=True)) + r")=(?:'([^']*)'|([\w.+-]+))"
)

DATA_HELP = (
    "data file (.csv, .npz, .mat, .h5, .parquet) or a measured benchmark read from $NLID_DATA_DIR: "
    f"{describe_datasets()}"
)


class _WholeWords:
    """A help formatter's line splitting that never breaks a hyphenated word (``dataset:silverbox:arrow-full``)."""

    def _split_lines(self, text: str, width: int) -> list[str]:
        return textwrap.wrap(" ".join(text.split()), width, break_on_hyphens=False, break_long_words=False)


class _HelpFormatter(_WholeWords, argparse.HelpFormatter):
    def _fill_text(self, text: str, width: int, indent: str) -> str:
        lines = textwrap.wrap(" ".join(text.split()), width, break_on_hyphens=False, break_long_words=False)
        return "\n".join(indent + line for line in lines)


class _RawDescriptionHelpFormatter(_WholeWords, argparse.RawDescriptionHelpFormatter):
    pass


class Parser(argparse.ArgumentParser):
    """ArgumentParser whose usage errors are one line and exit with status 2, and whose help never splits a
    hyphenated name (a flag, a dataset) across two lines."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        given = kwargs.get("formatter_class", argparse.HelpFormatter)
        kwargs["formatter_class"] = {
            argparse.HelpFormatter: _HelpFormatter,
            argparse.RawDescriptionHelpFormatter: _RawDescriptionHelpFormatter,
        }.get(given, given)
        super().__init__(*args, **kwargs)

    def error(self, message: str) -> None:  # type: ignore[override]
        self.exit(2, f"{self.prog}: error: {one_line(message)} (see {self.prog} --help)\n")


def to_cli(message: str) -> str:
    """A library message with its Python parameters (``mass=``) replaced by the flags that set them (``--mass``)."""
    message = message.replace("bias_correction=False", FLAGS["bias_correction=False"])
    message = message.replace("force=True", FLAGS["force=True"])
    message = _PARAM_VALUE.sub(
        lambda m: f"{FLAGS[m.group(1)]} {m.group(2) if m.group(2) is not None else m.group(3)}", message
    )
    message = _PARAM.sub(lambda m: FLAGS[m.group(1)], message)
    return message


def describe_os_error(exc: OSError) -> str:
    """One line for an operating-system error: what failed and on which path."""
    what = exc.strerror or str(exc) or type(exc).__name__
    paths = [one_line(str(p), 200) for p in (exc.filename, exc.filename2) if p is not None]
    return f"{what}: {' -> '.join(paths)}" if paths else what


def parse_settings(items: Sequence[str] | None) -> dict[str, str]:
    """``["k=v", ...]`` from repeated ``--set`` into a dict (values stay strings)."""
    out: dict[str, str] = {}
    for item in items or ():
        if "=" not in item:
            raise InputError(f"--set expects key=value, got {brief(item)}")
        key, value = item.split("=", 1)
        key = key.strip()
        if not key:
            raise InputError(f"--set expects key=value, got {brief(item)}")
        out[key] = value.strip()
    return out


def add_model_arguments(parser: argparse.ArgumentParser, method_help: str) -> None:
    """The model and identifier options: --method, --terms, --without, --mass, --px-roots, --set."""
    parser.add_argument("--method", metavar="NAME", help=method_help)  # default: nlid.contract.methods.choose_method
    add_term_arguments(
        parser,
        "known mass in kg; for a structure its matrix (default: estimated by the method; a structure's comes from "
        "the record's .meta.json sidecar when it has one)",
    )
    parser.add_argument("--set", action="append", metavar="KEY=VALUE", help="identifier option (repeatable)")


def add_term_arguments(parser: argparse.ArgumentParser, mass_help: str) -> None:
    """The model's options: --terms, --without, --mass, --px-roots."""
    parser.add_argument(
        "--terms", default="", metavar="TERMS", help="comma-separated terms besides 1, z, v, e.g. 'z^3,z^2,v*|v|'"
    )
    parser.add_argument("--without", default="", metavar="TERMS", help="default terms to leave out, e.g. '1' or 'z'")
    add_mass_argument(parser, mass_help)
    parser.add_argument(
        "--px-roots",
        metavar="ZMINUS,ZPLUS",
        help="roots of px(z) in m (default: taken from the identified stiffness, iterated)",
    )


def add_mass_argument(parser: argparse.ArgumentParser, mass_help: str) -> None:
    """``--mass``: a number of kg, ``estimate``, or a structure's mass matrix (literal, ``diag(...)``, a file)."""
    parser.add_argument(
        "--mass",
        metavar="KG|MATRIX|FILE",
        help=f"{mass_help}; a matrix is written '[[1,0,0],[0,1,0],[0,0,2]]' or 'diag(1,1,2)' or read from a "
        ".csv/.json/.npy file; 'estimate' asks the method to estimate it",
    )


def mass_argument(text: str | None) -> Any:
    """``--mass`` as the library's ``mass=`` (:func:`nlid.base.validate.parse_mass`), ``None`` when not given."""
    from ..base.validate import parse_mass

    return None if text is None else parse_mass(text)


def parse_px_roots(text: str | None) -> tuple[float, float] | None:
    """``--px-roots 'zminus,zplus'`` as two floats (``None`` when not given)."""
    if not text:
        return None
    try:
        a, b = (float(x) for x in text.split(","))
    except ValueError:
        raise InputError(f"--px-roots expects two numbers 'zminus,zplus', got {brief(text)}") from None
    return a, b


def identify_options(args: argparse.Namespace) -> dict[str, Any]:
    """What :func:`add_model_arguments` read, as :func:`nlid.identify`'s keywords.

    ``mass=`` (``--mass`` parsed: kg, ``estimate`` or a matrix), ``options=``, ``without=``, ``px_roots=``.
    """
    return {
        "mass": mass_argument(args.mass),
        "options": parse_settings(args.set),
        "without": args.without,
        "px_roots": parse_px_roots(args.px_roots),
    }


def add_data_arguments(parser: argparse.ArgumentParser) -> None:
    """The DATA positional and the options that say how to read it."""
    parser.add_argument("data", metavar="DATA", help=DATA_HELP)
    parser.add_argument(
        "--columns",
        metavar="MAP",
        help="which file columns are which channels, with optional scale factors, "
        "e.g. 'f=vir*gtau,z=qm' (channels t, f, z, v, a; default: columns named like the channels)",
    )
    parser.add_argument(
        "--units",
        metavar="CH=UNIT,...",
        help="units the channels are in, converted to SI, e.g. 'z=mm,a=g,f=kN' (t: s ms; f: N kN mN; "
        "z: m cm mm um; v: m/s mm/s...; a: m/s^2 mm/s^2 g; default SI); also z[mm]=COLUMN in --columns",
    )
    parser.add_argument("--fs", type=float, metavar="HZ", help="sampling frequency when the file has no time column")
    parser.add_argument(
        "--force-hold",
        choices=("sampled", "zoh"),
        help="how the force behaves between samples: 'sampled' (a sampled continuous signal, the default for "
        "measured data) or 'zoh' (held over each sample: a DAC output, or nlid's simulator); default: what the "
        "file's .meta.json says, else 'sampled'",
    )


def load_data(args: argparse.Namespace) -> Record:
    """Read the record named by ``args.data`` (:func:`nlid.api.load`)."""
    from ..api import load
    from ..data.units import parse_units

    units = parse_units(getattr(args, "units", None), where="--units", indexed=True) or None
    if str(args.data).startswith("dataset:") and (args.columns or args.fs or units):
        raise InputError("--columns, --fs and --units do not apply to bundled datasets")
    return load(args.data, columns=args.columns, fs=args.fs, force_hold=getattr(args, "force_hold", None), units=units)


def print_json(obj: Any) -> None:
    """One JSON object on stdout (NaN/inf written as null)."""
    from ..base.jsonable import to_jsonable

    json.dump(to_jsonable(obj), sys.stdout, allow_nan=False)
    sys.stdout.write("\n")


def _process_age() -> float:
    """Seconds since this process started (Linux ``/proc``), 0 where that cannot be read."""
    try:
        with open("/proc/self/stat") as stat, open("/proc/uptime") as up:
            ticks = int(stat.read().rsplit(")", 1)[1].split()[19])  # field 22: start time, clock ticks after boot
            return max(0.0, float(up.read().split()[0]) - ticks / os.sysconf("SC_CLK_TCK"))
    except (OSError, ValueError, IndexError, AttributeError):
        return 0.0


#: When the process started, on the :func:`time.perf_counter` clock (where it cannot be read: when the
#: command line's modules were imported, a fraction of a second later).
STARTED = time.perf_counter() - _process_age()


def with_wall_time(text: str, what: str) -> str:
    """``text`` with its ``time: 0.39 s`` line saying what that time is and the command's wall time so far.

    ``time: 0.39 s (identification), 6.6 s wall``: the library's figure times the work it names; the wall
    time also counts starting Python, importing, starting the worker process and compiling the kernels.
    """
    wall = time.perf_counter() - STARTED
    lines = text.split("\n")
    for i, line in enumerate(lines):
        if line.startswith("time: ") and line.endswith(" s"):
            lines[i] = f"{line} ({what}), {wall:.3g} s wall"
            break
    return "\n".join(lines)


def untrusted(command: str, problem: str) -> int:
    """The exit status of a result that ran: 0, or 1 with ``problem`` as one line on stderr when it is not empty.

    ``problem`` is why the result cannot be trusted, naming the likely cause
    (:func:`nlid.identified.plausibility.headline`); the result itself has been printed.
    """
    if not problem:
        return 0
    sys.stdout.flush()
    print(f"nlid {command}: error: {one_line(to_cli(problem))}", file=sys.stderr)
    return 1


def _setting(value: Any) -> str | None:
    """An option's value as ``--set`` spells it, or ``None`` when it cannot."""
    if value is None:
        return "auto"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float, str)):
        return str(value)
    if isinstance(value, (list, tuple)) and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in value):
        return ",".join(str(x) for x in value)
    return None


def identify_command(provenance: Any) -> str | None:
    """The ``nlid identify`` command that repeats a fit, from its provenance (:mod:`nlid.identification.provenance`).

    Parameters
    ----------
    provenance
        ``IdentifiedModel.provenance``, or the ``"provenance"`` object of
        ``nlid identify --json``.

    Returns
    -------
    str or None
        A shell command (``nlid identify rig.csv --columns ... --units ...
        --method ... --terms ... --mass ...``), or ``None`` when the data did
        not come from a file or a bundled dataset, were changed after loading,
        or a setting has no flag (``px_tol``, ``cutoff``, a column map given
        as a mapping).
    """
    import shlex

    from ..data.columnmap import column_units

    data, call = dict(provenance.get("data") or {}), dict(provenance.get("identify") or {})
    source = str(data.get("source") or "")
    from_file = data.get("sha256_of") == "file" or source.startswith("dataset:")
    columns = data.get("columns")
    if not call or not from_file or data.get("as_loaded") is False or not isinstance(columns, (str, type(None))):
        return None
    if call.get("px_tol", 1e-4) != 1e-4 or call.get("px_max_iter", 30) != 30 or call.get("cutoff") is not None:
        return None  # no flag of `nlid identify` sets them
    words = ["nlid", "identify", source]
    if columns:
        words += ["--columns", columns]
    in_map = column_units(columns)
    units = [
        f"{c}={u['unit']}" for c, u in (data.get("units") or {}).items() if u.get("factor") != 1.0 and c not in in_map
    ]
    if units:
        words += ["--units", ",".join(units)]
    if data.get("fs_given") is not None:
        words += ["--fs", str(float(data["fs_given"]))]
    words += ["--method", str(call["method"]), "--terms", ",".join(call.get("terms") or ())]
    if call.get("without"):
        words += ["--without", ",".join(call["without"])]
    if call.get("mass") is not None:
        mass = call["mass"]
        words += ["--mass", json.dumps(mass, separators=(",", ":")) if isinstance(mass, list) else str(float(mass))]
    if call.get("px_roots") is not None:
        words += ["--px-roots", ",".join(str(float(x)) for x in call["px_roots"])]
    for key, value in dict(call.get("options") or {}).items():
        text = _setting(value)
        if text is None:
            return None
        words += ["--set", f"{key}={text}"]
    return " ".join(shlex.quote(w) for w in words)
