"""Property-based tests (hypothesis) of everything that reads user input (issue 18, group 8).

For every generated input, the term grammar, column maps, study TOML and the
CSV/NPZ/MAT readers give either a valid result or an nlid error (at the
command line: exit 2 with one line), never another exception, and quickly
(each example is timed: no input may make them hang). Examples are
derandomised, so a run is reproducible, and few enough to keep the suite fast.
"""

from __future__ import annotations

import math
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy import io as sio

import nlid
from nlid.cli.main import main
from nlid.data.columnmap import ColumnExpr, parse_columns
from nlid.errors import NlidError
from nlid.model.terms import Model, parse_term
from nlid.model.terms.term import MAX_POWER, VARIABLES
from nlid.study import ConfigError, parse_study
from nlid.study.config import resolve_study

SETTINGS = settings(
    max_examples=120,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)
FEW = settings(SETTINGS, max_examples=40)
#: No single parse may take longer than this (s): a generous bound that still catches a hang.
QUICK = 5.0

# --------------------------------------------------------------------------- term grammar
TERM_TOKENS = [
    "z", "v", "1", "px(z)", "|", "(", ")", "*", "^", "**", "2", "3", "15", "16", "0", "sign(", "sgn(", "abs(",
    "exp(-|v|/0.01)", "exp(-(v/0.1)^2)", "tanh(v/0.001)", "exp(", "tanh(", "-", "+", "/", ",", " ", "q", "1e3",
    ".5", "z^15", "(z^4)^4", "\u00e9",
]
term_text = st.one_of(
    st.lists(st.sampled_from(TERM_TOKENS), max_size=40).map("".join),
    st.text(max_size=60),
    st.integers(0, 600).map(lambda n: "(" * n + "z" + ")" * n),
    st.integers(1, 3000).map(lambda n: "*".join(["z"] * n)),
)


@SETTINGS
@given(term_text)
def test_terms_parse_or_refuse_with_an_nlid_error(text):
    start = time.perf_counter()
    try:
        model = Model.from_spec(text, defaults=False)
    except NlidError as exc:
        assert "\n" not in str(exc)
        return
    finally:
        assert time.perf_counter() - start < QUICK
    for term in model.terms:
        assert parse_term(term.name).name == term.name  # the canonical spelling parses to itself
        for var in VARIABLES:
            assert getattr(term, var)[0] <= MAX_POWER, term.name  # limits hold on the normal form
        assert all(s[3] <= MAX_POWER for s in term.special), term.name


# --------------------------------------------------------------------------- column maps
MAP_TOKENS = ["f", "z", "t", "v", "a", "q", "=", ",", "*", "/", "-", "2.5", "0", "1e3", "col", "k", "s", " ", "+"]
map_text = st.one_of(st.lists(st.sampled_from(MAP_TOKENS), max_size=25).map("".join), st.text(max_size=40))
N = 64
TABLE = {
    "col": np.linspace(0.0, 1.0, N),
    "t": np.arange(N) / 100.0,
    "f": np.sin(np.arange(N)),
    "z": np.cos(np.arange(N)),
    "k": np.array(2.0),
    "s": np.array(["text"] * N),
    "c": np.arange(N) + 1j,
    "m": np.ones((N, 2)),
    "zero": np.array(0.0),
    "o": np.array([None], dtype=object),
}


@SETTINGS
@given(map_text)
def test_column_maps_parse_and_evaluate_or_refuse(text):
    start = time.perf_counter()
    try:
        exprs = parse_columns(text)
    except NlidError as exc:
        assert "\n" not in str(exc)
        return
    for channel, expr in exprs.items():
        assert isinstance(expr, ColumnExpr)
        try:
            out = expr.evaluate(TABLE, "table")
        except NlidError:
            continue
        assert out.dtype == float and out.ndim <= 1, (channel, expr)
    assert time.perf_counter() - start < QUICK


@SETTINGS
@given(st.sampled_from(list(TABLE)), st.lists(st.sampled_from(list(TABLE) + [2.0, 0.5]), max_size=3), st.booleans())
def test_every_kind_of_variable_is_a_number_or_a_data_error(column, factors, negate):
    expr = ColumnExpr(column, tuple(factors), (), negate)
    try:
        out = expr.evaluate(TABLE, "table")
    except NlidError as exc:
        assert "\n" not in str(exc)
        return
    assert out.dtype == float and np.isrealobj(out)


