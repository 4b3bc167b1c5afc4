"""Hostile inputs at the command line (issue 18): one line and the right exit status, never a traceback.

Each case is ``(argv, status, fragment)``: ``nlid ARGV`` must exit with
``status`` (2: bad input, 1: a result that cannot be trusted) and print
exactly one line on stderr, starting ``nlid `` and containing ``fragment``,
and nothing that looks like a traceback or a raw numpy warning. Cases are
grouped by the classes of issue 18 (``G1``..``G6``); every group of the
issue is also covered by the dedicated tests named in each section.

The files the cases read are written once per module into a temporary
folder (the cases run there); ``{ro}`` stands for a path that cannot be
written (a file used as a folder).
"""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from plugin_dist import write_distribution
from scipy import io as sio

from nlid.cli.main import main
from nlid.contract.registry import default_registry, registry_for
from nlid.simulation.presets import get_preset

TERMS = "z^3,z^2,v*|v|"
NESTED = "(" * 500 + "z" + ")" * 500
PRODUCT = "*".join(["z"] * 50001)
SIMULATE_SET = ["simulate", "--preset", "paper-numerical", "--set"]
DISCOVER_X = ["discover", "x.csv", "--declared", "1,z,v", "--mass", "0.2"]

HOSTILE_PLUGINS = '''
import os
import signal
import sys
import time

from nlid.plugin import Estimate, Identifier, hookimpl


class ExitIdentify(Identifier):
    name = "exit-identify"
    summary = "calls sys.exit(4) in identify (test plugin)"

    def identify(self, record, model, *, mass=None):
        sys.exit(4)


class Hang(Identifier):
    name = "hang-forever"
    summary = "never returns (test plugin)"

    def identify(self, record, model, *, mass=None):
        while True:
            time.sleep(0.2)


class Segv(Identifier):
    name = "segv"
    summary = "crashes its own process (test plugin)"

    def identify(self, record, model, *, mass=None):
        os.kill(os.getpid(), signal.SIGSEGV)


class Warns(Identifier):
    name = "warns"
    summary = "overflows internally but returns finite numbers (test plugin)"

    def identify(self, record, model, *, mass=None):
        import numpy as np

        np.float64(1e308) * np.float64(10.0)
        return Estimate(coefficients={n: 1.0 for n in model.names})


class NanError(Identifier):
    name = "nan-se"
    summary = "returns a NaN standard error (test plugin)"

    def identify(self, record, model, *, mass=None):
        return Estimate(
            coefficients={n: 1.0 for n in model.names}, standard_errors={n: float("nan") for n in model.names}
        )


@hookimpl
def nlid_identifiers():
    return [ExitIdentify, Hang, Segv, Warns, NanError]
'''


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """A folder with good and hostile data files, study files and hostile plugins (on sys.path)."""
    d = tmp_path_factory.mktemp("hostile")
    record = get_preset("paper-numerical").with_overrides(duration=4.0).simulate(0, channels=("z", "v", "a"))
    frame = pd.DataFrame({"t": record.t, "f": record.f, "z": record.z, "v": record.v, "a": record.a})
    frame.to_csv(d / "x.csv", index=False)
    noisy = get_preset("paper-numerical").with_overrides(duration=4.0).simulate(0, noise=0.02, channels=("z", "a"))
    pd.DataFrame({"t": noisy.t, "f": noisy.f, "z": noisy.z, "a": noisy.a}).to_csv(d / "n.csv", index=False)
    big = frame.copy()
    big["f"] *= 1e298
    big.to_csv(d / "big.csv", index=False)
    t, f, z = record.t, record.f, record.z
    np.savez(d / "cplx.npz", t=t, f=f + 1j, z=z)
    np.savez(d / "strs.npz", t=t, f=np.array(["a"] * t.size), z=z)
    np.savez(d / "two.npz", t=t, f=f, z=np.vstack([z, z]).T)
    np.savez(d / "fstr.npz", f=f, z=z, fs=np.array("fast"))
    np.save(d / "obj.npy", np.array([{"a": 1}], dtype=object), allow_pickle=True)
    (d / "obj.npz").write_bytes(b"")  # replaced below by a real archive holding an object array
    import zipfile

    with zipfile.ZipFile(d / "obj.npz", "w") as zf:
        zf.write(d / "obj.npy", "f.npy")
        np.save(d / "z.npy", z)
        zf.write(d / "z.npy", "z.npy")
    sio.savemat(d / "cell.mat", {"t": t, "f": f, "z": z, "k": np.array(["abc"], dtype=object)})
    sio.savemat(d / "str.mat", {"t": t, "f": f, "z": z, "k": "abc"})
    sio.savemat(d / "struct.mat", {"t": t, "f": f, "z": {"a": z}})
    sio.savemat(d / "cplx.mat", {"t": t, "f": f, "z": z + 1j})
    bad = frame.copy()
    bad.loc[100, "z"] = np.nan
    bad.to_csv(d / "nan.csv", index=False)
    bad = frame.copy()
    bad.loc[7, "f"] = np.inf
    bad.to_csv(d / "inf.csv", index=False)
    word = frame.head(50).astype(object)
    word.loc[20, "z"] = "five"
    word.to_csv(d / "word.csv", index=False)
    (d / "empty.csv").write_text("")
    (d / "header.csv").write_text("t,f,z\n")
    frame.head(10).to_csv(d / "short.csv", index=False)
    jitter = frame.copy()
    jitter.loc[50:, "t"] += 0.01
    jitter.to_csv(d / "jitter.csv", index=False)
    flat = frame.copy()
    flat["z"] = 1.0
    flat.to_csv(d / "flat.csv", index=False)
    (d / "latin1.csv").write_bytes("t,f,z,é\n".encode("latin-1") + b"0,1,2,3\n")
    (d / "garbage.csv").write_bytes(bytes(range(256)) * 4)
    (d / "garbage.npz").write_bytes(b"PK\x03\x04 not really a zip")
    (d / "garbage.mat").write_bytes(b"MATLAB 5.0 MAT-file, garbage" + bytes(200))
    (d / "data.xyz").write_text("t,f,z\n0,1,2\n")
    (d / "folder.csv").mkdir()
    (d / "afile").write_text("not a folder")
    (d / "user").mkdir()
    for name in ("results.csv", "summary.md", "report.html", "study.toml", "posterior.json", "report.md"):
        (d / "user" / name).write_text("the user's own file\n")
    (d / "existing.csv").write_text("the user's own file\n")
    (d / "mine.csv.meta.json").write_text('{"my": "notes"}\n')
    (d / "notutf8.toml").write_bytes("[study]\ndescription = 'caf\xe9'\n".encode("latin-1"))
    (d / "bad.toml").write_text("[[datasets]\n")
    (d / "x0.toml").write_text("[[datasets]]\npreset = 'paper-numerical'\noverrides = { x0 = [1e300, 0] }\n")
    (d / "columns.toml").write_text("[[datasets]]\nfile = 'x.csv'\ncolumns = 'q=x'\n")
    (d / "prior.toml").write_text(
        "[posterior]\npriors = { 'z^3' = 'normal(0, 1)' }\n[[datasets]]\npreset = 'paper-numerical'\n"
    )
    (d / "tiny.toml").write_text(
        "[study]\nidentifiers = ['rfs']\n[[datasets]]\npreset = 'paper-numerical'\noverrides = { duration = 2 }\n"
    )
    (d / "dir.toml").mkdir()
    (d / "deep.toml").write_text("x = " + "[" * 5000 + "]" * 5000 + "\n")
    frame.to_csv(d / "deep.csv", index=False)
    (d / "deep.csv.meta.json").write_text("[" * 100000 + "]" * 100000)
    plugins = d / "plugins"
    plugins.mkdir()
    write_distribution(
        plugins,
        "nlid-hostile",
        {"nlid_hostile_plugins": HOSTILE_PLUGINS, "nlid_exit_at_import": "import sys\nsys.exit(3)\n"},
        {"hostile": "nlid_hostile_plugins", "exit-at-import": "nlid_exit_at_import"},
    )
    with pytest.MonkeyPatch.context() as mp:
        mp.syspath_prepend(str(plugins))
        default_registry.cache_clear()
        registry_for.cache_clear()
        yield d
    default_registry.cache_clear()
    registry_for.cache_clear()


