"""Study configs are validated before anything runs: file, key and suggestion in one line."""

from __future__ import annotations

import dataclasses
import json
import sys
import textwrap

import pytest

import nlid
import nlid.bayes
from nlid.errors import NlidError
from nlid.study import ConfigError, ResultStore, builtin_studies, load_study, parse_study, plan_study
from nlid.study.config import resolve_study
from nlid.study.plan import RunSpec, derive_seed, record_key
from nlid.study.report import write_report
from nlid.study.values import EstimatedMass, NoHoldout, PresetSource
from nlid.study.worker import execute_run

BAD = [
    ("[study]\nnmae = 'x'\n", "study.nmae: unknown key 'nmae' (did you mean 'name'?)"),
    ("[stduy]\n", "unknown key 'stduy' (did you mean 'study'?)"),
    ("[study]\nidentifiers = ['rsf']\n[[datasets]]\npreset='paper-numerical'\n", "did you mean 'rfs'"),
    ("[options.rfs]\ncutof = 3\n[[datasets]]\npreset='paper-numerical'\n", "options.rfs: unknown option 'cutof'"),
    ("[options.rfs]\ndecimate = 'many'\n[[datasets]]\npreset='paper-numerical'\n", "expects an integer"),
    ("[[datasets]]\npreset = 'paper-numerica'\n", "datasets[0].preset: unknown preset 'paper-numerica'"),
    ("[[datasets]]\npreset = 'paper-numerical'\nterms = 'z^^3'\n", "datasets[0].terms: "),
    ("[[datasets]]\npreset = 'paper-numerical'\nterms = 'q^3'\n", "unknown name 'q'"),
    ("[[datasets]]\npreset = 'paper-numerical'\noverrides = { mas = 1 }\n", "did you mean 'mass'"),
    ("[[datasets]]\npreset = 'paper-numerical'\nnoise = { q = 0.1 }\n", "datasets[0].noise.q: unknown channel"),
    ("[[datasets]]\npreset = 'paper-numerical'\nhodlout = 0.2\n", "did you mean 'holdout'"),
    ("[[datasets]]\npreset = 'paper-numerical'\nholdout = 1.5\n", "between 0 and 1"),
    ("[[datasets]]\ndataset = 'emsp'\n", "unknown dataset 'emsp' (did you mean 'emps'?)"),
    ("[[datasets]]\npreset = 'paper-numerical'\n[datasets.methods.rfs]\noptions = { nope = 1 }\n", "unknown option"),
    ("[[datasets]]\npreset = 'paper-numerical'\n[datasets.models]\nmain = 'z^3'\n", "'main' is the dataset's"),
    ("[study]\nname = 'a b'\n[[datasets]]\npreset = 'paper-numerical'\n", "not a usable name"),
    ("[[datasets]]\npreset = 'paper-numerical'\n[[datasets]]\npreset = 'paper-numerical'\n", "used twice"),
    ("[study]\n", "needs at least one [[datasets]]"),
    ("[[datasets]\n", "not valid TOML"),
    ("[[datasets]]\npreset = 'paper-numerical'\n[posterior]\ndraws = 10\n", "needs the module nlid.bayes"),
]

