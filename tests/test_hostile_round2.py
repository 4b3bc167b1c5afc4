"""Hostile probe, round two (issue 25): what a plugin returns, plugins that print, silent inputs, runaway messages.

Groups of issue 25 covered here (the process boundary, groups 1-2 and the crash cases of 3/5, is
tested with ``nlid.runtime``):

``G4``  silent wrong from a plugin: everything an identifier returns is checked before use
        (:func:`nlid.contract.estimate.check_estimate`); a hypothesis test drives the boundary with
        random return values.
``G35`` ``nlid methods``: a plugin printing at import, one with no hook, one slow to import.
``G6``  input accepted silently (boolean channels, ``**``, posterior slices and noise levels, the API).
``G7``  tracebacks and runaway messages (one line, capped, newlines escaped).

CLI cases are ``(argv, status, fragment)`` as in ``tests/test_hostile.py``: exit status 2 (bad input,
broken plugin) or 1 (a result that cannot be trusted), exactly one line on stderr starting ``nlid``
and holding ``fragment``, no traceback. The plugins live in a temporary folder with a ``.dist-info``
declaring their entry points (nothing installed); the generated plugin takes its answer from its
``spec`` option, so the same plugin serves every case and crosses a process boundary unchanged.
"""

from __future__ import annotations

import contextlib
import importlib
import io
import json
import math
import sys

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from plugin_dist import write_distribution

import nlid
from nlid.cli.main import main
from nlid.contract import registry as registry_module
from nlid.contract.registry import default_registry, registry_for
from nlid.data.record import Record
from nlid.errors import DataError, InputError, NlidError, PluginError, brief, listing, one_line
from nlid.identified.model import IdentifiedModel
from nlid.simulation.presets import get_preset

TERMS = "z^3,z^2,v*|v|"

GENERATED = '''
import json

import numpy as np

from nlid.plugin import Estimate, Identifier, Option, hookimpl


class Opaque:
    """An object that is neither a number nor JSON."""


def decode(x):
    """A JSON token of the spec as the hostile Python value it stands for."""
    if isinstance(x, dict) and "$" in x:
        tag = x["$"]
        if tag == "nan":
            return float("nan")
        if tag == "inf":
            return float("inf")
        if tag == "-inf":
            return float("-inf")
        if tag == "object":
            return Opaque()
        if tag == "array":
            return np.array(x["v"])
        if tag == "np":
            return np.float64(x["v"])
        if tag == "npbool":
            return np.bool_(True)
        if tag == "complex":
            return complex(1.0, 2.0)
        if tag == "bytes":
            return b"raw"
        if tag == "set":
            return {1, 2}
        if tag == "tuple":
            return tuple(decode(v) for v in x["v"])
        if tag == "self":
            d = {"a": 1}
            d["me"] = d
            return d
        raise ValueError(tag)
    if isinstance(x, list):
        return [decode(v) for v in x]
    if isinstance(x, dict):
        return {k: decode(v) for k, v in x.items()}
    return x


class Generated(Identifier):
    name = "generated"
    summary = "returns what its spec option describes (test plugin)"
    options = (Option("spec", "str", "{}", "JSON description of the Estimate to return"),)

    def identify(self, record, model, *, mass=None):
        spec = json.loads(self.settings["spec"])
        names = list(model.names)
        if "coef_raw" in spec:
            coefficients = decode(spec["coef_raw"])
        else:
            tokens = spec.get("coef", [1.0])
            coefficients = {n: decode(tokens[i % len(tokens)]) for i, n in enumerate(names)}
            if spec.get("reversed"):
                coefficients = dict(reversed(list(coefficients.items())))
        kwargs = {}
        if "mass" in spec:
            kwargs["mass"] = decode(spec["mass"])
        if "se_raw" in spec:
            kwargs["standard_errors"] = decode(spec["se_raw"])
        elif "se" in spec:
            kwargs["standard_errors"] = {n: decode(spec["se"][i % len(spec["se"])]) for i, n in enumerate(names)}
        if "mass_se" in spec:
            kwargs["mass_standard_error"] = decode(spec["mass_se"])
        if "diag" in spec:
            kwargs["diagnostics"] = decode(spec["diag"])
        if "warnings" in spec:
            kwargs["warnings"] = decode(spec["warnings"])
        if "modal" in spec:
            kwargs["modal"] = decode(spec["modal"])
        if "arrays" in spec:
            kwargs["arrays"] = decode(spec["arrays"])
        return Estimate(coefficients=coefficients, **kwargs)


@hookimpl
def nlid_identifiers():
    return [Generated]
'''