# --------------------------------------------------------------------------- the cases
G1_UNTRUSTED = [  # results that cannot be trusted exit 1 with one line saying what
    (["identify", "big.csv", "--terms", TERMS, "--mass", "0.2"], 1, "cannot be trusted: standard errors of"),
    (["identify", "big.csv", "--terms", TERMS, "--mass", "0.2", "--json"], 1, "epsilon and the force residual"),
    (["identify", "big.csv", "--terms", TERMS, "--mass", "0.2"], 1, "badly scaled"),
    (["identify", "x.csv", "--method", "nan-se", "--terms", TERMS, "--mass", "0.2"], 1, "standard errors of 1, z"),
    (["posterior", "n.csv", "--terms", TERMS, "--mass", "0.2", "--prior", "v=normal(100,0.001)",
      "--no-bias-correction"], 1, "prior in conflict with the data: the prior of v"),
    (["posterior", "n.csv", "--terms", TERMS, "--mass", "0.2", "--prior", "v*|v|=uniform(4.9,5.1)",
      "--prior", "v=normal(-50,0.01)", "--no-bias-correction"], 1, "prior in conflict"),
]

G2_CONFIG = [  # study configs refused before any run, naming file, table and key
    (["study", "run", "x0.toml"], 2, "x0.toml: datasets[0].overrides: the first"),
    (["study", "run", "columns.toml"], 2, "columns.toml: datasets[0].columns: column map"),
    (["study", "run", "prior.toml"], 2, "prior.toml: posterior.priors: a prior is given for z^3"),
    (["study", "run", "notutf8.toml"], 2, "not UTF-8"),
    (["study", "run", "bad.toml"], 2, "not valid TOML"),
    (["study", "run", "dir.toml"], 2, "is a folder"),
    (["study", "run", "deep.toml"], 2, "deep.toml: not usable TOML: arrays or tables nested too deeply"),
    (["study", "run", "plugins"], 2, "study file plugins is a folder, not a .toml file"),
    (["study", "run", "missing.toml"], 2, "not found"),
    (["study", "run", "paper-numerica"], 2, "did you mean 'paper-numerical'"),
    (["study", "run", "tiny.toml", "--jobs", "0"], 2, "--jobs must be at least 1"),
    (["study", "run", "tiny.toml", "--scheduler", "tcp://x:1"], 2, "--scheduler needs"),
]