# values that are not finite, negative or absurd, and tables with unknown keys (issue 18): refused at once
BAD_VALUES = [
    ("[study]\ntimeout = nan\n[[datasets]]\npreset = 'paper-numerical'\n", "study.timeout: expected a finite number"),
    ("[study]\ntimeout = -1\n[[datasets]]\npreset = 'paper-numerical'\n", "study.timeout: must be positive"),
    ("[study]\ntimeout = 1e12\n[[datasets]]\npreset = 'paper-numerical'\n", "study.timeout: must be <="),
    ("[study]\nrepetitions = 1000000000\n[[datasets]]\npreset = 'paper-numerical'\n", "study.repetitions: must be <="),
    (
        "[study]\nrepetitions = 6000\nidentifiers = ['rfs', 'sindy', 'nsi-ip', 'nsi-shift']\n"
        "[[datasets]]\npreset = 'paper-numerical'\n",
        "plans 24000 runs",
    ),
    ("[[datasets]]\npreset = 'paper-numerical'\nmass = inf\n", "datasets[0].mass: expected a finite number"),
    ("[[datasets]]\npreset = 'paper-numerical'\nmass = -0.2\n", "datasets[0].mass: must be positive"),
    ("[[datasets]]\npreset = 'paper-numerical'\nmass = 1e300\n", "datasets[0].mass: must be <="),
    ("[[datasets]]\npreset = 'paper-numerical'\nnoise = -0.02\n", "datasets[0].noise: must be 0 or a fraction"),
    ("[[datasets]]\npreset = 'paper-numerical'\nnoise = { z = nan }\n", "datasets[0].noise.z: must be 0 or a fraction"),
    ("[[datasets]]\npreset = 'paper-numerical'\nslices = [0.0, nan]\n", "datasets[0].slices[1]: expected a finite"),
    ("[[datasets]]\npreset = 'paper-numerical'\noverrides = { duration = 0 }\n", "datasets[0].overrides: preset"),
    (
        "[[datasets]]\npreset = 'paper-numerical'\noverrides = { fs = nan }\n",
        "datasets[0].overrides.fs: expected a finite",
    ),
    ("[[datasets]]\npreset = 'paper-numerical'\noverrides = { duration = 1e9 }\n", "more than the limit"),
    ("[[datasets]]\npreset = 'paper-numerical'\ntimeout = 0\n", "datasets[0].timeout: must be positive"),
    ("[[datasets]]\nfile = 'x.csv'\nfs = -5\n", "datasets[0].fs: must be positive"),
    ("[[datasets]]\npreset = 'paper-numerical'\n[posterior]\ndraws = 10\n", "posterior.draws: unknown key 'draws'"),
    ("[[datasets]]\npreset = 'paper-numerical'\n[posterior]\nlevel = 1.5\n", "posterior.level: the credible level"),
    (
        "[[datasets]]\npreset = 'paper-numerical'\n[posterior]\nwalkers = 1.5\n",
        "posterior.walkers: expected an integer",
    ),
    ("[[datasets]]\npreset = 'paper-numerical'\n[posterior]\nmove = 'gibbs'\n", "posterior: unknown move"),
    (
        "[[datasets]]\npreset = 'paper-numerical'\n[datasets.reference]\nmass = nan\n",
        "reference.mass: expected a finite",
    ),
    # every table: reference values, per-identifier overrides, [options.X], preset fields, [posterior] (issue 18)
    ("[[datasets]]\npreset = 'paper-numerical'\n[datasets.reference]\nmass = 1e300\n", "reference.mass: must be <="),
    (
        "[[datasets]]\npreset = 'paper-numerical'\n[datasets.reference]\nmodal = [{ fn_hz = 1 }]\n",
        "modal[0]: needs zeta",
    ),
    (
        "[[datasets]]\npreset = 'paper-numerical'\n[datasets.reference]\nmodal = [{ fn_hz = inf, zeta = 0.1 }]\n",
        "modal[0].fn_hz: expected a finite",
    ),
    (
        "[[datasets]]\npreset = 'paper-numerical'\n[datasets.reference]\nequilibria = [1e300]\n",
        "equilibria[0]: must be <=",
    ),
    (
        "[[datasets]]\npreset = 'paper-numerical'\n[datasets.reference]\ncoefficients = { 'z^3' = nan }\n",
        "reference.coefficients.z^3: expected a finite",
    ),
    ("[[datasets]]\npreset = 'paper-numerical'\nslices = [-1e300]\n", "datasets[0].slices[0]: must be >="),
    (
        "[[datasets]]\npreset = 'paper-numerical'\npx_roots = [nan, 0.01]\n",
        "datasets[0].px_roots[0]: expected a finite",
    ),
    (
        "[[datasets]]\npreset = 'paper-numerical'\n[datasets.models.b]\npx_roots = [-0.01, inf]\n",
        "datasets[0].models.b.px_roots[1]: expected a finite",
    ),
    (
        "[[datasets]]\npreset = 'paper-numerical'\n[datasets.methods.rfs]\npx_roots = [-1e9, 0.01]\n",
        "datasets[0].methods.rfs.px_roots[0]: must be >=",
    ),
    (
        "[[datasets]]\npreset = 'paper-numerical'\n[datasets.methods.rfs.options]\ncutoff = nan\n",
        "datasets[0].methods.rfs.options: ",
    ),
    (
        "[[datasets]]\npreset = 'paper-numerical'\n[datasets.methods.rfs]\nterms = 5\n",
        "methods.rfs.terms: expected a string",
    ),
    ("[options.rfs]\ncutoff = -inf\n[[datasets]]\npreset = 'paper-numerical'\n", "options.rfs: "),
    ("[[datasets]]\npreset = 'paper-numerical'\noverrides = { band = [10, 5] }\n", "band must be (low, high)"),
    ("[[datasets]]\npreset = 'paper-numerical'\noverrides = { band = 5 }\n", "band must be (low, high)"),
    ("[[datasets]]\npreset = 'paper-numerical'\noverrides = { excitation = 5 }\n", "excitation must be"),
    ("[[datasets]]\npreset = 'paper-numerical'\noverrides = { coefficients = { 'z^3' = 'a' } }\n", "must be a number"),
    ("[[datasets]]\npreset = 'paper-numerical'\noverrides = { coefficients = { bogus = 1 } }\n", "neither a preset"),
    ("[[datasets]]\nfile = 'x.csv'\ncolumns = 'q=x'\n", "datasets[0].columns: column map: unknown channel 'q'"),
    ("[posterior]\nmax_steps = 100000000000\n[[datasets]]\npreset = 'paper-numerical'\n", "posterior.max_steps"),
    ("[posterior]\nwalkers = 100000000\n[[datasets]]\npreset = 'paper-numerical'\n", "walkers= must be an integer"),
    ("[posterior]\nbias_correction = 'no'\n[[datasets]]\npreset = 'paper-numerical'\n", "bias_correction must be"),
    ("[posterior]\nnoise = { z = -1 }\n[[datasets]]\npreset = 'paper-numerical'\n", "noise on z must be"),
    ("[posterior]\npriors = { v = 'normal(0, -1)' }\n[[datasets]]\npreset = 'paper-numerical'\n", "positive sd"),
    ("[posterior]\nparams = 'z^5'\n[[datasets]]\npreset = 'paper-numerical'\n", "posterior.params: dataset"),
    (
        "[posterior]\npriors = { 'z^3' = 'normal(0, 1)' }\n[[datasets]]\npreset = 'paper-numerical'\n",
        "posterior.priors: a prior is given for z^3",
    ),
]