NOISY = """
import os
import sys

print("hello from a plugin at import")
sys.stderr.write("a plugin's stderr at import\\n")
os.write(1, b"raw bytes on file descriptor 1\\n")

from nlid.plugin import Estimate, Identifier, hookimpl


class Noisy(Identifier):
    name = "noisy"
    summary = "prints while it is imported (test plugin)"

    def identify(self, record, model, *, mass=None):
        return Estimate(coefficients={n: 1.0 for n in model.names})


@hookimpl
def nlid_identifiers():
    print("and while asked for its identifiers")
    return [Noisy]
"""

SLOW = """
import time

time.sleep(0.3)

from nlid.plugin import hookimpl


@hookimpl
def nlid_identifiers():
    return []
"""

PLUGIN_MODULES = {
    "nlid_r2_generated": GENERATED,
    "nlid_r2_noisy": NOISY,
    "nlid_r2_nohook": "VALUE = 1  # a module that implements no hook at all\n",
    "nlid_r2_unmarked": "def nlid_identifiers():  # the @hookimpl marker is missing\n    return []\n",
    "nlid_r2_slow": SLOW,
}
ENTRY_POINTS = {
    "generated": "nlid_r2_generated",
    "noisy": "nlid_r2_noisy",
    "nohook": "nlid_r2_nohook",
    "unmarked": "nlid_r2_unmarked",
    "slow": "nlid_r2_slow",
}


def spec(**fields) -> str:
    """``--set spec=...`` for the generated plugin."""
    return "spec=" + json.dumps(fields)


NAN, INF, OBJ = {"$": "nan"}, {"$": "inf"}, {"$": "object"}


def _forget_plugin_modules() -> None:
    for name in PLUGIN_MODULES:
        sys.modules.pop(name, None)
    default_registry.cache_clear()
    registry_for.cache_clear()


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """Data files with hostile content, and the test plugins on ``sys.path`` with their entry points."""
    d = tmp_path_factory.mktemp("hostile2")
    record = get_preset("paper-numerical").with_overrides(duration=2.0).simulate(0, channels=("z", "v", "a"))
    frame = pd.DataFrame({"t": record.t, "f": record.f, "z": record.z, "v": record.v, "a": record.a})
    frame.to_csv(d / "x.csv", index=False)
    noisy = get_preset("paper-numerical").with_overrides(duration=4.0).simulate(0, noise=0.02, channels=("z", "a"))
    pd.DataFrame({"t": noisy.t, "f": noisy.f, "z": noisy.z, "a": noisy.a}).to_csv(d / "n.csv", index=False)
    np.savez(d / "boolf.npz", t=record.t, f=record.f > 0, z=record.z)
    np.savez(d / "boolz.npz", t=record.t, f=record.f, z=record.z > 0)
    bools = frame.copy()
    bools["f"] = bools["f"] > 0
    bools.to_csv(d / "boolf.csv", index=False)
    wide = 5000
    (d / "wide.csv").write_text(",".join(f"c{i}" for i in range(wide)) + "\n" + ",".join(["1"] * wide) + "\n")
    (d / "seed.toml").write_text(
        "[study]\nseed = 99999999999999999999\nidentifiers = ['rfs']\n"
        "[[datasets]]\npreset = 'paper-numerical'\noverrides = { duration = 2 }\n"
    )
    (d / "bad\nname.toml").write_text("[[datasets]\n")
    plugins = d / "plugins"
    plugins.mkdir()
    write_distribution(plugins, "nlid-hostile2", PLUGIN_MODULES, ENTRY_POINTS)
    with pytest.MonkeyPatch.context() as mp:
        mp.syspath_prepend(str(plugins))
        _forget_plugin_modules()
        yield d
    _forget_plugin_modules()


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
    assert "Traceback" not in err and "RuntimeWarning" not in err, err[-2000:]
    assert ": internal error:" not in lines[0], lines[0]  # the last resort caught a bug
    return lines[0]


# --------------------------------------------------------------------------- the CLI cases
IDENTIFY = ["identify", "x.csv", "--method", "generated", "--terms", TERMS, "--mass", "0.2", "--set"]
ESTIMATE = ["identify", "x.csv", "--method", "generated", "--terms", TERMS, "--set"]

