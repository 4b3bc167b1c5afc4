"""An input delay shorter than the smallest time of the grid is found (issue 31).

The input-path candidates try 0.25 to 8 samples and refine between the best value's grid neighbours. On a
broadband force a quarter of a sample is already far from zero (on the Silverbox estimation part every grid delay
explained about -1500 % of the held-out residual), so when the smallest time of the grid is the best the
refinement reaches below it (:data:`nlid.discovery.trials.INPUT_PATH_BELOW_GRID`); before, the delay found could
never be shorter than a quarter of a sample.
"""

from __future__ import annotations

import pytest

import nlid
from nlid.discovery import PredictionRule
from nlid.estimation.inputpath import InputPath

pytestmark = pytest.mark.slow

#: The true delay of the acting force behind the force channel, in samples (below the grid's 0.25).
DELAY_SAMPLES = 0.15


def test_a_delay_below_the_grid_is_found():
    multisine = {"period": 4096, "lines": (4, 600), "periods": 3, "transient_periods": 2, "phases": "random"}
    record = nlid.simulate(
        "paper-numerical",
        seed=1,
        noise={"z": 0.01},
        channels=("z",),
        multisine={**multisine, "oversample": 8},
        duration=3 * 4096 / 2048,
    )
    truth = record.meta["reference"]
    # the force channel runs ahead of the acting force by DELAY_SAMPLES (exact for the periodic record)
    channel = InputPath(delay=-DELAY_SAMPLES / record.fs).apply(record).f
    skewed = nlid.Record(f=channel, z=record.z, fs=record.fs, meta={"periodic": record.meta["periodic"]})
    result = nlid.discover(
        skewed,
        ", ".join(truth["coefficients"]),
        "rfs",
        mass=truth["mass"],
        candidates="input-delay",
        simulate=False,
        views=False,
        prediction=PredictionRule(enabled=False),
    )
    assert [s.effect for s in result.steps] == ["input-delay"], result.stop_reason
    found = result.final.path.delay * record.fs
    assert found == pytest.approx(DELAY_SAMPLES, abs=0.03), found