@pytest.mark.parametrize("text, message", BAD, ids=[m[:40] for _, m in BAD])
def test_bad_configs_name_file_key_and_suggestion(text, message, monkeypatch):
    monkeypatch.setitem(sys.modules, "nlid.bayes", None)  # not written yet (issue 6)
    with pytest.raises(ConfigError) as info:
        parse_study(text, source="my.toml")
    text = str(info.value)
    assert text.startswith("my.toml: ") and message in text, text
    assert "\n" not in text


@pytest.mark.parametrize("text, message", BAD_VALUES, ids=[m[:40] for _, m in BAD_VALUES])
def test_absurd_values_and_unknown_keys_are_refused_before_any_run(text, message):
    with pytest.raises(ConfigError) as info:
        parse_study(text, source="my.toml")
    text = str(info.value)
    assert text.startswith("my.toml: ") and message in text, text
    assert "\n" not in text


def test_the_disk_is_read_by_the_resolve_step_only(tmp_path):
    config = parse_study("[[datasets]]\nfile = 'nope.csv'\nmass = 1.0\nfs = 100\n", source="my.toml", base_dir=tmp_path)
    assert not config.resolved
    with pytest.raises(ConfigError, match=r"^my.toml: datasets\[0\].file: file .*nope.csv not found"):
        resolve_study(config)
    (tmp_path / "nope.csv").write_text("f,z\n" + "".join(f"{i % 7},{i % 5}\n" for i in range(100)))
    assert resolve_study(config).resolved