G4_PLUGIN = [  # what a plugin returns is checked before anything uses it
    (
        [*IDENTIFY, spec(coef=[{"$": "array", "v": [1, 2, 3]}])],
        2,
        "returned an array of shape (3,) as the coefficient of 1",
    ),
    ([*IDENTIFY, spec(coef=[1.0, 2.0, "abc"])], 2, "returned a string 'abc' as the coefficient of z^2"),
    ([*IDENTIFY, spec(coef=[OBJ])], 2, "an object of type Opaque as the coefficient of 1"),
    ([*IDENTIFY, spec(coef=[True])], 2, "a bool (True) as the coefficient of 1"),
    ([*IDENTIFY, spec(coef=[[1.0]])], 2, "a list [1.0] as the coefficient of 1"),
    ([*IDENTIFY, spec(coef=[{"a": 1}])], 2, "a dict {'a': 1} as the coefficient"),
    ([*IDENTIFY, spec(coef=[None])], 2, "returned None as the coefficient of 1"),
    ([*IDENTIFY, spec(coef=[{"$": "complex"}])], 2, "a complex number"),
    ([*IDENTIFY, spec(coef_raw=[1.0, 2.0])], 2, "returned coefficients as a list"),
    ([*IDENTIFY, spec(coef_raw={"z^3": 1.0})], 2, "but the model is"),
    ([*IDENTIFY, spec(coef=[NAN])], 1, "non-finite coefficients for 1 (nan)"),
    ([*IDENTIFY, spec(coef=[1.0, INF])], 1, "non-finite coefficients for z (inf)"),
    ([*IDENTIFY, spec(coef=[10**400])], 1, "non-finite coefficients for 1 (inf)"),
    ([*ESTIMATE, spec(mass=-0.2)], 1, "estimated a mass that is not positive (-0.2 kg)"),
    ([*ESTIMATE, spec(mass=0.0)], 1, "estimated a mass that is not positive"),
    ([*ESTIMATE, spec(mass=NAN)], 1, "estimated a mass that is not positive (nan kg)"),
    ([*ESTIMATE, spec(mass=OBJ)], 2, "returned an object of type Opaque as the mass"),
    ([*ESTIMATE, spec(mass="0.2")], 2, "returned a string '0.2' as the mass"),
    ([*ESTIMATE, spec(mass={"$": "array", "v": [0.2]})], 2, "returned an array of shape (1,) as the mass"),
    ([*IDENTIFY, spec(mass=0.3)], 2, "returned a mass of 0.3 kg although the mass was given (0.2 kg)"),
    ([*IDENTIFY, spec(se=["big"])], 2, "as the standard error of 1, not a number"),
    ([*IDENTIFY, spec(se_raw=[1.0])], 2, "returned standard errors as a list"),
    ([*IDENTIFY, spec(se=[-1.0])], 1, "standard errors of 1, z, z^2, z^3, v, v*|v| are negative"),
    ([*IDENTIFY, spec(se=[NAN])], 1, "standard errors of 1"),
    ([*ESTIMATE, spec(mass=0.2, mass_se=OBJ)], 2, "as the standard error of the mass"),
    ([*ESTIMATE, spec(mass=0.2, mass_se=-1.0)], 1, "the standard error of the mass is -1.0"),
    ([*IDENTIFY, spec(warnings="careful")], 2, "returned warnings as a string 'careful'"),
    ([*IDENTIFY, spec(warnings=["ok", 3])], 2, "returned a number (3) among its warnings, not a string"),
    ([*IDENTIFY, spec(modal="fast")], 2, "returned modal parameters as a string"),
    ([*IDENTIFY, spec(modal=[{"fn_hz": 10.0}])], 2, "returned malformed modal parameters"),
    ([*IDENTIFY, spec(modal=[3])], 2, "returned malformed modal parameters: expected a mapping, got a number (3)"),
]

G6_INPUT = [  # input that was accepted silently
    (
        ["identify", "boolf.npz", "--terms", "z^3"],
        2,
        "column 'f' in boolf.npz holds booleans (True/False), not numbers",
    ),
    (["identify", "boolz.npz", "--terms", "z^3"], 2, "column 'z' in boolz.npz holds booleans"),
    (["identify", "boolf.csv", "--terms", "z^3"], 2, "column 'f' in boolf.csv holds booleans"),
    (
        ["posterior", "n.csv", "--terms", TERMS, "--mass", "0.2", "--slices", "nan", "--out", "p"],
        2,
        "--slices expects finite numbers, got 'nan'",
    ),
    (
        ["posterior", "n.csv", "--terms", TERMS, "--mass", "0.2", "--slices", "0.01,inf", "--out", "p"],
        2,
        "--slices expects finite numbers",
    ),
    (["posterior", "n.csv", "--terms", TERMS, "--mass", "0.2", "--slices", "0.01"], 2, "give --out DIR"),
    (
        ["posterior", "n.csv", "--terms", TERMS, "--mass", "0.2", "--noise-level", "z=1e-300"],
        2,
        "less than 1e-12 of the channel's standard deviation",
    ),
    (
        ["posterior", "n.csv", "--terms", TERMS, "--mass", "0.2", "--noise-level", "z=1e-300", "--no-bias-correction"],
        2,
        "noise on z is 1e-300 m, less than 1e-12",
    ),
    (["study", "run", "seed.toml", "--out", "s"], 2, "study.seed: must be an integer from 0 to 2**63 - 1"),
]

