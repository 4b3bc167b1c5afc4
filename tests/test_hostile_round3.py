"""Hostile probe, round three (issue 34): bounded reads, bench and compare hardened, the model JSON, signals.

One regression test (or more) per defect of the issue, under the class it belongs to:

``A``  reads and allocations bounded by what the input is, not by what it claims: files that declare more
       than they hold (read in a child process under a memory limit), DOF numbers, special files, sparse CSVs;
``B``  ``nlid bench`` as hardened as ``identify``: benchmark files of one's own, empty lists, bad test files,
       ``--render-docs`` input, the package's loader functions as an allow-list;
``C``  ``nlid compare`` and the CLI's small inconsistencies;
``D``  the model file format (a versioned schema validated on load) and provenance replay;
``E``  signals, crashes, symlinks, the dependency floor and the Dask scheduler's warning.

CLI cases check what ``tests/test_hostile.py`` checks: the exit status and exactly one line on stderr
starting ``nlid``, holding the fragment, never a traceback.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import signal
import struct
import subprocess
import sys
import time
import zipfile
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy import io as sio

import nlid
from nlid.cli.main import main
from nlid.data.io import write_csv
from nlid.errors import DataError, InputError

ROOT = Path(__file__).resolve().parents[1]
N = 1000
#: The address-space limit the bounded reads run under (the issue's ``ulimit -v 1572864``).
MEMORY_LIMIT = 1536 << 20


def _short(value: object) -> str:
    """A test id for a parameter: long texts (100 000 nested brackets) cut to a readable size."""
    text = str(value)
    return text if len(text) <= 40 else f"{text[:30]}...({len(text)})"


def _run(argv: list[str]) -> tuple[int, str, str]:
    """``nlid ARGV`` in this process: status, stdout, stderr."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            status = main(list(argv))
        except SystemExit as exc:  # argparse's own usage errors
            status = exc.code
    return status, out.getvalue(), err.getvalue()


def _one_error_line(err: str) -> str:
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1, f"expected one line on stderr, got {len(lines)}: {err[-2000:]}"
    assert lines[0].startswith(("nlid ", "nlid:")), lines[0]
    assert "Traceback" not in err and ": internal error:" not in lines[0], err[-2000:]
    return lines[0]


def _refused(argv: list[str], fragment: str, status: int = 2) -> str:
    got, _, err = _run(argv)
    assert got == status, f"exit {got}, expected {status}; stderr: {err[-2000:]}"
    line = _one_error_line(err)
    assert fragment in line, line
    return line


@contextlib.contextmanager
def _deadline(seconds: int):
    """Fail instead of hanging (a FIFO opened for reading blocks until a writer comes)."""

    def expired(signum, frame):
        raise TimeoutError(f"still running after {seconds} s: the path was read, not refused")

    previous = signal.signal(signal.SIGALRM, expired)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)


def _signals(n: int = N) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(34)
    f = rng.standard_normal(n)
    return {"t": np.arange(n) / 100.0, "f": f, "z": np.cumsum(f) * 1e-3}


# ============================================================================ A: bounded reads
def _mat5_forged(path: Path) -> Path:
    """A MAT v5 file with t, f, z and a variable ``big`` declaring 3e8 doubles (2.4 GB) that holds 16 bytes."""
    sio.savemat(path, _signals(), do_compression=False)

    def sub(kind: int, payload: bytes) -> bytes:
        return struct.pack("<II", kind, len(payload)) + payload + b"\0" * ((-len(payload)) % 8)

    declared = 300_000_000 * 8
    body = sub(6, struct.pack("<II", 6, 0)) + sub(5, struct.pack("<ii", 300_000_000, 1)) + sub(1, b"big")
    element = body + struct.pack("<II", 9, declared) + b"\0" * 16  # miDOUBLE, cut short
    with open(path, "ab") as fh:
        fh.write(struct.pack("<II", 14, len(body) + 8 + declared) + element)
    return path


def _mat4_forged(path: Path) -> Path:
    """A MAT v4 file with t, f, z and a variable ``big`` whose header declares 3e8 doubles, holding 16 bytes."""
    sio.savemat(path, _signals(), format="4")
    with open(path, "ab") as fh:  # type 0000 (little-endian doubles), 3e8 x 1, real, a 4-byte name
        fh.write(struct.pack("<5i", 0, 300_000_000, 1, 0, 4) + b"big\0" + b"\0" * 16)
    return path


def _npz_forged(path: Path) -> Path:
    """An NPZ archive with t, f, z and ``big.npy`` whose header declares 3e8 doubles and that holds 16 bytes."""
    np.savez(path, **_signals())
    member = io.BytesIO()
    np.lib.format.write_array_header_1_0(member, {"descr": "<f8", "fortran_order": False, "shape": (300_000_000,)})
    with zipfile.ZipFile(path, "a") as archive:
        archive.writestr("big.npy", member.getvalue() + b"\0" * 16)
    return path


def _h5_forged(path: Path, matlab: bool = False) -> Path:
    """HDF5 (or MATLAB v7.3) with t, z and a chunked ``f`` of 2e9 doubles (16 GB) of which 1000 are written."""
    import h5py

    data = _signals()
    with h5py.File(path, "w", userblock_size=512 if matlab else 0) as h:
        for name in ("t", "z"):
            h[name] = data[name][:, None] if matlab else data[name]
        f = h.create_dataset("f", shape=(2_000_000_000, 1) if matlab else (2_000_000_000,), chunks=True, dtype="f8")
        f[:N] = data["f"][:, None] if matlab else data["f"]
        if matlab:
            for name in ("t", "z", "f"):
                h[name].attrs["MATLAB_class"] = np.bytes_("double")
    if matlab:
        header = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Mon Jan  1 00:00:00 2024 HDF5 schema 1.00 ."
        with open(path, "r+b") as handle:
            handle.write(header.ljust(116, b" ") + b"\0" * 8 + b"\x00\x02IM")
    return path


_BOUNDED_READS = """
import json, sys
import nlid
out = {}
for name, columns in json.loads(sys.argv[1]).items():
    try:
        record = nlid.load(name.strip(), columns=columns)
        out[name] = ["ok", record.n]
    except Exception as exc:
        out[name] = [type(exc).__name__, str(exc)]
print(json.dumps(out))
"""


def _limit_memory() -> None:
    import resource

    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT, MEMORY_LIMIT))


