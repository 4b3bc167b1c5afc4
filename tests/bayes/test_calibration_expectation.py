"""The binomial yardstick of the calibration matrix (benchmarks/calibration_posterior.py, docs/posterior.md).

A perfectly calibrated 90 % interval covers the truth in each replicate with probability 0.9, so the
share of coefficient-cells whose coverage lands in 85-95 % is limited by the replicate count alone.
"""

from __future__ import annotations

import importlib.util
from math import comb
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[2] / "benchmarks" / "calibration_posterior.py"


@pytest.fixture(scope="module")
def expected_within():
    spec = importlib.util.spec_from_file_location("calibration_posterior", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.expected_within


def _by_enumeration(n: int) -> float:
    """P(85 <= 100 k / n <= 95) for k ~ Binomial(n, 0.9), summed term by term."""
    return sum(comb(n, k) * 0.9**k * 0.1 ** (n - k) for k in range(n + 1) if 85 * n <= 100 * k <= 95 * n)


@pytest.mark.parametrize("n", [20, 37, 50, 100, 150])
def test_matches_enumeration(expected_within, n):
    assert expected_within([n]) == pytest.approx(_by_enumeration(n), rel=1e-9)


def test_fifty_replicates_cannot_reach_75_of_84(expected_within):
    # the docs' statement: at 50 replicates a perfect posterior puts about 64 of 84 cells in the band
    assert 63 < expected_within([50] * 84) < 66
    assert expected_within([100] * 84) > 75