LONG = "q" * 100_000
G7_ONE_LINE = [  # tracebacks and runaway messages
    (
        ["posterior", "n.csv", "--terms", TERMS, "--mass", "0.2", "--steps", "1", "--no-bias-correction"],
        1,
        "the chains did not converge in 1 steps: too few steps to estimate the autocorrelation time",
    ),
    (["terms", "z^" + "7" * 5000], 2, "exponent 77777777777777777777... (5000 digits) is larger than the maximum 15"),
    (["terms", "z^0000000000000000000000016"], 2, "exponent 16 is larger than the maximum 15"),
    (["terms", "tanh(v/" + "1" * 400 + ")"], 2, "is too large"),
    (["terms", LONG], 2, "unknown name 'qqqqqqqqqqqqqqqqqqq... (100 000 characters)"),
    (["identify", "x.csv", "--terms", "z^3," + LONG], 2, "(100 000 characters)"),
    (["identify", "x.csv", "--terms", "z^3", "--method", LONG], 2, "unknown method 'qqqq"),
    (["identify", "x.csv", "--terms", "z^3", "--set", LONG + "=1"], 2, "unknown option 'qqqq"),
    (["identify", "x.csv", "--terms", "z^3", "--set", "cutoff=" + LONG], 2, "expects a number or 'auto', got 'qqq"),
    (["identify", "x.csv", "--terms", "z^3", "--columns", "f=" + LONG], 2, "column 'qqqq"),
    (["identify", "x.csv", "--terms", "z^3", "--mass", LONG], 2, "--mass must be a number of kg"),
    (
        ["identify", "wide.csv", "--terms", "z^3"],
        2,
        "the file has: c0, c1, c10, c100, c1000, c1001, c1002, c1003, c1004, c1005 ... and 4 990 more",
    ),
    (["identify", "dataset:" + LONG, "--terms", "z^3"], 2, "unknown dataset 'qqqq"),
    (["simulate", "--preset", LONG, "--out", "s.csv"], 2, "unknown preset 'qqqq"),
    (["posterior", "n.csv", "--terms", TERMS, "--mass", "0.2", "--prior", "v=" + LONG], 2, "cannot read the prior"),
    (["methods", LONG], 2, "unknown method 'qqqq"),
    ([LONG], 2, "invalid choice"),
    (["identify", "bad\nname.csv", "--terms", "z^3"], 2, "bad\\nname.csv"),
    (["study", "run", "bad\nname.toml"], 2, "bad\\nname.toml"),
    (["simulate", "--preset", "paper-numerical", "--out", "no\ndir/x.csv"], 2, "no\\ndir"),
    (
        [
            "identify",
            "x.csv",
            "--method",
            "generated",
            "--terms",
            "z^3",
            "--mass",
            "0.2",
            "--set",
            spec(warnings=["line one\nline two"], coef=[1.0]),
        ],
        0,
        None,
    ),
]

CASES = [
    *(("G4", *c) for c in G4_PLUGIN),
    *(("G6", *c) for c in G6_INPUT),
    *(("G7", *c) for c in G7_ONE_LINE),
]


def _id(case) -> str:
    group, argv, status, _ = case
    text = " ".join(a if len(a) < 30 else a[:20] + "..." for a in argv)
    return f"{group}:{status}:{text}"


@pytest.mark.parametrize("case", CASES, ids=[_id(c) for c in CASES])
def test_hostile_case_gives_one_line_and_the_right_status(case, files, monkeypatch):
    group, argv, status, fragment = case
    monkeypatch.chdir(files)
    got, out, err = _run(argv)
    assert got == status, f"exit {got}, expected {status}; stderr: {err[-2000:]}"
    assert "Traceback" not in err
    if status == 0:  # a warning with a line break stays one line of the result
        assert "line one\\nline two" in out + err and "line one\nline two" not in out + err
        return
    line = _one_error_line(err)
    assert fragment in line, line
    assert len(line) <= 1200, f"{len(line)} characters: {line[:300]}"


