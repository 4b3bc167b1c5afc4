"""nlid.runtime.memory.PeakMemory: the peak a block adds, untraced where the system keeps the peak."""

from __future__ import annotations

import sys
import tracemalloc

import numpy as np
import pytest

from nlid.runtime import memory
from nlid.runtime.memory import RESIDENT, TRACED, PeakMemory

MB = 1_000_000


def _touch(megabytes: int) -> float:
    x = np.ones(megabytes * MB // 8)  # every page written
    return float(x[-1])


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="the resident high-water mark is Linux's")
def test_resident_peak_sees_a_touched_array_and_traces_nothing():
    seen = []
    with PeakMemory() as peak:
        seen.append(tracemalloc.is_tracing())
        _touch(80)
    assert peak.how == RESIDENT
    assert seen == [False]  # the timed block runs untraced
    assert 70 * MB <= peak.bytes <= 400 * MB


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="the resident high-water mark is Linux's")
def test_the_peak_is_reset_for_each_block():
    with PeakMemory():
        _touch(120)
    with PeakMemory() as small:
        _touch(10)
    assert small.bytes < 60 * MB  # the first block's peak is not the second's


def test_traced_when_the_system_keeps_no_peak(monkeypatch):
    monkeypatch.setattr(memory, "_reset_high_water", lambda: False)
    with PeakMemory() as peak:
        assert tracemalloc.is_tracing()
        _touch(40)
    assert peak.how == TRACED
    assert not tracemalloc.is_tracing()
    assert 38 * MB <= peak.bytes <= 200 * MB


def test_traced_when_proc_cannot_be_read(monkeypatch, tmp_path):
    monkeypatch.setattr(memory, "_PROC", tmp_path / "nowhere")
    with PeakMemory() as peak:
        _touch(20)
    assert peak.how == TRACED and peak.bytes >= 18 * MB