# --------------------------------------------------------------------------- study TOML
def _toml(value) -> str:
    """A value as TOML (inline tables and arrays; nan and inf as TOML writes them)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n") + '"'
    if isinstance(value, list):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    return "{ " + ", ".join(f'"{k}" = {_toml(v)}' for k, v in value.items()) + " }"


scalars = st.one_of(
    st.integers(-(2**40), 2**40),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0, 1, -1, 0.02, 1e300, -0.2, 2.0, 600, 0.25]),
    st.sampled_from(["", "all", "known", "estimate", "none", "independent", "z^3, z^2, v*|v|", "q", "rfs", "x y"]),
    st.booleans(),
)
values = st.recursive(
    scalars,
    lambda inner: st.one_of(
        st.lists(inner, max_size=3),
        st.dictionaries(st.sampled_from(["z", "v", "a", "q", "duration", "mass"]), inner, max_size=3),
    ),
    max_leaves=6,
)
STUDY_KEYS = ["name", "description", "seed", "repetitions", "timeout", "identifiers", "bogus"]
DATASET_KEYS = [
    "name", "overrides", "noise", "channels", "terms", "without", "px_roots", "mass", "holdout", "freerun",
    "slices", "repetitions", "timeout", "models", "methods", "reference", "columns", "fs", "part", "bogus",
]
POSTERIOR_KEYS = ["params", "priors", "walkers", "max_steps", "seed", "move", "bias_correction", "bias_pairs",
                  "noise", "cutoff", "others", "level", "draws"]


@st.composite
def study_text(draw) -> str:
    lines = []
    study = draw(st.dictionaries(st.sampled_from(STUDY_KEYS), values, max_size=3))
    if study:
        lines.append("[study]")
        lines += [f'"{k}" = {_toml(v)}' for k, v in study.items()]
    if draw(st.booleans()):
        opts = draw(st.dictionaries(st.sampled_from(["cutoff", "decimate", "bogus"]), values, max_size=2))
        lines.append("[options.rfs]")
        lines += [f'"{k}" = {_toml(v)}' for k, v in opts.items()]
    for _ in range(draw(st.integers(0, 2))):
        lines.append("[[datasets]]")
        kind = draw(st.sampled_from(["preset", "preset", "dataset", "file", None]))
        if kind == "preset":
            lines.append('preset = "paper-numerical"')
        elif kind == "dataset":
            lines.append('dataset = "emps"')
        elif kind == "file":
            lines.append('file = "x.csv"')
        entry = draw(st.dictionaries(st.sampled_from(DATASET_KEYS), values, max_size=4))
        lines += [f'"{k}" = {_toml(v)}' for k, v in entry.items()]
    if draw(st.booleans()):
        post = draw(st.dictionaries(st.sampled_from(POSTERIOR_KEYS), values, max_size=3))
        lines.append("[posterior]")
        lines += [f'"{k}" = {_toml(v)}' for k, v in post.items()]
    return "\n".join(lines) + "\n"


@SETTINGS
@given(st.one_of(study_text(), st.text(max_size=80)))
def test_study_toml_validates_or_refuses_with_file_and_key(text):
    start = time.perf_counter()
    try:
        config = resolve_study(parse_study(text, source="gen.toml", base_dir=tempfile.gettempdir()))
    except ConfigError as exc:
        message = str(exc)
        assert message.startswith("gen.toml: ") and "\n" not in message, message
        return
    finally:
        assert time.perf_counter() - start < 4 * QUICK
    assert config.run_count >= 1
    for ds in config.datasets:
        assert all(math.isfinite(x) for x in ds.slices)
        assert 0 < ds.timeout and ds.repetitions >= 1


# --------------------------------------------------------------------------- CSV / NPZ / MAT readers
cells = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True, width=64),
    st.sampled_from([0.0, 1.0, -1.0, 1e300, 1e-300]),
    st.integers(-5, 5),
)
names = st.sampled_from(["t", "f", "z", "v", "a", "x", "fs"])


@st.composite
def tables(draw) -> dict[str, np.ndarray]:
    n = draw(st.integers(0, 80))
    base = np.arange(n, dtype=float)
    out = {}
    for name in draw(st.lists(names, min_size=0, max_size=5, unique=True)):
        kind = draw(st.sampled_from(["smooth", "cells", "time", "scalar", "text", "complex"]))
        if kind == "smooth":
            out[name] = np.sin(0.3 * base + draw(st.floats(0, 3))) * draw(st.sampled_from([1.0, 1e-6, 1e6]))
        elif kind == "cells":
            out[name] = np.array(draw(st.lists(cells, min_size=n, max_size=n)), dtype=float)
        elif kind == "time":
            out[name] = base / draw(st.sampled_from([100.0, 1.0, 1e6]))
        elif kind == "scalar":
            out[name] = np.array(draw(st.sampled_from([100.0, 0.0, -1.0, float("nan")])))
        elif kind == "text":
            out[name] = np.array(["a"] * max(n, 1))
        else:
            out[name] = base + 1j
    return out


def _write(table: dict[str, np.ndarray], folder: Path, suffix: str) -> Path:
    path = folder / f"gen{suffix}"
    if suffix == ".npz":
        np.savez(path, **table)
    elif suffix == ".mat":
        sio.savemat(path, table)
    else:
        columns = {k: v for k, v in table.items() if v.ndim == 1}
        n = max((v.size for v in columns.values()), default=0)
        frame = pd.DataFrame({k: pd.Series(v) for k, v in columns.items()}, index=range(n))
        frame.to_csv(path, index=False)
    return path


@SETTINGS
@given(tables(), st.sampled_from([".csv", ".npz", ".mat"]), st.one_of(st.none(), map_text),
       st.one_of(st.none(), st.sampled_from([100.0, 0.0, -5.0, float("nan"), 1e12])))
def test_readers_give_a_record_or_a_data_error(table, suffix, columns, fs):
    with tempfile.TemporaryDirectory() as tmp:
        try:
            path = _write(table, Path(tmp), suffix)
        except (ValueError, TypeError):
            return  # the writer itself refused (e.g. scipy with a complex scalar): nothing to read
        start = time.perf_counter()
        try:
            record = nlid.load(path, columns=columns, fs=fs)
        except NlidError as exc:
            assert "\n" not in str(exc)
            return
        finally:
            assert time.perf_counter() - start < QUICK
    assert record.n >= 32 and np.all(np.isfinite(record.f)) and np.all(np.isfinite(record.z))
    assert np.isrealobj(record.f) and np.isrealobj(record.z)


@FEW
@given(st.binary(max_size=400), st.sampled_from([".csv", ".txt", ".npz", ".mat"]))
def test_random_bytes_are_a_data_error(data, suffix):
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"junk{suffix}"
        path.write_bytes(data)
        with pytest.raises(NlidError):
            nlid.load(path)


# --------------------------------------------------------------------------- the command line
@FEW
@given(text=term_text, columns=st.one_of(st.none(), map_text))
def test_cli_exits_0_or_2_with_one_line(text, columns, capsys, tmp_path_factory):
    folder = tmp_path_factory.getbasetemp() / "prop-cli"
    data = folder / "x.csv"
    if not data.exists():
        folder.mkdir(exist_ok=True)
        record = nlid.simulate("paper-numerical", seed=0, channels="z,v,a", duration=2)
        pd.DataFrame({"t": record.t, "f": record.f, "z": record.z, "v": record.v, "a": record.a}).to_csv(
            data, index=False
        )
    argv = ["identify", str(data), f"--terms={text}", "--mass", "0.2"]
    if columns is not None:
        argv.append(f"--columns={columns}")
    capsys.readouterr()
    try:
        status = main(argv)
    except SystemExit as exc:  # argparse usage errors: one line, status 2
        status = exc.code
    err = capsys.readouterr().err
    assert status in (0, 1, 2), status
    if status:
        lines = [line for line in err.splitlines() if line.strip()]
        assert len(lines) == 1 and lines[0].startswith("nlid identify: error: "), err
    assert status != 2 or "error" in err
    assert "Traceback" not in err