def test_the_case_list_covers_every_group():
    counts = {g: sum(1 for c in CASES if c[0] == g) for g in ("G4", "G6", "G7")}
    assert all(n >= 9 for n in counts.values()), counts


# --------------------------------------------------------------------------- G4: what the core keeps
def test_unusable_diagnostics_are_dropped_with_a_warning_and_json_stays_valid(files, monkeypatch):
    monkeypatch.chdir(files)
    diag = {
        "ok": 1.5,
        "opaque": OBJ,
        "loop": {"$": "self"},
        "raw": {"$": "bytes"},
        "nan": NAN,
        "arr": {"$": "array", "v": [1]},
    }
    status, out, err = _run(
        [*IDENTIFY, spec(diag=diag, arrays={"frf": OBJ, "good": {"$": "array", "v": [1.0]}}), "--json"]
    )
    assert status == 0, err
    data = json.loads(out)
    assert data["diagnostics"]["ok"] == 1.5 and data["diagnostics"]["nan"] is None and data["diagnostics"]["arr"] == [1]
    assert not {"opaque", "loop", "raw"} & set(data["diagnostics"])
    dropped = [w for w in data["warnings"] if w.startswith("diagnostics dropped")]
    assert len(dropped) == 1 and all(k in dropped[0] for k in ("'opaque'", "'loop'", "'raw'")), data["warnings"]
    assert any(w.startswith("arrays dropped") and "'frf'" in w for w in data["warnings"]), data["warnings"]


def test_coefficients_in_another_order_are_put_in_model_order(files, monkeypatch):
    monkeypatch.chdir(files)
    status, out, err = _run([*IDENTIFY, spec(coef=[1.0, 2.0, 3.0, 4.0, 5.0, 6.0], reversed=True), "--json"])
    assert status == 0, err
    data = json.loads(out)
    assert list(data["coefficients"]) == data["terms"]
    assert [data["coefficients"][t] for t in data["terms"]] == [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]


def test_the_compliance_suite_uses_the_core_check():
    """nlid.testing refuses what nlid.identify refuses, with the same message."""
    from nlid.plugin import Estimate, Identifier
    from nlid.testing import identifier_checks

    class ArrayCoefficient(Identifier):
        name = "array-coefficient"
        summary = "returns an array as a coefficient (test plugin)"

        def identify(self, record, model, *, mass=None):
            return Estimate(coefficients={n: np.ones(2) for n in model.names}, mass=None if mass else 0.2)

    check = {c.name: c for c in identifier_checks(ArrayCoefficient)}["check_known_mass"]
    with pytest.raises(AssertionError, match=r"returned an array of shape \(2,\) as the coefficient of 1"):
        check()


# --------------------------------------------------------------------------- G3/G5: nlid methods
def test_methods_json_stays_clean_when_a_plugin_prints_at_import(files, monkeypatch, capfd):
    monkeypatch.setattr(registry_module, "SLOW_IMPORT", 0.2)
    _forget_plugin_modules()
    try:
        assert main(["methods", "--json"]) == 0
        captured = capfd.readouterr()
    finally:
        _forget_plugin_modules()
    data = json.loads(captured.out)  # one JSON object on one line: nothing the plugin printed around it
    assert captured.out.count("\n") == 1
    assert "a plugin's stderr" not in captured.err
    noisy = " ".join(data["notes"]["noisy"])
    assert "printed at import (kept out of nlid's output)" in noisy and "hello from a plugin" in noisy
    assert "raw bytes on file descriptor 1" in noisy and "a plugin's stderr" in noisy
    assert "printed in nlid_identifiers()" in noisy
    assert "noisy" in data["methods"] and "generated" in data["methods"]
    assert data["failures"]["nohook"].startswith("provides nothing: it implements no nlid hook")
    assert data["failures"]["unmarked"] == "provides nothing: nlid_identifiers() is not marked with @nlid.hookimpl"
    slow = " ".join(data["notes"]["slow"])
    assert "s to import" in slow and "provides no identifier" in slow