G3_ISOLATION = [  # a plugin that exits, hangs or crashes is reported by name
    (["identify", "x.csv", "--method", "exit-identify", "--terms", "z^3"], 2, "'exit-identify' called sys.exit(4)"),
    (["identify", "x.csv", "--method", "exit-at-import", "--terms", "z^3"], 2, "called sys.exit(3)"),
    (["identify", "x.csv", "--method", "hang-forever", "--terms", "z^3", "--timeout", "2"], 1,
     "did not finish within the time limit of 2 s"),
    (["identify", "x.csv", "--method", "segv", "--terms", "z^3", "--timeout", "60"], 2, "segmentation fault (SIGSEGV)"),
    (["identify", "x.csv", "--method", "exit-identify", "--terms", "z^3", "--timeout", "60"], 2, "sys.exit(4)"),
    (["identify", "x.csv", "--terms", "z^3,q", "--timeout", "60"], 2, "unknown name 'q'"),
    (["identify", "big.csv", "--terms", TERMS, "--mass", "0.2", "--timeout", "60"], 1, "cannot be trusted"),
    (["identify", "x.csv", "--terms", "z^3", "--timeout", "-1"], 2, "--timeout must be a number of seconds"),
    (["identify", "x.csv", "--terms", "z^3", "--timeout", "nan"], 2, "--timeout must be"),
    (["identify", "x.csv", "--terms", "z^3", "--timeout", "1e12"], 2, "--timeout must be"),
]