def _load_under_memory_limit(folder: Path, cases: dict[str, str | None]) -> dict[str, list]:
    if not sys.platform.startswith("linux"):
        pytest.skip("RLIMIT_AS bounds the address space on Linux")
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), str(ROOT / "plugins"), env.get("PYTHONPATH", "")])
    done = subprocess.run(
        [sys.executable, "-c", _BOUNDED_READS, json.dumps(cases)],
        cwd=folder,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
        preexec_fn=_limit_memory,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_a_every_reader_refuses_a_file_that_declares_more_than_it_holds_under_a_memory_limit(tmp_path):
    """MAT v4 and v5, NPZ, HDF5 and MATLAB v7.3: a variable declaring gigabytes is never allocated.

    Unused, it is not read at all (only the mapped variables are); mapped, the refusal names what it
    declares and what the file holds. The child runs under ``ulimit -v 1.5 GB``: reading what the
    files declare would end in ``MemoryError``.
    """
    pytest.importorskip("h5py")
    _mat5_forged(tmp_path / "big.mat")
    _mat4_forged(tmp_path / "big4.mat")
    _npz_forged(tmp_path / "big.npz")
    _h5_forged(tmp_path / "big.h5")
    _h5_forged(tmp_path / "big73.mat", matlab=True)
    got = _load_under_memory_limit(
        tmp_path,
        {
            "big.mat": None,  # the unused 2.4 GB variable is not read
            "big4.mat": None,
            "big.npz": None,
            "big.mat ": "t=big, f=big, z=big",  # (a trailing space repeats a file; the child strips it)
            "big4.mat ": "t=big, f=big, z=big",
            "big.npz ": "t=big, f=big, z=big",
            "big.h5": "f=f, z=z",  # f declares 2e9 samples, z 1000: refused before reading either
            "big73.mat": "t=t, f=f, z=z",
            "big.h5 ": "t=f, f=f, z=f",  # consistent lengths, but the file holds 1000 of the 2e9 samples
        },
    )
    assert got["big.mat"] == got["big4.mat"] == got["big.npz"] == ["ok", N], got
    for name in ("big.mat ", "big4.mat ", "big.npz "):
        kind, message = got[name]
        assert kind == "SizeError", got[name]
        assert "declares 300 000 000 values (2.4 GB) but the file holds" in message, message
        held = message.split("holds ")[1].split(" ")[1]  # v5 and NPZ: the variable's own bytes; v4: the file's
        assert held == ("kB" if name == "big4.mat " else "bytes"), message
    for name in ("big.h5", "big73.mat"):
        kind, message = got[name]
        assert kind == "DataError" and "declares 2 000 000 000 values" in message, got[name]
        assert "1 000" in message and "nothing was read" in message, message
    kind, message = got["big.h5 "]
    assert kind == "SizeError" and "declares 2 000 000 000 values (16 GB)" in message, got["big.h5 "]


def test_a_a_compressed_mat_variable_is_bounded_by_deflate_s_ratio(tmp_path):
    """A compressed variable may expand at most 1032 times (deflate's limit): a forged ratio is refused."""
    from nlid.data.filetables import MAX_COMPRESSION, _bounded

    _bounded("x", "f.mat", 1000, 8, 8, True)  # small: read whatever the file holds
    with pytest.raises(DataError, match=r"declares 300 000 000 values \(2.4 GB\) but the file holds 1 kB compressed"):
        _bounded("x", "f.mat", 300_000_000, 8, 1000, True)
    _bounded("x", "f.mat", 1000 * MAX_COMPRESSION, 1, 1000, True)  # at the limit: read


def test_a_mat_logical_arrays_are_booleans_and_only_mapped_variables_are_read(tmp_path, monkeypatch):
    from scipy import io as scipy_io

    data = _signals()
    path = tmp_path / "m.mat"
    scipy_io.savemat(path, {**data, "flag": data["f"] > 0, "other": np.arange(5.0)})
    names = []
    real = scipy_io.loadmat

    def loadmat(*args, **kwargs):
        names.extend(kwargs.get("variable_names") or ["<every variable>"])
        return real(*args, **kwargs)

    monkeypatch.setattr(scipy_io, "loadmat", loadmat)
    assert nlid.load(path).n == N
    assert sorted(names) == ["f", "t", "z"]  # never "other", never every variable
    with pytest.raises(DataError, match="column 'flag' in .*m.mat holds booleans"):
        nlid.load(path, columns="f=flag, z=z")


def test_a_dof_numbers_have_an_upper_bound(tmp_path):
    data = _signals(64)
    frame = pd.DataFrame({"t": data["t"], "f1": data["f"], "z1": data["z"], "z99999999999": data["z"]})
    frame.to_csv(tmp_path / "dof.csv", index=False)
    with _deadline(60):
        with pytest.raises(DataError, match=r"column 'z99999999999' names DOF 99999999999; a structure has at most"):
            nlid.load(tmp_path / "dof.csv")
        with pytest.raises(InputError, match=r"column map: channel 'z99999999999' names DOF 99999999999"):
            nlid.load(tmp_path / "dof.csv", columns="f1=f1, z1=z1, z99999999999=z1")
    _refused(["identify", str(tmp_path / "dof.csv"), "--terms", "z1^3"], "names DOF 99999999999")


@pytest.fixture
def fifo(tmp_path):
    if not hasattr(os, "mkfifo"):
        pytest.skip("no named pipes on this platform")
    path = tmp_path / "pipe.csv"
    os.mkfifo(path)
    return path


@pytest.fixture
def fit_json(tmp_path, short_record):
    """A model JSON of a record read from a file (its provenance names the file)."""
    path = tmp_path / "x.csv"
    write_csv(short_record, path)
    fit = nlid.identify(nlid.load(path), "z^3, z^2, v*|v|", "rfs", mass=0.2)
    (tmp_path / "fit.json").write_text(json.dumps(fit.to_dict(), allow_nan=False))
    return tmp_path / "fit.json"


@pytest.mark.parametrize("special", ["fifo", "/dev/zero"])
def test_a_special_files_are_refused_by_bench_compare_and_replay(special, fifo, fit_json, monkeypatch):
    """The three readers that bypassed nlid.data.io's path check now go through it (none hangs or reads forever)."""
    from nlid.identification.replay import identify_again

    if special == "/dev/zero" and not Path(special).exists():
        pytest.skip("no /dev/zero")
    path = str(fifo) if special == "fifo" else special
    monkeypatch.chdir(fit_json.parent)
    what = "a named pipe (FIFO)" if special == "fifo" else "a device"
    with _deadline(120):
        _refused(["compare", "x.csv", "--terms", "z^3", "--mass", "0.2", "--reference", path], what)
        _refused(["bench", "--benchmark", "bouc-wen", "--test-file", f"bouc-wen:multisine={path}", "--out", "b"], what)
        provenance = json.loads(fit_json.read_text())["provenance"]
        provenance["data"]["source"] = path
        with pytest.raises(DataError, match=what.replace("(", r"\(").replace(")", r"\)")):
            identify_again(provenance)
    assert not Path("b").exists()  # refused before the output folder was made


def test_a_a_sparse_csv_is_refused_before_pandas_reads_it(tmp_path):
    path = tmp_path / "sparse.csv"
    path.write_text("t,f,z\n")
    with open(path, "r+b") as fh:
        fh.truncate(2 << 30)  # 2 GiB of holes
    if os.stat(path).st_blocks * 512 > 1 << 20:
        pytest.skip("this file system does not make sparse files")
    with _deadline(60):
        _refused(["identify", str(path), "--terms", "z^3"], "is 2.15 GB long but holds only")


def test_a_a_csv_or_parquet_that_would_not_fit_in_memory_is_refused_naming_its_size(tmp_path, monkeypatch):
    from nlid.data import filetables

    data = _signals()
    pd.DataFrame(data).to_csv(tmp_path / "x.csv", index=False)
    monkeypatch.setattr(filetables, "memory_limit", lambda: 40_000)
    with pytest.raises(DataError, match=r"x.csv is .* kB: read as a table it needs up to .*, more than the 40 kB"):
        nlid.load(tmp_path / "x.csv")
    pytest.importorskip("pyarrow")
    pd.DataFrame(data).to_parquet(tmp_path / "x.parquet")
    monkeypatch.setattr(filetables, "memory_limit", lambda: 4_000)
    with pytest.raises(DataError, match=r"column 't' in .*x.parquet declares 1 000 rows \(8 kB\), more than the 4 kB"):
        nlid.load(tmp_path / "x.parquet")
    monkeypatch.undo()
    assert nlid.load(tmp_path / "x.parquet").n == N  # read column by column


# ============================================================================ B: nlid bench as hardened as identify
PROBE = """
[benchmark]
name = "probe"
title = "a benchmark of one's own"
citation = "nlid test suite"
dataset = "probe"
official = false
protocol = "nlid tests"
unit = "mm"
scale = 1000.0
fs = 1024.0

[estimation]
description = "6 s of the single-well case"

[estimation.file]
names = ["est.csv"]
columns = "f=f, z=z"

[[tests]]
name = "independent"
rule = "window:20"
description = "2 s of another force"

[tests.file]
names = ["test.csv"]
columns = "f=f, z=z"

[pipelines]
terms = "z^3"
declared = "1, z, v"
mass = 0.2
"""


@pytest.fixture(scope="module")
def probe(tmp_path_factory):
    """A benchmark file of one's own (``probe.toml``), its estimation and test CSVs, and hostile test files."""
    from nlid.discovery.cases import build_case

    folder = tmp_path_factory.mktemp("probe")
    preset, _ = build_case("single", "cubic-stiffness")
    write_csv(preset.with_overrides(duration=6.0).simulate(1, noise=0.01, channels=("z",)), folder / "est.csv")
    test = preset.with_overrides(duration=2.0).simulate(2, noise=0.01, channels=("z",))
    write_csv(test, folder / "test.csv")
    (folder / "probe.toml").write_text(PROBE)
    frame = pd.read_csv(folder / "test.csv")
    frame.iloc[:100].to_csv(folder / "short.csv", index=False)
    nan = frame.copy()
    nan.loc[5, "z"] = np.nan
    nan.to_csv(folder / "nan.csv", index=False)
    huge = frame.copy()
    huge["f"] = huge["f"] * 1e300
    huge.to_csv(folder / "huge.csv", index=False)
    return folder


def _bench(probe: Path, test: str, out: str, *extra: str) -> list[str]:
    return [
        "bench",
        "--benchmark",
        str(probe / "probe.toml"),
        "--pipeline",
        "rfs",
        "--jobs",
        "1",
        "--test-file",
        f"probe:estimation={probe / 'est.csv'}",
        "--test-file",
        f"probe:independent={probe / test}",
        "--out",
        out,
        *extra,
    ]


def test_b_a_benchmark_file_of_ones_own_ends_with_its_leaderboard_in_text_mode(probe, tmp_path):
    """The protocols are kept by the name the rows carry, not reloaded by that name (it is not a built-in)."""
    status, out, err = _run(_bench(probe, "test.csv", str(tmp_path / "o"), "--no-progress"))
    assert status == 0, err[-2000:]
    assert "Benchmark `probe`" in out and "**nlid** `rfs`" in out, out
    assert "unknown benchmark" not in err and "Traceback" not in err


@pytest.mark.parametrize("flag", ["--benchmark", "--pipeline"])
@pytest.mark.parametrize("value", ["", ",", " , "])
def test_b_an_empty_list_of_benchmarks_or_pipelines_is_refused(flag, value, tmp_path):
    """Not silently the three default benchmarks (or the default pipelines)."""
    _refused(["bench", flag, value, "--out", str(tmp_path / "o")], f"{flag} names nothing")
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("value", ["-1", "0", "nan"])
def test_b_a_bad_time_limit_is_refused_before_the_output_folder_is_made(probe, tmp_path, value):
    _refused([*_bench(probe, "test.csv", str(tmp_path / "o")), f"--timeout={value}"], "--timeout must be a number")
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize(
    "name, fragment",
    [
        ("short.csv", "probe test set 'independent': record too short for a filtered force balance: 100 samples"),
        ("nan.csv", "channel 'z' has a non-finite value (nan) at index 5"),
        ("huge.csv", "its f reaches 7.33e+301 N: the sum of its squares overflows a float64"),
    ],
)
def test_b_a_test_file_that_no_job_could_use_is_refused_before_any_job_runs(probe, tmp_path, name, fragment):
    _refused(_bench(probe, name, str(tmp_path / "o")), fragment)
    assert not (tmp_path / "o").exists()  # no job ran, no folder was made


def test_b_a_test_file_shorter_than_the_benchmark_declares_or_its_rule_needs_is_refused(probe, tmp_path):
    from nlid.benchmarking import parse_protocol
    from nlid.benchmarking.data import check_user_files

    declared = parse_protocol(PROBE.replace('rule = "window:20"', 'rule = "window:20"\nsamples = 4096'))
    with pytest.raises(DataError, match="2048 samples, the benchmark declares 4096"):
        check_user_files({"probe": declared}, {"probe:independent": str(probe / "test.csv")})
    window = parse_protocol(PROBE.replace('rule = "window:20"', 'rule = "window:2047"'))
    with pytest.raises(DataError, match="2048 samples, too few to score after its initialisation window of 2047"):
        check_user_files({"probe": window}, {"probe:independent": str(probe / "test.csv")})
    periodic = parse_protocol(PROBE.replace('rule = "window:20"', 'rule = "periodic:4096"'))
    with pytest.raises(DataError, match="2048 samples, less than the period of 4096 samples"):
        check_user_files({"probe": periodic}, {"probe:independent": str(probe / "test.csv")})


@pytest.fixture
def docs(tmp_path):
    """A copy of the docs pages the benchmark blocks are generated into, with their data."""
    import shutil

    folder = tmp_path / "docs"
    shutil.copytree(ROOT / "docs" / "_data", folder / "_data")
    for page in ("results.md", "discover.md", "data.md"):
        shutil.copy(ROOT / "docs" / page, folder / page)
    shutil.copy(ROOT / "README.md", tmp_path / "README.md")  # the results block of the README (--docs DIR/..)
    return folder


@pytest.mark.parametrize(
    "text, fragment",
    [
        ("{", "bench.json: not JSON"),
        ('{"benchmarks": ["bouc-wen"], "jobs": [1]}', "not the bench.json of an nlid bench run (AttributeError"),
        ('{"benchmarks": ["bouc-wen"], "run": ' + "[" * 900 + "]" * 900 + "}", "not the bench.json of an nlid"),
        ('{"benchmarks": ["bouc-wen"], "run": ' + "[" * 100_000 + "]" * 100_000 + "}", "nested too deeply"),
        ("[1]", "no list of benchmarks"),
        ('{"benchmarks": ["bouc-wen"], "run": {"load_average": ["a", "b"]}}', "not the bench.json of an nlid"),
    ],
    ids=_short,
)
def test_b_render_docs_checks_the_folder_before_replacing_anything(docs, tmp_path, text, fragment):
    bad = tmp_path / "bad"
    bad.mkdir()
    (bad / "leaderboard.csv").write_bytes((docs / "_data" / "leaderboard.csv").read_bytes())
    (bad / "bench.json").write_text(text)
    before = {p.name: p.read_bytes() for p in (docs / "_data").iterdir()}
    pages = {p: (docs / p).read_bytes() for p in ("results.md", "discover.md")}
    _refused(["bench", "--render-docs", "--from", str(bad), "--docs", str(docs)], fragment)
    assert {p.name: p.read_bytes() for p in (docs / "_data").iterdir()} == before
    assert {p: (docs / p).read_bytes() for p in pages} == pages


def test_b_render_docs_from_the_docs_own_data_regenerates_the_same_pages(docs):
    pages = {p: (docs / p).read_text() for p in ("results.md", "discover.md", "data.md", "../README.md")}
    status, _, err = _run(["bench", "--render-docs", "--from", str(docs / "_data"), "--docs", str(docs)])
    assert status == 0, err
    assert {p: (docs / p).read_text() for p in pages} == pages


def test_b_a_benchmark_file_names_only_a_loader_of_the_package_never_other_code(monkeypatch, tmp_path):
    """``package.function`` is an allow-list of the package's loaders, looked up by name in its module.

    A stub package exposing ``os`` showed that a walk of attributes could call ``os.abort``.
    """
    import types

    from nlid.benchmarking import data as bench_data
    from nlid.benchmarking import parse_protocol
    from nlid.benchmarking.protocol import PACKAGE_FUNCTIONS

    called = []
    stub = types.ModuleType("nonlinear_benchmarks")
    stub.os = types.SimpleNamespace(abort=lambda: called.append("abort"))
    stub.Silverbox = print  # a builtin, not a function of the package: refused, never called
    monkeypatch.setitem(sys.modules, "nonlinear_benchmarks", stub)
    base = PROBE.replace("fs = 1024.0\n", 'fs = 1024.0\n\n[benchmark.package]\nfunction = "{}"\n')
    for name in ("os.abort", "os", "__class__", "Silverbox.__call__", "not_splitted_benchmarks.os.abort"):
        with pytest.raises(InputError, match="must name one of the nonlinear-benchmarks package's loaders"):
            parse_protocol(base.replace("{}", name))
        with pytest.raises(DataError, match="is not a loader of the nonlinear-benchmarks package nlid knows"):
            bench_data._package_function(name)
    assert "EMPS" in PACKAGE_FUNCTIONS and "not_splitted_benchmarks.BoucWen" in PACKAGE_FUNCTIONS
    assert parse_protocol(base.replace("{}", "Silverbox")).package_function == "Silverbox"
    with pytest.raises(DataError, match="nonlinear_benchmarks.Silverbox is not a function"):
        bench_data._package_function("Silverbox")
    assert not called


# ============================================================================ C: nlid compare and the CLI's odd ends
@pytest.fixture(scope="module")
def structure_csv(tmp_path_factory):
    """8 s of the 3dof-cubic structure (its truth in the sidecar), as nlid simulate writes it."""
    from nlid.simulation.presets import get_preset

    folder = tmp_path_factory.mktemp("structure")
    record = get_preset("3dof-cubic").with_overrides(duration=8.0).simulate(0)
    return write_csv(record, folder / "s3.csv")


def test_c_compare_accepts_a_structure(structure_csv):
    """Elements on connections, the linear modes and each DOF's residual, against the structure's truth."""
    status, out, err = _run(["compare", str(structure_csv), "--terms", "z3^3", "--methods", "rfs", "--json"])
    assert status == 0, err
    rows = {(r["quantity"], r["name"]): r for r in json.loads(out)}
    coef = rows[("coefficient", "z3^3")]
    assert coef["method"] == "rfs" and coef["unit"] == "N/m^3" and coef["reference"] == 5e9
    assert abs(coef["error_pct"]) < 5, coef
    assert {("fn_hz", "m1"), ("zeta", "m3"), ("eps_percent", "z2"), ("seconds", "identification")} <= set(rows)
    assert abs(rows[("fn_hz", "m1")]["error_pct"]) < 1
    frame = nlid.compare(nlid.load(structure_csv), "z3^3", ["rfs"], reference={"z3^3": 4e9})
    assert frame.set_index("name").loc["z3^3", "reference"] == 4e9


@pytest.mark.parametrize(
    "extra, fragment",
    [
        (["--terms", "z^3"], "name the degree of freedom: write z1, v2 or a difference"),
        (["--terms", "z9^3"], "DOF"),
        (["--terms", "z3^3", "--holdout", "0.25"], "--holdout, --rule and --px-roots do not apply to a structure"),
        (["--terms", "z3^3", "--px-roots=-0.1,0.1"], "do not apply to a structure of several DOFs"),
    ],
)
def test_c_compare_refuses_a_structure_s_bad_elements_before_running(structure_csv, extra, fragment):
    _refused(["compare", str(structure_csv), *extra, "--methods", "rfs"], fragment)


@pytest.mark.parametrize(
    "text, fragment",
    [
        ('{"z^3": NaN}', "reference coefficient 'z^3' must be a finite number, got nan"),
        # was an internal error (LinAlgError) when the reference's equilibria were solved
        ('{"coefficients": {"z^3": 1e6, "z": NaN}, "mass": 0.2}', "reference coefficient 'z' must be a finite number"),
        ('{"coefficients": {"z^3": 1e6}, "mass": NaN}', "reference mass must be a finite number of kg, got nan"),
        ('{"mass": 1e400}', "must be a finite number of kg, got inf"),
        ('{"equilibria": [NaN]}', "reference equilibria must be a list of finite numbers, got nan"),
        ('{"modal": [{"fn_hz": "fast", "zeta": 0.1}]}', "reference modes' fn_hz must be a number, got 'fast'"),
        ('{"z^3": true}', "reference coefficient 'z^3' must be a number, got True"),
        ('{"terms": [[1]]}', "reference terms must be a list of terms"),
        ('{"z^3": ' + "[" * 900 + "]" * 900 + "}", "(1 800 characters)"),
        ('{"coefficients": ' + "[" * 900 + "]" * 900 + "}", "reference coefficients must map term names"),
        ("[" * 100_000 + "]" * 100_000, "nested too deeply"),
    ],
    ids=_short,
)
def test_c_a_reference_with_a_nan_or_nested_deeply_is_one_line(tmp_path, short_record, text, fragment, monkeypatch):
    monkeypatch.chdir(tmp_path)
    write_csv(short_record, "x.csv")
    Path("r.json").write_text(text)
    _refused(
        ["compare", "x.csv", "--terms", "z^3", "--mass", "0.2", "--methods", "rfs", "--reference", "r.json"], fragment
    )


@pytest.mark.parametrize(
    "setting, fragment",
    [
        ("rfs.cutoff=abc", "rfs: option 'cutoff' expects a number or 'auto', got 'abc'"),
        ("rfs.decimate=0", "decimate"),
        ("rfs.nope=1", "unknown option 'nope'"),
    ],
)
def test_c_compare_refuses_bad_option_values_before_running(tmp_path, short_record, setting, fragment, monkeypatch):
    monkeypatch.chdir(tmp_path)
    write_csv(short_record, "x.csv")
    _refused(
        ["compare", "x.csv", "--terms", "z^3", "--mass", "0.2", "--methods", "rfs,sindy", "--set", setting], fragment
    )
    with pytest.raises(InputError, match=fragment.split(":")[-1].strip()[:20].replace("(", r"\(")):
        nlid.compare(short_record, "z^3", ["rfs"], mass=0.2, options={"rfs": dict([setting[4:].split("=")])})


def test_c_methods_refuses_an_unknown_name_with_json_too():
    _refused(["methods", "nope", "--json"], "unknown method 'nope'")
    status, out, _ = _run(["methods", "rfs", "--json"])
    assert status == 0 and list(json.loads(out)["methods"]) == ["rfs"]


def test_c_units_of_a_structure_s_dofs_are_accepted_on_the_command_line(structure_csv):
    """``--units z2=um`` as the column map (``z2[um]=z2``) and the API already accept it."""
    from nlid.cli.common import load_data

    args = dict(data=str(structure_csv), columns=None, fs=None, force_hold=None)
    converted = load_data(__import__("argparse").Namespace(**args, units="z2=um"))
    plain = nlid.load(structure_csv)
    np.testing.assert_allclose(converted.z[:, 1], plain.z[:, 1] * 1e-6)
    np.testing.assert_array_equal(converted.z[:, 0], plain.z[:, 0])
    mapped = nlid.load(structure_csv, columns="f1=f1, z1=z1, z2[um]=z2, z3=z3")
    np.testing.assert_array_equal(converted.z, mapped.z)
    _refused(["identify", str(structure_csv), "--terms", "z3^3", "--units", "z2=kg"], "unknown unit 'kg'")


def test_c_mat_v5_logical_arrays_are_refused_as_every_format_s_booleans(tmp_path):
    data = _signals()
    sio.savemat(tmp_path / "b.mat", {**data, "flag": data["f"] > 0})
    with pytest.raises(DataError, match="column 'flag' in .*b.mat holds booleans"):
        nlid.load(tmp_path / "b.mat", columns="t=t, f=flag, z=z")
    _refused(["identify", str(tmp_path / "b.mat"), "--terms", "z^3", "--columns", "f=flag"], "holds booleans")


def test_c_identify_without_none_removes_nothing(short_record):
    fit = nlid.identify(short_record, "z^3", "rfs", mass=0.2, without=None)
    assert fit.terms == nlid.identify(short_record, "z^3", "rfs", mass=0.2).terms == ("1", "z", "z^3", "v")
    frame = nlid.compare(short_record, "z^3", ["rfs"], mass=0.2, without=None)
    assert "failed" not in set(frame["quantity"])


# ============================================================================ D: the model file format and replay
@pytest.fixture(scope="module")
def model_dict():
    record = nlid.simulate("paper-numerical", seed=3, duration=4.0)
    return nlid.identify(record, "z^3, z^2, v*|v|", "rfs", mass=0.2).to_dict()


def _deep(levels: int) -> list:
    return json.loads("[" * levels + "]" * levels)


@pytest.mark.parametrize(
    "field, value, fragment",
    [
        ("coefficients", "abc", "model JSON: coefficients: must be an object of finite numbers, got 'abc'"),
        ("equilibria", "none", "model JSON: equilibria: must be {stable, unstable} or null, got 'none'"),
        ("standard_errors", {"z": "x"}, "model JSON: standard_errors.z: must be a number or null, got 'x'"),
        ("provenance", "abc", "model JSON: provenance: must be a provenance object or null, got 'abc'"),
        ("provenance", _deep(900), "model JSON: provenance[0][0][0]...: nested deeper than 32 levels"),
        ("method", 42, "model JSON: method: must be a string, got 42"),
        ("mass", -0.2, "model JSON: mass: must be a positive number or null, got -0.2"),
        ("modal", [1], "model JSON: modal[0]: must be {equilibrium, fn_hz, zeta, ...}, got 1"),
        ("scores", {"samples": "many"}, "model JSON: scores.samples: must be a whole number or null"),
        ("z_range", [0.1], "model JSON: z_range: must be two finite numbers or null, got a list of 1"),
        ("diagnostics", {"x": {1, 2}}, "model JSON: diagnostics.x: set is not a JSON value"),
        ("coeficients", {}, "model JSON: coeficients: not a field of this layout (did you mean 'coefficients'?)"),
    ],
)
def test_d_from_dict_checks_every_field_and_names_the_first_misfit(model_dict, field, value, fragment):
    data = json.loads(json.dumps(model_dict))
    data[field] = value
    with pytest.raises(InputError) as info:
        nlid.IdentifiedModel.from_dict(data)
    assert fragment in str(info.value) and "\n" not in str(info.value), str(info.value)


def test_d_version_1_is_today_s_layout_and_reads_back(model_dict):
    from nlid.identified.fileformat import MODEL_FIELDS

    assert model_dict["schema"] == "nlid.IdentifiedModel/1"
    assert set(model_dict) <= {f.name for f in MODEL_FIELDS}  # every field to_dict writes is declared
    again = nlid.IdentifiedModel.from_dict(json.loads(json.dumps(model_dict)))
    assert again.to_dict() == model_dict
    bare = {k: v for k, v in model_dict.items() if k != "schema"}  # no "schema": read as version 1
    assert nlid.IdentifiedModel.from_dict(bare).coefficients == again.coefficients
    with pytest.raises(InputError, match="unknown identified-model layout 'nlid.IdentifiedModel/2'"):
        nlid.IdentifiedModel.from_dict({**model_dict, "schema": "nlid.IdentifiedModel/2"})


def test_d_a_structure_s_json_is_checked_against_its_schema(structure_csv):
    from nlid.identified.fileformat import STRUCTURE_FIELDS
    from nlid.identified.structure import IdentifiedStructure

    fit = nlid.identify(nlid.load(structure_csv), "z3^3", "rfs")
    data = json.loads(json.dumps(fit.to_dict()))
    assert set(data) <= {f.name for f in STRUCTURE_FIELDS}
    assert IdentifiedStructure.from_dict(data).to_dict() == fit.to_dict()
    for field, value, fragment in [
        ("method", 42, "model JSON: method: must be a string, got 42"),
        ("eps_percent", "low", "model JSON: eps_percent: must be a list or null"),
        ("structure", {**data["structure"], "M": [["a"]]}, "model JSON: structure.M[0][0]: must be a finite number"),
        ("provenance", _deep(900), "nested deeper than 32 levels"),
    ]:
        with pytest.raises(InputError, match=fragment.replace("(", r"\(").replace("[", r"\[")):
            IdentifiedStructure.from_dict({**data, field: value})


def test_d_compare_reference_with_a_damaged_model_json_is_one_line(tmp_path, short_record, model_dict, monkeypatch):
    monkeypatch.chdir(tmp_path)
    write_csv(short_record, "x.csv")
    Path("m.json").write_text(json.dumps({**model_dict, "provenance": _deep(900)}))
    argv = ["compare", "x.csv", "--terms", "z^3", "--mass", "0.2", "--methods", "rfs", "--reference", "m.json"]
    _refused(argv, "model JSON: provenance[0][0][0]...: nested deeper than 32 levels")


def test_d_identify_again_turns_every_bad_provenance_into_one_error(fit_json, monkeypatch):
    from nlid.identification.replay import identify_again

    monkeypatch.chdir(fit_json.parent)
    good = json.loads(fit_json.read_text())["provenance"]
    assert (
        identify_again(good).coefficients
        == nlid.IdentifiedModel.from_dict(json.loads(fit_json.read_text())).coefficients
    )
    Path("folder").mkdir()

    def changed(part: str, key: str, value) -> dict:
        out = json.loads(json.dumps(good))
        out[part][key] = value
        return out

    cases = [
        (changed("data", "source", "missing.csv"), DataError, "file not found: missing.csv"),
        (changed("data", "source", "folder"), DataError, "folder is a folder, not a data file"),
        (changed("data", "units", "mm"), InputError, "provenance.data.units: must be an object of units, got 'mm'"),
        (changed("data", "units", ["mm"]), InputError, "provenance.data.units: must be an object of units"),
        (changed("identify", "px_tol", "abc"), InputError, "provenance.identify.px_tol: must be a positive number"),
        (changed("identify", "terms", "z^3"), InputError, "provenance.identify.terms: must be a list of strings"),
        (None, InputError, "the provenance lacks its 'data' or 'identify' part"),
        ("abc", InputError, "the provenance lacks its 'data' or 'identify' part"),
        (changed("data", "source", "dataset:nope"), InputError, "unknown dataset 'nope'"),
    ]
    for provenance, kind, fragment in cases:
        with pytest.raises(kind) as info:
            identify_again(provenance)
        assert fragment in str(info.value), (fragment, str(info.value))
    # a bundled dataset is loaded as such even when the provenance says its hash is a file's (no open("dataset:..."))
    monkeypatch.delenv("NLID_DATA_DIR", raising=False)
    bundled = changed("data", "source", "dataset:emps")
    with pytest.raises(DataError, match="set NLID_DATA_DIR"):
        identify_again(bundled)


def test_d_the_docs_write_down_every_field_of_the_schema():
    import re

    from nlid.identified.fileformat import MODEL_FIELDS, PROVENANCE_FIELDS, STRUCTURE_FIELDS, Obj

    page = (ROOT / "docs" / "model-json.md").read_text()
    names = []
    todo = [f for f in (*MODEL_FIELDS, *STRUCTURE_FIELDS, *PROVENANCE_FIELDS) if f.name != "scores"]
    while todo:
        field = todo.pop()
        names.append(field.name)
        kind = getattr(field.kind, "kind", field.kind)  # inside a Nullable
        kind = getattr(kind, "item", kind)  # inside a list or a map
        if isinstance(kind, Obj):
            todo += list(kind.fields)
    missing = sorted({n for n in names if not re.search(rf"`[^`]*\b{re.escape(n)}\b[^`]*`", page)})
    assert not missing, f"fields of nlid.identified.fileformat not in docs/model-json.md: {missing}"
    assert "nlid.IdentifiedModel/1" in page and "nlid.IdentifiedStructure/1" in page


# ============================================================================ E: signals, crashes and symlinks
R3_PLUGINS = """
import os
import signal
import time
from pathlib import Path

from nlid.plugin import Estimate, Identifier, hookimpl

TRUTH = {"1": 1.962, "z": -500.0, "z^2": 5000.0, "z^3": 1e6, "v": 1.0, "v*|v|": 5.0}


class Sleepy(Identifier):
    name = "r3-sleepy"
    summary = "sleeps NLID_R3_SLEEP seconds, then returns the truth (test plugin)"

    def identify(self, record, model, *, mass=None):
        time.sleep(float(os.environ.get("NLID_R3_SLEEP", "0")))
        return Estimate(coefficients={n: TRUTH.get(n, 0.0) for n in model.names})


class KillServer(Identifier):
    name = "r3-kill-server"
    summary = "kills its fork server while the count in NLID_R3_KILLS lasts, then returns the truth (test plugin)"

    def identify(self, record, model, *, mass=None):
        path = Path(os.environ["NLID_R3_KILLS"])
        left = int(path.read_text())
        if left > 0:
            path.write_text(str(left - 1))
            os.kill(os.getppid(), signal.SIGKILL)  # its fork server (the OOM killer's doing)
            time.sleep(60)
        return Estimate(coefficients={n: TRUTH.get(n, 0.0) for n in model.names})


@hookimpl
def nlid_identifiers():
    return [Sleepy, KillServer]
"""

STUDY = """
[study]
name = "r3"
seed = 7
repetitions = {repetitions}
timeout = 120
identifiers = [{identifiers}]

[[datasets]]
name = "short"
preset = "paper-numerical"
overrides = {{ duration = 2 }}
channels = ["z", "v", "a"]
terms = "z^3, z^2, v*|v|"
mass = "known"
holdout = "none"
"""


@pytest.fixture(scope="module")
def r3_plugins(tmp_path_factory):
    """The E-class test plugins in a folder with their ``.dist-info`` (nothing installed), on ``sys.path``."""
    from plugin_dist import write_distribution

    from nlid.contract.registry import default_registry, registry_for

    folder = tmp_path_factory.mktemp("r3plugins")
    write_distribution(folder, "nlid-r3", {"nlid_r3_plugins": R3_PLUGINS}, {"r3": "nlid_r3_plugins"})

    def forget():
        sys.modules.pop("nlid_r3_plugins", None)
        default_registry.cache_clear()
        registry_for.cache_clear()

    with pytest.MonkeyPatch.context() as mp:
        mp.syspath_prepend(str(folder))
        forget()
        yield folder
    forget()


def _study(folder: Path, identifiers: str, repetitions: int = 1) -> Path:
    path = folder / "r3.toml"
    path.write_text(STUDY.format(identifiers=identifiers, repetitions=repetitions))
    return path


def _child_env(plugins: Path, **extra: str) -> dict[str, str]:
    env = {**os.environ, **extra}
    env["PYTHONPATH"] = os.pathsep.join([str(plugins), str(ROOT), str(ROOT / "plugins"), env.get("PYTHONPATH", "")])
    return env


def _temporary_files(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*") if ".tmp" in p.name)


def test_e_ctrl_c_on_a_running_study_prints_one_line_and_the_study_resumes(r3_plugins, tmp_path):
    """The terminal's Ctrl-C reaches the whole foreground process group: the fork server no longer is in it."""
    study = _study(tmp_path, '"r3-sleepy"', repetitions=2)
    env = _child_env(r3_plugins, NLID_R3_SLEEP="30")
    argv = [sys.executable, "-m", "nlid.cli.main", "study", "run", str(study), "--out", "out", "--jobs", "2"]
    # a terminal's foreground command hears Ctrl-C: a suite started in the background (`pytest &` in a script,
    # nohup) inherits SIGINT ignored, and so would the study without this reset
    proc = subprocess.Popen(
        argv, cwd=tmp_path, env=env, stderr=subprocess.PIPE, text=True, start_new_session=True, preexec_fn=_hear_sigint
    )
    first = proc.stderr.readline()  # the study has started: the fork server runs, the runs are on their way
    assert first.startswith("nlid study r3: 2 runs"), first
    for _ in range(300):  # the fork server and the two sleeping runs it forked
        if len(_descendants(proc.pid)) >= 3:
            break
        time.sleep(0.2)
    time.sleep(1.0)
    os.killpg(proc.pid, signal.SIGINT)  # what Ctrl-C does: SIGINT to the terminal's foreground process group
    rest = proc.stderr.read()
    proc.stderr.close()
    assert proc.wait(timeout=60) == 130
    lines = [line for line in rest.splitlines() if line.strip()]
    assert lines == ["nlid: interrupted"], rest[-3000:]
    assert _temporary_files(tmp_path / "out") == []
    done = subprocess.run(
        argv, cwd=tmp_path, env={**env, "NLID_R3_SLEEP": "0"}, capture_output=True, text=True, timeout=300
    )
    assert done.returncode == 0, done.stderr[-3000:]
    assert "0 already done, 2 to run" in done.stderr, done.stderr  # the interrupted runs were not stored as done


def _hear_sigint() -> None:
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _descendants(pid: int) -> list[int]:
    from nlid.runtime.process import descendants_of

    return descendants_of(pid)


_INTERRUPT_BETWEEN_WRITE_AND_RENAME = """
import os, signal, sys
real = os.replace
def replace(src, dst, *args, **kwargs):
    if ".tmp" in str(src) and "runs" in str(src) and os.environ.get("NLID_R3_SIGNAL"):
        os.kill(os.getpid(), getattr(signal, os.environ.pop("NLID_R3_SIGNAL")))  # written, not yet renamed
    return real(src, dst, *args, **kwargs)
os.replace = replace
from nlid.cli.main import main
sys.exit(main(sys.argv[1:]))
"""


@pytest.mark.parametrize("sig", ["SIGTERM", "SIGKILL"])
def test_e_a_signal_between_write_and_rename_leaves_no_temporary_file_after_the_next_run(r3_plugins, tmp_path, sig):
    """SIGTERM: the temporary file is removed at once; SIGKILL (no handler can run): the next run sweeps it."""
    study = _study(tmp_path, '"r3-sleepy"', repetitions=2)
    env = _child_env(r3_plugins, NLID_R3_SIGNAL=sig)
    argv = [sys.executable, "-c", _INTERRUPT_BETWEEN_WRITE_AND_RENAME, "study", "run", str(study), "--out", "out"]
    first = subprocess.run([*argv, "--jobs", "1"], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)
    assert first.returncode == (130 if sig == "SIGTERM" else -signal.SIGKILL), first.stderr[-3000:]
    if sig == "SIGTERM":
        assert "Traceback" not in first.stderr and first.stderr.rstrip().endswith("nlid: interrupted"), first.stderr
        assert _temporary_files(tmp_path / "out") == []
    else:
        assert _temporary_files(tmp_path / "out"), "the kill did not land between the write and the rename"
    env.pop("NLID_R3_SIGNAL")
    again = subprocess.run([*argv, "--jobs", "1"], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)
    assert again.returncode == 0, again.stderr[-3000:]
    assert _temporary_files(tmp_path / "out") == []
    assert len(list((tmp_path / "out" / "runs").glob("*.json"))) == 2


def test_e_an_interrupted_atomic_write_removes_its_temporary_file(tmp_path, monkeypatch):
    from nlid.runtime import outputs

    path = tmp_path / "x.json"
    path.write_text("old")

    def interrupted(src, dst):
        raise KeyboardInterrupt  # nlid's SIGTERM handlers raise it

    monkeypatch.setattr(outputs.os, "replace", interrupted)
    with pytest.raises(KeyboardInterrupt):
        outputs.atomic_write(path, b"new")
    monkeypatch.undo()
    assert path.read_text() == "old" and _temporary_files(tmp_path) == []
    stale = tmp_path / f".x.json.{2**22 + 12345}.tmp"  # a process id no system hands out: its writer is gone
    stale.write_text("half")
    mine = tmp_path / "keep.tmp"
    mine.write_text("not nlid's")  # not nlid's pattern: never touched
    assert outputs.sweep_temporary(tmp_path) == [stale]
    assert mine.exists()


def kill_fork_server() -> None:
    """A target for ``run_in_child``: kill the fork server that forked this child (the OOM killer's doing)."""
    os.kill(os.getppid(), signal.SIGKILL)
    time.sleep(60)


def test_e_a_dead_fork_server_is_infrastructure_not_the_identifier_s_crash(r3_plugins, tmp_path, monkeypatch):
    """The run is tried again at once; if the server dies again, the run is not stored and a resume runs it."""
    from nlid.runtime.isolation import run_in_child
    from nlid.runtime.outcome import IsolationError

    if not sys.platform.startswith("linux"):
        pytest.skip("the fork server's children die with it on Linux (parent-death signal)")
    outcome = run_in_child(kill_fork_server, method="forkserver", timeout=60)
    assert outcome.status == "lost" and outcome.infrastructure, outcome
    assert "nlid's fork server ended while it ran" in outcome.describe("identifier 'x'")
    with pytest.raises(IsolationError, match="not the identifier's failure"):
        outcome.answer("identifier 'x'", 60, "")
    kills = tmp_path / "kills"
    monkeypatch.setenv("NLID_R3_KILLS", str(kills))
    study = _study(tmp_path, '"r3-kill-server"')
    kills.write_text("2")  # the run and its immediate retry both lose their server
    from nlid.study import LocalExecutor, load_study, run_study

    def run(log):
        config = load_study(study)
        return run_study(config, tmp_path / "out", executor=LocalExecutor(1), report=False, progress=False, log=log)

    log = io.StringIO()
    first = run(log)
    assert first.executed == 1 and not list((tmp_path / "out" / "runs").glob("*.json")), "a lost run was stored"
    assert "not saved: it runs again on resume" in log.getvalue(), log.getvalue()
    assert "crashed" not in log.getvalue()
    kills.write_text("1")  # on resume: lost once, then retried on a new server
    again = run(io.StringIO())
    assert again.executed == 1 and again.skipped == 0
    (stored,) = [json.loads(p.read_text()) for p in (tmp_path / "out" / "runs").glob("*.json")]
    assert stored["row"]["status"] == "ok", stored["row"]


def test_e_a_report_of_many_identifiers_issues_no_raw_matplotlib_warning(tmp_path):
    """A legend taller than its axes collapses constrained layout: matplotlib's default layout is kept, silently."""
    import warnings

    from nlid.report.plotting import new_figure, save_figure

    fig, ax = new_figure(width=4.0, height=3.0)
    for i in range(60):
        ax.plot([0, 1], [i, i + 1], label=f"identifier-with-a-long-name-{i}")
    ax.legend(fontsize=8)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        paths = save_figure(fig, tmp_path / "many")
    assert [p.suffix for p in paths] == [".png", ".svg"] and all(p.stat().st_size > 0 for p in paths)


def test_e_simulate_does_not_write_through_a_sidecar_that_is_a_symlink(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    Path("other.json").write_text('{"source": "precious"}')
    os.symlink("other.json", "x.csv.meta.json")
    argv = ["simulate", "--preset", "paper-numerical", "--duration", "2", "--out", "x.csv", "--force"]
    _refused(argv, "x.csv.meta.json is a symbolic link (to other.json); nlid does not write through it")
    assert Path("other.json").read_text() == '{"source": "precious"}' and not Path("x.csv").exists()


@pytest.mark.parametrize(
    "argv",
    [
        ["bench", "--benchmark", "bouc-wen", "--out", "link"],
        ["study", "run", "paper-numerical", "--out", "link"],
        ["simulate", "--preset", "paper-numerical", "--duration", "2", "--out", "link.csv"],
        ["compare", "x.csv", "--terms", "z^3", "--mass", "0.2", "--methods", "rfs", "--out", "link.csv"],
    ],
)
def test_e_a_dangling_out_symlink_is_refused_and_its_target_never_created(tmp_path, short_record, monkeypatch, argv):
    monkeypatch.chdir(tmp_path)
    write_csv(short_record, "x.csv")
    name = argv[argv.index("--out") + 1]
    os.symlink(tmp_path / "elsewhere" / "target", name)
    _refused(argv, f"{name} is a symbolic link to {tmp_path / 'elsewhere' / 'target'}, which does not exist")
    assert not (tmp_path / "elsewhere").exists()


def test_e_the_parquet_floor_excludes_the_versions_with_cve_2023_47248():
    try:
        import tomllib
    except ModuleNotFoundError:  # Python 3.10
        import tomli as tomllib
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    specs = [*project["optional-dependencies"]["parquet"], *project["optional-dependencies"]["test"]]
    floors = [s for s in specs if s.startswith("pyarrow")]
    assert floors and all(s == "pyarrow>=14.0.1" for s in floors), floors


@pytest.mark.parametrize("command", [["study", "run"], ["bench"]])
def test_e_the_scheduler_help_says_an_untrusted_scheduler_gets_code_execution(command, capsys):
    with pytest.raises(SystemExit):
        main([*command, "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "a scheduler you do not trust gets code execution on this machine" in text
