"""The one number formatter of nlid's tables: significant digits from the spread, tables within 100 columns."""

from __future__ import annotations

import math

import pytest

from nlid.base.formatting import column_digits, sig, spread_cell, spread_digits, text_table


@pytest.mark.parametrize(
    "x, digits, text",
    [
        (1e6, 4, "1.000e+06"),
        (999_600.0, 5, "9.9960e+05"),
        (4996.3, 3, "5000"),
        (-500.08, 5, "-500.08"),
        (0.0995, 2, "0.10"),
        (0.00595, 3, "0.00595"),
        (0.000919, 3, "9.19e-04"),
        (0.0, 3, "0"),
        (float("nan"), 3, "–"),
        (None, 3, "–"),
    ],
)
def test_sig_keeps_the_digits_it_is_asked_for(x, digits, text):
    assert sig(x, digits) == text


def test_digits_tell_min_median_and_max_apart():
    # the example: 1e+06 [9.999e+05, 1.001e+06] hid the differences in the fifth digit
    med, lo, hi = 1_000_030.0, 999_940.0, 1_001_300.0
    d = spread_digits(med, lo, hi)
    texts = [sig(v, d) for v in (med, lo, hi)]
    assert len(set(texts)) == 3, texts
    assert spread_digits(0.48, 0.281, 4.12) == 3  # gap 0.2 on 4.12: two digits + one
    assert spread_digits(5.0, 5.0, 5.0) == 3  # no spread: the default
    assert column_digits([(1.0, 0.9, 1.1), (1.0, 0.999, 1.001)]) == spread_digits(1.0, 0.999, 1.001)
    assert spread_cell(1.0, 0.5, 2.0, 2) == "1.0 [0.50, 2.0]"
    assert spread_cell(3.0) == "3.00"


def test_text_table_splits_wide_tables_and_repeats_the_label_column():
    header = ["method", *(f"column {i} (%)" for i in range(12))]
    rows = [[m, *(f"{math.pi * i:.4f} [{i:.3f}, {2 * i:.3f}]" for i in range(12))] for m in ("nsi-ip", "rfs")]
    text = text_table(header, rows, width=100)
    lines = text.splitlines()
    assert max(len(line) for line in lines) <= 100
    blocks = text.split("\n\n")
    assert len(blocks) > 1 and all(b.startswith("method") for b in blocks)
    assert sum(b.count("column") for b in blocks) == 12  # every column once
    assert all(("nsi-ip" in b and "rfs" in b) for b in blocks)