G4_FILES = [  # no user file lost
    (["study", "run", "tiny.toml", "--out", "user"], 2, "holds files nlid did not write"),
    (["study", "run", "tiny.toml", "--out", "user", "--force"], 2, "which nlid did not write and would replace"),
    (["study", "run", "tiny.toml", "--out", "afile"], 2, "exists and is not a folder"),
    (["simulate", "--preset", "paper-numerical", "--duration", "1", "--out", "existing.csv"], 2,
     "existing.csv already exists; give --force"),
    (["simulate", "--preset", "paper-numerical", "--duration", "1", "--out", "mine.csv", "--force"], 2,
     "mine.csv.meta.json exists and was not written by nlid"),
    (["simulate", "--preset", "paper-numerical", "--duration", "1", "--out", "folder.csv"], 2, "is a folder"),
    (["posterior", "x.csv", "--terms", "z^3", "--mass", "0.2", "--out", "afile", "--no-bias-correction"], 2,
     "exists and is not a folder"),
    (["posterior", "n.csv", "--terms", TERMS, "--mass", "0.2", "--out", "user", "--no-bias-correction"], 2,
     "holds files nlid did not write"),
    (["posterior", "n.csv", "--terms", TERMS, "--mass", "0.2", "--out", "user", "--force", "--no-bias-correction"],
     2, "posterior.json, which nlid did not write"),
    (["discover", "x.csv", "--declared", "1,z,v", "--mass", "0.2", "--out", "user", "--quiet"], 2,
     "holds files nlid did not write"),
    (["discover", "x.csv", "--declared", "1,z,v", "--mass", "0.2", "--out", "afile", "--quiet"], 2,
     "exists and is not a folder"),
]