def test_typed_values_and_the_run_spec_round_trip():
    config = parse_study(
        "[[datasets]]\npreset = 'paper-numerical'\nmass = 'estimate'\nholdout = 'none'\n"
        "overrides = { duration = 5 }\nnoise = { z = 0.02 }\n"
    )
    ds = config.datasets[0]
    assert isinstance(ds.source, PresetSource) and ds.source.overrides == {"duration": 5}
    assert isinstance(ds.mass, EstimatedMass) and isinstance(ds.holdout, NoHoldout)
    run = plan_study(config)[0]
    again = RunSpec.from_dict(json.loads(json.dumps(run.spec.to_dict())))
    assert again == run.spec and again.digest() == run.digest
    with pytest.raises(dataclasses.FrozenInstanceError):
        run.spec.method = "x"  # type: ignore[misc]


@pytest.mark.parametrize("name", sorted(builtin_studies()))
def test_a_parsed_study_writes_itself_back_to_the_same_runs(name):
    """StudyConfig.to_toml: every value explicit; read back, the same datasets, runs, seeds and digests."""
    path = builtin_studies()[name]
    config = parse_study(path.read_text(), source=str(path), base_dir=path.parent, default_name=name)
    text = config.to_toml()
    again = parse_study(text, source="written.toml", base_dir="/nowhere", default_name="other")
    assert again.datasets == config.datasets and again.to_dict() == config.to_dict()
    assert (again.name, again.seed, again.identifiers) == (config.name, config.seed, config.identifiers)
    assert (again.options, again.posterior) == (config.options, config.posterior)
    assert [(r.run_id, r.seed, r.digest) for r in plan_study(again)] == [
        (r.run_id, r.seed, r.digest) for r in plan_study(config)
    ]
    assert again.to_toml() == text  # a fixed point


def test_a_resolved_study_with_every_kind_of_value_round_trips_through_a_file(tmp_path):
    """Sources, masses, hold-outs, term sets, per-method options, references and awkward strings survive."""
    data = tmp_path / "data"
    data.mkdir()
    (data / "rig.csv").write_text("f,z\n" + "".join(f"{i % 7},{(i % 5) * 1e-3}\n" for i in range(400)))
    (tmp_path / "study.toml").write_text(
        textwrap.dedent(
            """\
            [study]
            description = 'quote " backslash \\\\ tab \\t unicode é 𝔷'
            seed = 7
            repetitions = 2
            timeout = 30
            identifiers = ["rfs", "sindy"]

            [options.rfs]
            cutoff = 80

            [[datasets]]
            name = "sim"
            preset = "paper-numerical"
            overrides = { duration = 4, band = [5, 40] }
            noise = { z = 0.02, a = 1e-5 }
            terms = "z^3, z^2, v*|v|"
            mass = 0.2
            holdout = 0.25
            slices = [-0.02, 0.0, 0.02]
            [datasets.models]
            stiffness-only = { terms = "z^3, z^2", without = "v" }
            roots = { terms = "z^3, px(z)", px_roots = [-0.01, 0.011] }
            [datasets.methods.rfs]
            without = "1"
            options = { cutoff = 50 }

            [[datasets]]
            name = "rig"
            file = "data/rig.csv"
            columns = "f=f,z=z"
            fs = 100
            holdout = "none"
            mass = "known"
            [datasets.reference]
            mass = 1.5
            coefficients = { "sign(v)" = 2.0, v = 3.0 }
            equilibria = [0.001, -0.002]
            modal = [{ fn_hz = 11.75, zeta = 0.109 }]
            """
        )
    )
    config = load_study(tmp_path / "study.toml")
    moved = tmp_path / "elsewhere"
    moved.mkdir()
    (moved / "copy.toml").write_text(config.to_toml())
    again = load_study(moved / "copy.toml")
    assert again.resolved and again.datasets == config.datasets
    assert again.datasets[1].source.path == str(data / "rig.csv")  # written absolute: found from anywhere
    assert again.description == config.description and again.options == config.options
    assert [r.digest for r in plan_study(again)] == [r.digest for r in plan_study(config)]
    sim = config.datasets[0].to_toml()
    assert sim["noise"] == {"z": 0.02, "a": 1e-5} and sim["channels"] == ["z", "a"]
    assert sim["models"]["roots"]["px_roots"] == [-0.01, 0.011] and sim["repetitions"] == 2