def test_methods_text_names_the_silent_plugins(files, monkeypatch, capfd):
    _forget_plugin_modules()
    try:
        assert main(["methods"]) == 0
        out = capfd.readouterr().out
    finally:
        _forget_plugin_modules()
    printed = [line for line in out.splitlines() if "hello from a plugin" in line]
    assert printed and all(line.startswith("noisy  NOTE: printed at import") for line in printed), printed
    assert "nohook  UNUSABLE: provides nothing" in out
    assert "noisy  NOTE: printed at import" in out


def test_identify_json_stays_clean_when_the_plugin_prints_at_import(files, monkeypatch, capfd):
    monkeypatch.chdir(files)
    _forget_plugin_modules()
    try:
        assert main(["identify", "x.csv", "--method", "noisy", "--terms", "z^3", "--mass", "0.2", "--json"]) == 0
        captured = capfd.readouterr()
    finally:
        _forget_plugin_modules()
    assert json.loads(captured.out)["method"] == "noisy"
    assert "hello" not in captured.err and "a plugin's stderr" not in captured.err


def test_a_plugin_without_hooks_is_named_when_asked_for(files, monkeypatch):
    monkeypatch.chdir(files)
    _forget_plugin_modules()
    status, _, err = _run(["identify", "x.csv", "--method", "nohook", "--terms", "z^3"])
    assert status == 2
    assert "identifier plugin 'nohook' is installed but unusable: provides nothing" in _one_error_line(err)


# --------------------------------------------------------------------------- G6: the API
@pytest.fixture(scope="module")
def record():
    return get_preset("paper-numerical").with_overrides(duration=2.0).simulate(0, channels=("z", "v", "a"))


@pytest.fixture(scope="module")
def fit(record):
    return nlid.identify(record, "z^3", mass=0.2)


def test_api_refuses_a_non_integer_seed():
    with pytest.raises(InputError, match="seed must be an integer from 0 to 2\\*\\*63 - 1, got 1.5"):
        nlid.simulate("paper-numerical", seed=1.5)


def test_api_refuses_missing_terms(record):
    with pytest.raises(InputError, match="terms are missing"):
        nlid.identify(record, None)


def test_api_score_names_a_wrong_record_type(fit):
    with pytest.raises(InputError, match="record must be a one-DOF nlid Record .*, got str"):
        fit.score("text")


@pytest.mark.parametrize(
    ("channel", "values", "message"),
    [
        ("f", lambda r: r.f + 1j, "channel 'f' holds complex numbers"),
        ("z", lambda r: r.z + 0j, "channel 'z' holds complex numbers"),
        ("f", lambda r: r.f > 0, "channel 'f' holds booleans"),
        ("v", lambda r: r.v > 0, "channel 'v' holds booleans"),
        ("z", lambda r: r.z.astype(str), "channel 'z' holds text"),
    ],
)
def test_record_refuses_complex_boolean_and_text_channels(record, channel, values, message):
    fields = {"f": record.f, "z": record.z, "v": record.v, channel: values(record)}
    with pytest.raises(DataError, match=message):
        Record(fs=record.fs, **fields)


@pytest.mark.parametrize("bad", [float("nan"), float("inf"), "1.0", [1.0], None, True])
def test_from_dict_refuses_a_coefficient_that_is_not_a_finite_number(fit, bad):
    data = fit.to_dict()
    data["coefficients"]["z^3"] = bad
    with pytest.raises(InputError, match="the coefficient of 'z\\^3' is .*, not a finite number"):
        IdentifiedModel.from_dict(data)


def test_compare_refuses_an_unknown_method_before_running(record, monkeypatch):
    import nlid.api

    def boom(*args, **kwargs):
        raise AssertionError("a method ran before the names were checked")

    monkeypatch.setattr(nlid.api, "identify", boom)
    with pytest.raises(InputError, match="unknown method 'rsf' \\(did you mean 'rfs'\\?\\)"):
        nlid.compare(record, "z^3", methods=["rfs", "rsf"], mass=0.2)
    with pytest.raises(InputError, match="options= are given for 'sindy'"):
        nlid.compare(record, "z^3", methods=["rfs"], mass=0.2, options={"sindy": {}})


def test_restoring_force_propagates_nan_as_documented(fit):
    assert math.isnan(fit.restoring_force(np.nan, 0.0))
    assert np.isnan(fit.restoring_force(np.array([0.0, np.nan]), np.zeros(2))).tolist() == [False, True]
    assert "NaN" in IdentifiedModel.restoring_force.__doc__


