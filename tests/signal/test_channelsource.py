"""The typed provenance of a channel (nlid.signal.channelsource): built from the filters, read back from JSON."""

from __future__ import annotations

import json

import numpy as np
import pytest

from nlid.data.record import Record
from nlid.signal import derivatives
from nlid.signal.channelsource import CHANNEL_SOURCES, ChannelSource, read_channel_sources, source_entries


def test_a_differentiated_channel_carries_its_filter_and_cutoff_and_the_record_text():
    rng = np.random.default_rng(0)
    z = np.cumsum(rng.standard_normal(4096)) * 1e-4
    record = Record(f=rng.standard_normal(z.size), z=z, fs=1000.0).with_derivatives(cutoff=57.0)
    _, used = derivatives.differentiate(z, 1000.0, order=1, cutoff=57.0)
    source = ChannelSource.differentiated(used, "z")
    assert source.text == record.source_of("v")  # one wording of the provenance, written in one place
    assert (source.measured, source.derived_from, source.operation, source.cutoff_hz) == (
        False,
        "z",
        "differentiated",
        57.0,
    )
    assert record.channel_source("f") == ChannelSource(True, "measured")
    assert record.channel_source("v").cutoff_hz is None  # the record keeps text only: nothing is read from it


def test_the_diagnostics_entry_is_json_and_reads_back():
    sources = {"v": ChannelSource.integrated(0.25), "z": ChannelSource(True)}
    diagnostics = json.loads(json.dumps({CHANNEL_SOURCES: source_entries(sources)}))
    assert read_channel_sources(diagnostics) == sources


@pytest.mark.parametrize(
    "entry",
    [
        "estimated from z: fc=57 Hz",  # prose is not a source
        {"text": "estimated", "cutoff_hz": 57.0},  # no measured flag
        {"measured": "no"},
        None,
    ],
)
def test_anything_but_a_source_object_is_left_out(entry):
    assert read_channel_sources({CHANNEL_SOURCES: {"v": entry}}) == {}


def test_a_bad_cutoff_is_dropped_not_kept():
    read = read_channel_sources({CHANNEL_SOURCES: {"v": {"measured": False, "cutoff_hz": -3.0}}})
    assert read["v"].cutoff_hz is None and read["v"].text == "estimated"
    assert read_channel_sources({CHANNEL_SOURCES: "v measured"}) == {}
