"""Benchmarks declared as data: the built-in files, and what a benchmark file may say."""

from __future__ import annotations

import pytest

from nlid import InputError
from nlid.benchmarking import builtin_benchmarks, load_protocol, parse_protocol
from nlid.data.datasets import SILVERBOX_PARTS


def test_builtin_benchmarks_and_their_protocols():
    assert set(builtin_benchmarks()) == {"emps", "emps-internal", "silverbox", "bouc-wen"}
    sb = load_protocol("silverbox")
    assert sb.official and sb.unit == "mV" and sb.scale == 1000.0 and sb.remove_means
    assert [(t.name, t.rule) for t in sb.tests] == [
        ("arrow-full", "window:50"),
        ("arrow-no-extrapolation", "window:50"),
        ("multisine", "window:50"),
    ]
    emps = load_protocol("emps")
    assert emps.test("pulses").file is not None and emps.test("pulses").rule == "window:20"
    internal = load_protocol("emps-internal")
    assert not internal.official and internal.estimation.range == (0, 18631)
    assert internal.test("last-quarter").source.range == (18631, 24841)
    bw = load_protocol("bouc-wen")
    assert [(t.name, t.rule, t.local) for t in bw.tests] == [
        ("held-out-period", "periodic:8192", True),
        ("sinesweep", "first-sample", True),
        ("multisine", "periodic:8192", False),
    ]
    assert bw.pipelines.mass == 2.0 and bw.test("held-out-period").noise_floor.periods == (2, 3, 4)


def test_silverbox_parts_are_the_nonlinear_benchmarks_split():
    # nonlinear_benchmarks 1.0.1, Silverbox(): train data[40650:105712]; tests [105712:127400], [100:40575], [100:32100]
    assert SILVERBOX_PARTS == {
        "estimation": (40650, 105712),
        "arrow-full": (100, 40575),
        "arrow-no-extrapolation": (100, 32100),
        "multisine-test": (105712, 127400),
    }
    sb = load_protocol("silverbox")
    for part in (sb.estimation, *(t.source for t in sb.tests)):
        start, stop = SILVERBOX_PARTS[part.part]
        assert part.samples == stop - start
    # the estimation part starts after the arrow head and its zeros: no test sample in it
    assert SILVERBOX_PARTS["estimation"][0] > SILVERBOX_PARTS["arrow-full"][1]


def test_published_figures_are_converted_and_only_verified_ones_accepted(toy_text):
    PROTOCOL = toy_text
    bw = load_protocol("bouc-wen")
    pnlss = [p for p in bw.published if p.parameters == 217][0]
    assert pnlss.unit == "dB" and pnlss.rmse == pytest.approx(1.2134e-5, rel=1e-3) and pnlss.same_rule
    dyno = [p for p in bw.published if p.method.startswith("dynoNet")][0]
    assert not dyno.same_rule and dyno.rmse == 4.52e-5
    unverified = PROTOCOL.replace('status = "verified"', 'status = "unverified"')
    with pytest.raises(InputError, match="status: must be one of verified, verified-secondary"):
        parse_protocol(unverified, "toy.toml")
    toy = parse_protocol(PROTOCOL)
    assert toy.published[0].rmse == pytest.approx(5e-4)  # 0.5 mm in m


@pytest.mark.parametrize(
    "change, message",
    [
        (('rule = "window:20"', 'rule = "window:0"'), "rule: must be first-sample, window:N or periodic"),
        (('rule = "window:20"', 'rule = "periodic:x"'), "rule: must be"),
        (("holdout = 0.25", "holdout = 1.5"), "holdout: must lie between 0 and 1"),
        (("mass = 0.2", 'mass = "known"'), 'mass: must be "estimate" or a positive number'),
        (('unit = "mm"', 'unit = "furlong"'), "unit: must be one of"),
        (('name = "independent"', 'name = "estimation"'), "'estimation' names the estimation part"),
        (("remove_means = true", 'remove_means = true\ncolour = "red"'), "benchmark.colour: unknown key"),
        (('test = "independent"', 'test = "arrow"'), "names no test set of this benchmark"),
        (("[pipelines]", '[pipelines]\ntemrs = "z"'), "temrs: unknown key"),
    ],
)
def test_benchmark_file_errors_name_the_key(change, message, toy_text):
    PROTOCOL = toy_text
    old, new = change
    assert old in PROTOCOL
    with pytest.raises(InputError, match=message):
        parse_protocol(PROTOCOL.replace(old, new, 1), "toy.toml")


def test_load_protocol_by_path_and_unknown_name(tmp_path, toy_text):
    PROTOCOL = toy_text
    path = tmp_path / "toy.toml"
    path.write_text(PROTOCOL)
    assert load_protocol(path).name == "toy"
    with pytest.raises(InputError, match="did you mean 'silverbox'"):
        load_protocol("silverbx")
    with pytest.raises(InputError, match="not valid TOML"):
        parse_protocol("[benchmark", "bad.toml")


def test_benchmark_files_ship_as_package_data():
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    text = (root / "pyproject.toml").read_text()
    assert '"benchmarking/protocols/*.toml"' in text
    for path in builtin_benchmarks().values():
        assert path.parent == root / "nlid" / "benchmarking" / "protocols"


def test_a_simulated_benchmark_declares_its_true_system_and_the_bench_scores_it(toy_text):
    """Bouc-Wen's [truth] is its published system; the bench scores it like any fit (kind "truth")."""
    import numpy as np

    from nlid.benchmarking.jobs import score_model
    from nlid.benchmarking.truth import TRUTH_KIND, true_fitted
    from nlid.data.datasets import BOUC_WEN_REFERENCE
    from nlid.data.record import Record

    bw = load_protocol("bouc-wen")
    assert bw.truth is not None and dict(bw.truth.coefficients) == BOUC_WEN_REFERENCE["coefficients"]
    assert bw.truth.mass == BOUC_WEN_REFERENCE["mass"]
    (fitted,) = true_fitted(bw)
    assert fitted.kind == TRUTH_KIND and fitted.parameters == 0 and not fitted.choices
    force = np.sin(2 * np.pi * 20.0 * np.arange(1500) / 750.0) * 10.0
    own = fitted.model.simulate(force, 750.0)  # its own response (free run from rest): scored at zero
    record = Record(f=force, z=own.z, v=own.v, fs=750.0, meta={"force_hold": "sampled"})
    scored = score_model(fitted, record, "first-sample")
    assert scored["rule"] == "from the record's first sample" and scored["rmse"] < 1e-9 * np.std(own.z)
    assert true_fitted(parse_protocol(toy_text)) == []  # a measured benchmark declares none
    bad = toy_text + '\n[truth]\ncoefficients = { zz = 1.0 }\nmass = 1.0\nsource = "x"\n'
    with pytest.raises(InputError, match="truth.coefficients: unknown name 'zz'"):
        parse_protocol(bad, "toy.toml")
    with pytest.raises(InputError, match="truth.mass: is required"):
        parse_protocol(toy_text + '\n[truth]\ncoefficients = { z = 1.0 }\nsource = "x"\n', "toy.toml")
