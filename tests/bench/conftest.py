"""Tiny simulated stand-ins for the measured benchmarks: a benchmark file whose parts are user files."""

from __future__ import annotations

import numpy as np
import pytest

from nlid.data.io import write_csv
from nlid.discovery.cases import build_case

#: A benchmark of our own: single-well Duffing, the cubic spring missing from the declared model.
PROTOCOL = """
[benchmark]
name = "toy"
title = "toy single-well Duffing oscillator"
citation = "nlid test suite"
dataset = "toy"
official = false
protocol = "nlid tests: a simulated stand-in"
unit = "mm"
scale = 1000.0
fs = 1024.0
remove_means = true

[estimation]
description = "6 s of the single-well case, seed 1"

[estimation.file]
names = ["toy_estimation.mat"]
columns = "f=force, z=disp"

[[tests]]
name = "independent"
rule = "window:20"
description = "2 s of another force, seed 2"

[tests.file]
names = ["toy_test.mat"]
columns = "f=force, z=disp"

[pipelines]
terms = "z^3"
without = ""
declared = "1, z, v"
mass = 0.2
holdout = 0.25

[pipelines.pysindy]
thresholds = [0.0, 0.1]

[pipelines.options.oe]
max_nfev = 40

[[published]]
test = "independent"
method = "a made-up figure"
paper = "nobody"
year = 2020
value = 0.5
unit = "mm"
rule = "from rest"
same_rule = false
source = "the test suite"
status = "verified"
"""


def toy_records(seed_est: int = 1, seed_test: int = 2):
    """Estimation and test records of the single-well Duffing case (noise 1 % on z)."""
    preset, _ = build_case("single", "cubic-stiffness")
    est = preset.with_overrides(duration=6.0).simulate(seed_est, noise=0.01, channels=("z",))
    test = preset.with_overrides(duration=2.0).simulate(seed_test, noise=0.01, channels=("z",))
    return est, test


@pytest.fixture(scope="session")
def toy(tmp_path_factory):
    """``(protocol text, estimation CSV, test CSV, folder)`` of the toy benchmark."""
    folder = tmp_path_factory.mktemp("toy")
    est, test = toy_records()
    (folder / "toy.toml").write_text(PROTOCOL)
    write_csv(est, folder / "est.csv")
    write_csv(test, folder / "test.csv")
    return PROTOCOL, folder / "est.csv", folder / "test.csv", folder


@pytest.fixture(scope="session")
def toy_text():
    """The toy benchmark file's text."""
    return PROTOCOL


@pytest.fixture(scope="session")
def perturb():
    """``perturb(path, out)``: a copy of a CSV record with its displacement changed."""
    return perturbed_copy


def perturbed_copy(path, out, *, scale=1.3, shift=0.002, noise=1e-4, seed=5):
    """A copy of a CSV record with its displacement scaled, shifted and noised (its force unchanged)."""
    import pandas as pd

    frame = pd.read_csv(path)
    rng = np.random.default_rng(seed)
    frame["z"] = frame["z"] * scale + shift + noise * rng.standard_normal(len(frame))
    frame.to_csv(out, index=False)
    return out