def test_builtin_studies_validate():
    studies = builtin_studies()
    assert {"paper-numerical", "noise-sweep", "paper-experimental", "emps", "silverbox"} <= set(studies)
    config = load_study("paper-numerical")
    assert config.identifiers == ("rfs", "sindy", "nsi-ip", "nsi-shift")  # oe is added by name (slow)
    assert len(plan_study(config)) == 5 * len(config.identifiers)
    assert len(plan_study(load_study("noise-sweep"))) == 5 * 5 * len(config.identifiers)
    experimental = plan_study(load_study("paper-experimental"))
    assert {r.model for r in experimental} == {"main", "stiffness-only"}


def test_run_ids_and_seeds_are_stable_and_order_independent(small_study, registry):
    a = parse_study(small_study('["rfs", "echo"]', repetitions=3), registry=registry)
    b = parse_study(small_study('["echo", "rfs"]', repetitions=3), registry=registry)
    runs_a = {r.run_id: r for r in plan_study(a)}
    runs_b = {r.run_id: r for r in plan_study(b)}
    assert runs_a.keys() == runs_b.keys()
    for run_id, run in runs_a.items():
        assert run.seed == runs_b[run_id].seed and run.digest == runs_b[run_id].digest
    seeds = {r.repetition: r.seed for r in runs_a.values() if r.method == "rfs"}
    assert all(r.seed == seeds[r.repetition] for r in runs_a.values()), "every method sees the same records"
    assert len(set(seeds.values())) == 3
    assert seeds[1] == derive_seed(7, record_key("paper-numerical", {"duration": 6.0}, 1))
    sweep = {r.run_id: r.seed for r in plan_study(load_study("noise-sweep"))}
    assert sweep["noise-1pct/main/rfs/r3"] == sweep["noise-10pct/main/rfs/r3"] != sweep["noise-10pct/main/rfs/r2"]


def test_models_table_and_per_method_overrides(small_study, registry):
    extra = """
[datasets.models]
stiffness-only = { terms = "z^3, z^2", without = "v" }
[datasets.methods.echo]
terms = "z^3, z^2"
options = { scale = 2 }
"""
    config = parse_study(small_study('["rfs", "echo"]', repetitions=1, extra=extra), registry=registry)
    runs = {r.run_id: r for r in plan_study(config)}
    assert set(runs) == {
        "short/main/rfs/r0",
        "short/main/echo/r0",
        "short/stiffness-only/rfs/r0",
        "short/stiffness-only/echo/r0",
    }
    assert runs["short/stiffness-only/rfs/r0"].spec.without == "v"
    assert runs["short/main/echo/r0"].spec.terms == "z^3, z^2"
    assert runs["short/main/echo/r0"].spec.options == {"scale": 2}
    payload = execute_run(runs["short/stiffness-only/rfs/r0"].spec)
    assert payload["row"]["status"] == "ok" and "coef:v" not in payload["row"]