G5_ONE_LINE = [  # tracebacks where one line belongs
    (["posterior", "x.csv", "--terms", "z^3", "--mass", "0.2", "--seed", "-1"], 2, "seed must be an integer"),
    (["posterior", "x.csv", "--terms", "z^3", "--mass", "0.2", "--walkers", "1"], 2, "--walkers must be"),
    (["posterior", "x.csv", "--terms", "z^3", "--mass", "0.2", "--steps", "0"], 2, "--steps must be"),
    (["posterior", "x.csv", "--terms", "z^3", "--mass", "0.2", "--bias-pairs", "0"], 2, "--bias-pairs must be"),
    (["posterior", "x.csv", "--terms", "z^3", "--mass", "0.2", "--noise-z", "-1"], 2, "--noise-z must be"),
    (["posterior", "x.csv", "--terms", "z^3", "--mass", "0.2", "--cutoff", "0"], 2, "cutoff must be a positive"),
    (["posterior", "x.csv", "--terms", "z^3", "--mass", "0.2", "--slices", "a,b"], 2, "--slices expects"),
    (["posterior", "x.csv", "--terms", "z^3", "--mass", "0.2", "--prior", "v=normal(0,-1)"], 2, "positive sd"),
    (["posterior", "x.csv", "--terms", "z^3", "--mass", "0.2", "--prior", "v=gamma(1,2)"], 2, "cannot read the prior"),
    (["posterior", "x.csv", "--terms", "z^3", "--mass", "0.2", "--prior", "v"], 2, "TERM=SPEC"),
    (["posterior", "x.csv", "--terms", "z^3", "--mass", "0.2", "--prior", "v=normal(0,1e999)"], 2, "positive sd"),
    (["posterior", "x.csv", "--terms", "z^3", "--mass", "0.2", "--params", "q"], 2, "unknown name 'q'"),
    (["posterior", "x.csv", "--terms", "z^3", "--mass", "0.2", "--params", "z^5"], 2, "does not contain"),
    (["posterior", "x.csv", "--terms", "z^3", "--mass", "0.2", "--prior", "q=flat"], 2, "unknown name 'q'"),
    (["simulate", "--preset", "paper-numerical", "--seed", "-1", "--out", "s.csv"], 2, "seed must be an integer"),
    (["simulate", "--preset", "paper-numerical", "--seed", "99999999999999999999", "--out", "s.csv"], 2, "seed must"),
    (SIMULATE_SET + ["fs=0", "--out", "s.csv"], 2, "fs must be a positive number of Hz"),
    (SIMULATE_SET + ["fs=1e9", "--out", "s.csv"], 2, "at most 1e+07, got 1e+09"),
    (SIMULATE_SET + ["fs=nan", "--out", "s.csv"], 2, "fs must be a positive number of Hz"),
    (["simulate", "--preset", "paper-numerical", "--set", "mass=abc", "--out", "s.csv"], 2, "expected a number"),
    (["simulate", "--preset", "paper-numerical", "--set", "novalue", "--out", "s.csv"], 2, "key=value"),
    (["simulate", "--preset", "paper-numerical", "--set", "z^5=1", "--out", "s.csv"], 2, "not in the model"),
    (["simulate", "--preset", "paper-numerical", "--duration", "1e9", "--out", "s.csv"], 2, "more than the limit"),
    (["simulate", "--preset", "paper-numerical", "--duration", "inf", "--out", "s.csv"], 2, "duration"),
    (["simulate", "--preset", "paper-numerical", "--duration", "nan", "--out", "s.csv"], 2, "--duration must be"),
    (["simulate", "--preset", "paper-numerical", "--duration", "-1", "--out", "s.csv"], 2, "--duration must be"),
    (["simulate", "--preset", "paper-numerical", "--duration", "0.001", "--out", "s.csv"], 2, "at least 64"),
    (["simulate", "--preset", "paper-numerical", "--noise", "-1", "--out", "s.csv"], 2, "--noise must be"),
    (["simulate", "--preset", "paper-numerical", "--noise", "nan", "--out", "s.csv"], 2, "--noise must be"),
    (["simulate", "--preset", "paper-numerical", "--channels", "q", "--out", "s.csv"], 2, "unknown channel"),
    (["simulate", "--preset", "paper-numeric", "--out", "s.csv"], 2, "did you mean"),
    (["simulate", "--preset", "paper-numerical", "--out", "s.txt"], 2, "must end in .csv or .npz"),
    (["simulate", "--preset", "paper-numerical", "--out", "nodir/x.csv"], 2, "the folder nodir does not exist"),
    (["simulate", "--preset", "paper-numerical", "--duration", "1", "--out", "afile/x.csv"], 2,
     "the folder afile does not exist"),
    (["terms", NESTED], 2, "nested more than 32 levels deep"),
    (["identify", "x.csv", "--terms", NESTED], 2, "nested more than"),
    (["identify", "cell.mat", "--columns", "f=f*k", "--terms", "z^3"], 2, "scale factor 'k' in cell.mat holds objects"),
    (["identify", "str.mat", "--columns", "f=f*k", "--terms", "z^3"], 2, "scale factor 'k' in str.mat holds text"),
    (["identify", "struct.mat", "--terms", "z^3"], 2, "column 'z' in struct.mat holds a struct"),
    (["identify", "cplx.mat", "--terms", "z^3"], 2, "holds complex numbers"),
    (["identify", "cplx.npz", "--terms", "z^3"], 2, "column 'f' in cplx.npz holds complex numbers"),
    (["identify", "strs.npz", "--terms", "z^3"], 2, "holds text, not numbers"),
    (["identify", "two.npz", "--terms", "z^3"], 2, "a channel needs one dimension"),
    (["identify", "fstr.npz", "--terms", "z^3"], 2, "variable 'fs' in fstr.npz holds text"),
    (["identify", "obj.npz", "--terms", "z^3"], 2, "pickled objects"),
    (["identify", "garbage.csv", "--terms", "z^3"], 2, "garbage.csv"),
    (["identify", "garbage.npz", "--terms", "z^3"], 2, "not an NPZ"),
    (["identify", "garbage.mat", "--terms", "z^3"], 2, "cannot read garbage.mat"),
    (["identify", "latin1.csv", "--terms", "z^3"], 2, "latin1.csv"),
    (["identify", "data.xyz", "--terms", "z^3"], 2, "unknown file type"),
    (["identify", "nan.csv", "--terms", "z^3"], 2, "nan.csv"),
    (["identify", "inf.csv", "--terms", "z^3"], 2, "inf.csv"),
    (["identify", "word.csv", "--terms", "z^3"], 2, "non-numeric value 'five'"),
    (["identify", "empty.csv", "--terms", "z^3"], 2, "empty.csv"),
    (["identify", "header.csv", "--terms", "z^3"], 2, "header.csv"),
    (["identify", "short.csv", "--terms", "z^3"], 2, "short.csv"),
    (["identify", "jitter.csv", "--terms", "z^3"], 2, "jitter.csv"),
    (["identify", "flat.csv", "--terms", "z^3"], 2, "flat.csv"),
    (["identify", "folder.csv", "--terms", "z^3"], 2, "is a folder, not a data file"),
    (["identify", "deep.csv", "--terms", "z^3"], 2, "cannot read the metadata file"),
    (["identify", "missing.csv", "--terms", "z^3"], 2, "file not found"),
    (["identify", "x.csv", "--fs", "100", "--terms", "z^3"], 2, "either a time column or --fs"),
    (["identify", "x.csv", "--terms", "z^3", "--mass", "-1"], 2, "--mass must be a positive"),
    (["identify", "x.csv", "--terms", "z^3", "--mass", "nan"], 2, "--mass must be a positive"),
    (["identify", "x.csv", "--terms", "z^3", "--mass", "inf"], 2, "--mass must be a positive"),
    (["identify", "x.csv", "--terms", "z^3", "--method", "rsf"], 2, "did you mean 'rfs'"),
    (["identify", "x.csv", "--terms", "z^3", "--set", "cutof=3"], 2, "unknown option 'cutof'"),
    (["identify", "x.csv", "--terms", "z^3", "--set", "cutoff=abc"], 2, "cutoff"),
    (["identify", "x.csv", "--terms", "z^3", "--set", "cutoff=nan"], 2, "must be finite"),
    (["identify", "x.csv", "--terms", "z^3", "--set", "=3"], 2, "key=value"),
    (["identify", "x.csv", "--terms", "z^3", "--px-roots", "a,b"], 2, "--px-roots expects two numbers"),
    (["identify", "x.csv", "--terms", "z^3", "--px-roots", "1"], 2, "--px-roots expects two numbers"),
    (["identify", "x.csv", "--terms", "sign(v)*|px(z)|", "--px-roots", "0.1,-0.1"], 2, "z- < 0 < z+"),
    (["identify", "x.csv", "--terms", "sign(v)*|px(z)|", "--px-roots", "nan,0.1"], 2, "px"),
    (["identify", "x.csv", "--terms", "z^3", "--without", "q"], 2, "unknown name 'q'"),
    (["identify", "x.csv", "--terms", "z^3", "--columns", "q=z"], 2, "unknown channel 'q'"),
    (["identify", "x.csv", "--terms", "z^3", "--columns", "f=nope"], 2, "column 'nope' not found"),
    (["identify", "x.csv", "--terms", "z^3", "--columns", "f=f/0"], 2, "divides 'f' by zero"),
    (["identify", "x.csv", "--terms", "z^3", "--columns", "f=f+z"], 2, "only * and / are allowed"),
    (["identify", "x.csv", "--terms", "z^3", "--columns", "f"], 2, "must look like channel=column"),
    (["identify", "x.csv", "--terms", "z^3", "--columns", "f=2*3"], 2, "names no column"),
    (["identify", "x.csv", "--terms", "z^3", "--columns", "f=f,f=z"], 2, "twice"),
    (["identify", "dataset:nope", "--terms", "z^3"], 2, "nope"),
    (["identify", "dataset:emps", "--columns", "f=x", "--terms", "z^3"], 2, "do not apply to bundled datasets"),
    (["discover", "x.csv", "--declared", "1,z,v", "--mass", "0.2", "--max-steps", "-1"], 2, "--max-steps must be"),
    (["discover", "x.csv", "--declared", "1,z,v", "--mass", "0.2", "--holdout", "1.5"], 2, "between 0 and 1"),
    (["discover", "x.csv", "--declared", "1,z,v", "--mass", "0.2", "--holdout", "missing.csv"], 2, "not found"),
    (["discover", "x.csv", "--declared", "1,z,v", "--mass", "0.2", "--candidates", "nope"], 2, "nope"),
    (["discover", "x.csv", "--declared", "1,z,v", "--mass", "0.2", "--candidate", "bad"], 2, "NAME=TERMS"),
    (["discover", "x.csv", "--declared", "1,z,q", "--mass", "0.2"], 2, "unknown name 'q'"),
    ([*DISCOVER_X, "--cutoff", "-1"], 2, "Nyquist frequency 1024 Hz, got -1"),
    (["discover", "x.csv", "--declared", "1,z,v", "--mass", "0.2", "--cutoff", "5000"], 2, "Nyquist"),
]