def test_power_may_be_written_as_in_python(files, monkeypatch):
    """``**`` is read as ``^`` (the grammar says so, ``nlid terms`` says so, every output shows ``^``)."""
    monkeypatch.chdir(files)
    status, out, _ = _run(["terms", "z**3, v*|v|**2", "--json"])
    assert status == 0
    assert [t["term"] for t in json.loads(out)] == ["z^3", "v^3"]
    status, out, _ = _run(["terms"])
    assert "** as in Python" in out


# --------------------------------------------------------------------------- G7: the helpers and the last resort
def test_listing_and_brief_cap_what_they_echo():
    assert listing(f"c{i}" for i in range(100_000)) == "c0, c1, c2, c3, c4, c5, c6, c7, c8, c9 ... and 99 990 more"
    assert brief("x" * 100_000).endswith("... (100 000 characters)") and len(brief("x" * 100_000)) < 100
    assert one_line("a\nb\r\nc") == "a\\nb\\r\\nc"
    assert len(one_line("y" * 10**6)) <= 1000


def test_the_cli_keeps_any_error_on_one_capped_line(monkeypatch):
    """The last resort: a message with line breaks and a megabyte of text is still one readable line."""
    from nlid.cli import cmd_terms

    def runaway(args):
        raise InputError("first part\nsecond part " + "z" * 10**6 + " the hint at the end")

    monkeypatch.setattr(cmd_terms, "run", runaway)
    status, _, err = _run(["terms", "z"])
    line = _one_error_line(err)
    assert status == 2
    assert line.startswith("nlid terms: error: first part\\nsecond part zzz") and line.endswith("the hint at the end")
    assert len(line) <= 1100


def test_a_100000_column_mapping_is_listed_in_a_short_message():
    table = {f"c{i}": np.arange(100.0) for i in range(100_000)}
    with pytest.raises(DataError) as info:
        Record.from_table(table, "f=c1,z=nope", fs=100.0)
    message = str(info.value)
    assert "column 'nope' not found" in message and "... and 99 990 more" in message and len(message) < 300


# --------------------------------------------------------------------------- the plugin boundary, by hypothesis
KEYS = st.text(alphabet="abcdxyz_", max_size=4)  # never "$", the generated plugin's tag
FINITE = st.floats(min_value=-1e6, max_value=1e6, allow_nan=False, allow_infinity=False)
#: Numbers a plugin may return that are no physical answer: non-finite, huge, zero, negative, subnormal.
BAD_NUMBERS = st.one_of(
    st.sampled_from([NAN, INF, {"$": "-inf"}, 10**400, -(10**400), 0.0, -1.0, -1e-300, 1e308, -1e308, 5e-324]),
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(min_value=-(10**30), max_value=10**30),
)
#: Values of the wrong kind: no number at all.
WRONG_KINDS = st.one_of(
    st.booleans(),
    st.none(),
    st.text(max_size=8),
    st.lists(FINITE, max_size=3),
    FINITE.map(lambda x: {"$": "array", "v": [x, x]}),
    FINITE.map(lambda x: {"$": "array", "v": x}),
    st.sampled_from([OBJ, {"$": "complex"}, {"$": "bytes"}, {"$": "set"}, {"$": "npbool"}, {"$": "self"}]),
    st.dictionaries(KEYS, FINITE, max_size=2),
)
HOSTILE = st.one_of(BAD_NUMBERS, FINITE.map(lambda x: {"$": "np", "v": x}), WRONG_KINDS)


def _value(token):
    """What the generated plugin makes of a token, for the oracle: a float for a real number, else a marker."""
    if isinstance(token, dict) and token.get("$") in ("nan", "inf", "-inf"):
        return float(token["$"])
    if isinstance(token, dict) and token.get("$") == "np":
        return float(token["v"])
    if isinstance(token, bool) or not isinstance(token, (int, float)):
        return "not a number"
    try:
        return float(token)
    except OverflowError:
        return math.inf if token > 0 else -math.inf