def test_posterior_hook_adds_its_metrics_to_the_row(small_study, registry, monkeypatch, tmp_path):
    calls = []

    def posterior_metrics(record, result, truth, **options):
        calls.append(options)
        assert truth.coefficients["z^3"] == 1e6 and "z^3" in result.model.names  # a nlid.identified.reference.Reference
        c = result.coefficients["z^3"]
        return nlid.bayes.PosteriorMetrics(0.9, {"z^3": (0.995 * c, 1.005 * c)}, {"z^3": True}, 1.0, 0.0, 0.0)

    monkeypatch.setattr(nlid.bayes, "posterior_metrics", posterior_metrics)
    config = parse_study(
        small_study('["rfs"]', repetitions=2, duration=4.0, extra="[posterior]\nwalkers = 50\n"), registry=registry
    )
    runs = plan_study(config)
    store = ResultStore(tmp_path)
    for run in runs:
        payload = execute_run(run.spec)
        assert payload["row"]["status"] == "ok", payload["row"]["error"]
        assert payload["row"]["ci_covers:z^3"] is True
        assert payload["row"]["ci_width:z^3"] == pytest.approx(1e4, rel=0.01)
        store.save(run, payload)
    assert calls == [{"walkers": 50}, {"walkers": 50}]
    summary, _ = write_report(config, runs, store)
    assert "### Posterior (emcee): 90 % credible interval" in summary
    assert "covers 2/2" in summary and "### Other metrics" not in summary


@pytest.mark.slow
def test_measured_studies_run(data_dir, tmp_path):
    """emps against the benchmark's reference; silverbox held out on the arrow head with a free run."""
    from nlid.study import LocalExecutor, run_study

    with pytest.raises(ConfigError, match="the mass is not known for this data"):
        resolve_study(parse_study('[[datasets]]\ndataset = "silverbox"\npart = "multisine"\nmass = "known"\n'))

    emps = run_study(load_study("emps"), tmp_path / "emps", executor=LocalExecutor(1), progress=False)
    row = ResultStore(tmp_path / "emps").results(emps.runs).set_index("method").loc["rfs"]
    assert row["status"] == "ok"
    assert (
        abs(row["mass_error_pct"]) < 1 and abs(row["coef_error_pct:sign(v)"]) < 2 and abs(row["coef_error_pct:v"]) < 2
    )
    assert row["freerun_note"] == "skipped: disabled in the study"
    silverbox = run_study(load_study("silverbox"), tmp_path / "sb", executor=LocalExecutor(1), progress=False)
    row = ResultStore(tmp_path / "sb").results(silverbox.runs).set_index("method").loc["rfs"]
    assert row["status"] == "ok" and row["samples"] == 105712 - 40650  # the benchmark's estimation part
    assert 0 < row["eps_holdout_percent"] < 5
    assert row["freerun_rmse"] < 0.01, "the cubic model should track the arrow head within 10 mV RMS"


def test_a_posterior_that_fails_is_a_warning_and_the_run_keeps_its_metrics(small_study, registry, monkeypatch):
    def posterior_metrics(record, result, truth, **options):
        raise NlidError("chains did not converge: raise max_steps=")

    monkeypatch.setattr(nlid.bayes, "posterior_metrics", posterior_metrics)
    config = parse_study(small_study('["rfs"]', repetitions=1, duration=4.0, extra="[posterior]\n"), registry=registry)
    row = execute_run(plan_study(config)[0].spec)["row"]
    assert row["status"] == "ok" and abs(row["coef_error_pct:z^3"]) < 1
    assert "posterior: chains did not converge: raise max_steps=" in row["warnings"]


def test_a_fit_that_cannot_be_trusted_says_so_in_its_row(small_study, registry):
    """A given mass 1000 times the record's (g for kg) is flagged by the plausibility checks, in the row too."""
    config = parse_study(small_study('["rfs"]', repetitions=1, duration=4.0, extra="mass = 200.0\n"), registry=registry)
    row = execute_run(plan_study(config)[0].spec)["row"]
    assert row["status"] == "ok"
    assert "NOT TRUSTED" in row["warnings"] and "0.2 kg" in row["warnings"]