G6_CONSISTENT = [  # limits and messages consistent
    (["terms", PRODUCT], 2, "is z^50001 in normal form: powers above 15 are not allowed"),
    (["terms", "(z^4)^4"], 2, "is z^16 in normal form"),
    (["terms", "z^15*|z|"], 2, "is z^16 in normal form"),
    (["terms", "(v*|v|)^8"], 2, "is v^16 in normal form"),
    (["terms", "tanh(v/0.1)^8*tanh(v/0.1)^8"], 2, "tanh(v/0.1)^16"),
    (["terms", "z^16"], 2, "exponent 16 is larger than the maximum 15"),
    (["terms", "z^99999999999999999999999"], 2, "larger than the maximum 15"),
    (["terms", "z^-1"], 2, "non-negative integer exponent"),
    (["terms", "z^1.5"], 2, "non-negative integer exponent"),
    (["terms", "z,,v"], 2, "empty term"),
    (["terms", "z+v"], 2, "not allowed inside a term"),
    (["terms", "2*z"], 2, "cannot be a factor"),
    (["terms", "\u00e9"], 2, "unexpected character"),
    (["posterior", "x.csv", "--terms", "z^3", "--mass", "0.2", "--cutoff", "-1"], 2, "got -1"),
    (["posterior", "n.csv", "--terms", "z^3", "--mass", "0.2", "--cutoff", "5000", "--no-bias-correction"], 2,
     "Nyquist frequency 1024 Hz, got 5000"),
    (["simulate", "--preset", "paper-numerical", "--out", "nodir/x.csv"], 2, "nodir"),
    (["simulate", "--preset", "paper-numerical", "--set", "bogus=1", "--out", "s.csv"], 2,
     "'bogus' is neither a preset parameter"),
    (["simulate", "--preset", "paper-numerical", "--set", "mas=1", "--out", "s.csv"], 2, "did you mean 'mass'"),
    (["identify", "folder.csv", "--terms", "z^3"], 2, "folder"),
]