@st.composite
def estimates(draw):
    """A spec for the generated plugin: which part is hostile (or none, or all), then the values.

    Returns ``(fields, mass given, --json)``.
    """
    target = draw(
        st.sampled_from(["none", "coef", "coef:numbers", "mass", "mass:numbers", "se", "mass_se", "diag", "all"])
    )
    given = draw(st.booleans())

    def part(name, clean, hostile):  # the strategy of one part: hostile values only in the targeted part
        if target == f"{name}:numbers":
            return st.one_of(clean, BAD_NUMBERS)
        return st.one_of(clean, hostile) if target in (name, "all") else clean

    fields: dict = {"coef": draw(st.lists(part("coef", FINITE, HOSTILE), min_size=1, max_size=5))}
    mass = draw(part("mass", st.one_of(st.none(), st.just(0.2) if given else st.floats(0.05, 5.0)), HOSTILE))
    if mass is not None:
        fields["mass"] = mass
    if target in ("se", "all") or draw(st.booleans()):
        fields["se"] = draw(st.lists(part("se", st.floats(0, 1e3), HOSTILE), min_size=1, max_size=3))
    if target in ("mass_se", "all") or draw(st.booleans()):
        fields["mass_se"] = draw(part("mass_se", st.floats(0, 1.0), HOSTILE))
    if target in ("diag", "all") or draw(st.booleans()):
        fields["diag"] = draw(st.dictionaries(KEYS, part("diag", FINITE, HOSTILE), max_size=3))
    return fields, given, draw(st.booleans())


def _expected(fields: dict, given: bool) -> str:
    """``"broken"`` (a value of the wrong kind: exit 2 or 1), ``"untrusted"`` (exit 1) or ``"clean"`` (0 or 1)."""
    coefs = [_value(t) for t in fields["coef"]]  # at most 5 tokens for the 5 terms: each is used
    kind = "clean"
    if any(c == "not a number" for c in coefs):
        return "broken"
    if any(not math.isfinite(c) for c in coefs):
        kind = "untrusted"
    if "mass" in fields and fields["mass"] is not None:
        m = _value(fields["mass"])
        if m == "not a number" or (given and not math.isclose(m, 0.2, rel_tol=1e-12)):
            return "broken"
        if not (math.isfinite(m) and m > 0):
            kind = "untrusted"
    for t in fields.get("se", []):
        if t is not None and _value(t) == "not a number":
            return "broken"
    if not given and fields.get("mass") is not None and fields.get("mass_se") is not None:
        if _value(fields["mass_se"]) == "not a number":
            return "broken"
    return kind


def _physical(data: dict) -> None:
    """A result that exits 0 holds only finite, physical figures."""
    assert data["coefficients"] and all(
        isinstance(x, float) and math.isfinite(x) for x in data["coefficients"].values()
    )
    assert data["mass"] is None or (isinstance(data["mass"], float) and data["mass"] > 0)
    for x in (data["standard_errors"] or {}).values():
        assert x is None or (isinstance(x, float) and x >= 0)
    assert data["mass_standard_error"] is None or data["mass_standard_error"] >= 0
    for mode in data["modal"]:
        assert mode["fn_hz"] > 0 and math.isfinite(mode["zeta"])
    if data["mass"] is not None:
        assert isinstance(data["eps_percent"], float) and math.isfinite(data["eps_percent"])
    json.dumps(data, allow_nan=False)


@settings(
    max_examples=100,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)
@given(case=estimates())
def test_random_plugin_answers_never_pass_unchecked(files, monkeypatch, case):
    """Whatever the plugin returns: never exit 0 with a non-finite or non-physical result, never a traceback."""
    fields, given_mass, as_json = case
    monkeypatch.chdir(files)
    argv = ["identify", "x.csv", "--method", "generated", "--terms", "z^3, v*|v|", "--set", spec(**fields)]
    argv += ["--mass", "0.2"] if given_mass else []
    argv += ["--json"] if as_json else []
    status, out, err = _run(argv)
    expected = _expected(fields, given_mass)
    assert status in (0, 1, 2) and "Traceback" not in err
    if status:
        line = _one_error_line(err)
        assert len(line) <= 1200
        if status == 2:
            assert "'generated'" in line, line
    if expected == "broken":
        assert status in (1, 2), (fields, out[:500])
    elif expected == "untrusted":
        assert status == 1, (fields, err)
    if status == 0 and as_json:
        _physical(json.loads(out))
    if status == 0:
        assert expected == "clean"


@settings(max_examples=60, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(case=estimates())
def test_random_plugin_answers_raise_only_nlid_errors_through_the_api(files, record, case):
    """Through ``nlid.identify`` (an identifier instance): an nlid error or a physical result, nothing else."""
    fields, given_mass, _ = case
    identifier = importlib.import_module("nlid_r2_generated").Generated(spec=json.dumps(fields))
    try:
        fit = nlid.identify(record, "z^3, v*|v|", identifier, mass=0.2 if given_mass else None)
    except NlidError as exc:
        assert "\n" not in str(exc)
        if isinstance(exc, PluginError):
            assert "'generated'" in str(exc)
        return
    assert _expected(fields, given_mass) == "clean", fields
    _physical(fit.to_dict())