CASES = [
    *(("G1", *c) for c in G1_UNTRUSTED),
    *(("G2", *c) for c in G2_CONFIG),
    *(("G3", *c) for c in G3_ISOLATION),
    *(("G4", *c) for c in G4_FILES),
    *(("G5", *c) for c in G5_ONE_LINE),
    *(("G6", *c) for c in G6_CONSISTENT),
]


def _id(case) -> str:
    group, argv, status, _ = case
    text = " ".join(a if len(a) < 30 else a[:20] + "..." for a in argv)
    return f"{group}:{status}:{text}"


@pytest.mark.parametrize("case", CASES, ids=[_id(c) for c in CASES])
def test_hostile_case_gives_one_line_and_the_right_status(case, files, monkeypatch, capsys):
    group, argv, status, fragment = case
    monkeypatch.chdir(files)
    before = {p.name: p.read_bytes() for p in (files / "user").iterdir()}
    got = main(list(argv))
    out = capsys.readouterr()
    lines = [line for line in out.err.splitlines() if line.strip()]
    assert got == status, f"exit {got}, expected {status}; stderr: {out.err[-2000:]}"
    assert len(lines) == 1, f"expected one line on stderr, got {len(lines)}: {out.err[-2000:]}"
    assert lines[0].startswith("nlid "), lines[0]
    assert fragment in lines[0], lines[0]
    assert "Traceback" not in out.err and "RuntimeWarning" not in out.err
    after = {p.name: p.read_bytes() for p in (files / "user").iterdir()}
    assert after == before, "a file of the user's was changed"


def test_the_case_list_covers_every_group():
    groups = {c[0] for c in CASES}
    assert groups == {"G1", "G2", "G3", "G4", "G5", "G6"}
    assert len(CASES) >= 130, len(CASES)


def test_numerical_warnings_of_a_finite_result_become_one_result_warning(files, monkeypatch, capsys):
    """Group 1: an identifier that overflows internally but returns finite numbers: exit 0, a warning line."""
    monkeypatch.chdir(files)
    assert main(["identify", "x.csv", "--method", "warns", "--terms", "z^3", "--mass", "0.2", "--json"]) == 0
    out = capsys.readouterr()
    data = json.loads(out.out)
    assert any("overflow encountered" in w for w in data["warnings"]), data["warnings"]
    assert "RuntimeWarning" not in out.err


def test_methods_lists_a_plugin_that_exits_at_import_as_unusable(files, capsys):
    """Group 3: ``sys.exit`` at import does not end ``nlid methods``; the plugin is named."""
    assert main(["methods"]) == 0
    out = capsys.readouterr().out
    assert "exit-at-import  UNUSABLE: failed to load (nlid_exit_at_import): called sys.exit(3)" in out
    assert "rfs" in out and "exit-identify" in out
