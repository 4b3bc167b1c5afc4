"""The pin comparison itself (``tests/pinning.py``): measured tolerances that still catch a real change."""

from __future__ import annotations

import json
import math
import re

import pytest
from pinning import TOLERANCE_PATH, Tolerances, assert_pinned, csv_leaves, group_of, is_number, leaves, mismatch

#: The leaves that are a model's coefficients or its mass: a change of one millionth in any must fail.
COEFFICIENT = re.compile(r"(\.coefficients\.[^.\[]+$|\.coef:[^.]+$|,coefficient,[^\]]*\]\.value$|\.mass$)")


def _pinned() -> dict[str, dict]:
    import test_pins
    import test_pins_spine

    spine = json.loads(test_pins_spine.PINS_PATH.read_text())
    issue22 = {}
    for section in ("identify", "compare", "study"):
        issue22.update(test_pins_spine.pinned_leaves(spine, section))
    return {"issue22": issue22, "issue12": test_pins.pinned_leaves_all()}


@pytest.fixture(scope="module")
def pinned() -> dict[str, dict]:
    return _pinned()


def test_leaves_name_every_scalar_and_every_list_length():
    out = leaves({"a": {"b": [1.0, {"c": "x"}]}, "d": None}, "r")
    assert out == {"r.a.b[#]": 2, "r.a.b[0]": 1.0, "r.a.b[1].c": "x", "r.d": None}
    assert group_of("r.a[3].b[12].c") == "r.a[].b[].c"


def test_csv_cells_are_named_by_their_row_and_column():
    out = csv_leaves("method,quantity,name,value\nrfs,coefficient,z,1.5\nrfs,coefficient,z,2\n", "f")
    assert out["f[#]"] == 3
    assert out["f[rfs,coefficient,z].value"] == 1.5 and out["f[rfs,coefficient,z#2].value"] == 2.0


def test_mismatch_rules():
    assert not mismatch(1.0 + 1e-10, 1.0, rel=1e-9) and mismatch(1.0 + 1e-8, 1.0, rel=1e-9)
    assert mismatch(3, 4, rel=1.0), "two ints are counts: exact"
    assert not mismatch(math.nan, None, rel=0) and not mismatch(None, "", rel=0)
    assert mismatch(True, 1, rel=0) and mismatch("a", "b", rel=1.0)
    assert not mismatch(0.5, 0.0, rel=0.0, absolute=0.6)


def test_a_gone_leaf_and_a_masked_text():
    tol = Tolerances(
        "s", {"suites": {"s": {"floor": 1e-9, "groups": {}, "masked": {"t.*": {"mask": r"at \d+", "reason": ""}}}}}
    )
    assert_pinned({"t.w": "diverged at 12 s"}, {"t.w": "diverged at 4996 s"}, tol)
    with pytest.raises(AssertionError, match="gone"):
        assert_pinned({}, {"t.w": "x"}, tol)
    with pytest.raises(AssertionError, match="diverged"):
        assert_pinned({"t.w": "escaped at 12 s"}, {"t.w": "diverged at 4996 s"}, tol)


@pytest.mark.parametrize("suite", ["issue22", "issue12"])
def test_every_pinned_number_has_a_measured_tolerance(pinned, suite):
    """A pinned number whose group the tolerance file does not know was never measured: re-measure
    (``python benchmarks/pin_spreads.py --write``) rather than let it fall back to the floor."""
    groups = Tolerances(suite).groups
    numeric = {group_of(p) for p, v in pinned[suite].items() if is_number(v) and not isinstance(v, int)}
    missing = sorted(numeric - set(groups))
    assert not missing, f"{len(missing)} pinned groups without a measured tolerance, e.g. {missing[:5]}"


@pytest.mark.parametrize("suite", ["issue22", "issue12"])
def test_no_tolerance_is_so_wide_that_it_pins_nothing(suite):
    """A relative tolerance above 1e-3 would not pin the number; such a quantity is checked another way."""
    wide = {g: v["rel"] for g, v in Tolerances(suite).groups.items() if v.get("rel", 0) > 1e-3}
    assert not wide, wide


@pytest.mark.parametrize("suite", ["issue22", "issue12"])
def test_a_millionth_in_any_pinned_coefficient_is_caught(pinned, suite):
    """Every coefficient and mass the pins hold fails its comparison when moved by one part in a million."""
    tol = Tolerances(suite)
    checked = 0
    for path, value in pinned[suite].items():
        if COEFFICIENT.search(path) and is_number(value) and value != 0:
            rel, absolute = tol.limits(path)
            assert mismatch(value * (1 + 1e-6), value, rel, absolute), (path, rel, absolute)
            checked += 1
    assert checked > 40, checked


def test_an_input_changed_by_a_millionth_fails_the_pins(pinned):
    """End to end: the spine's rfs identification with the known mass given 1e-6 larger no longer matches
    its pins (its coefficients move by about that much), while the unchanged run does."""
    import test_pins_spine as spine

    import nlid

    record = nlid.simulate("paper-numerical", seed=3, noise={"z": 0.02, "a": 0.02}, channels="z,a", duration=10)
    old = {p: v for p, v in pinned["issue22"].items() if p.startswith("identify.rfs_known.")}
    tol = Tolerances("issue22")

    def run(mass: float) -> dict:
        fit = nlid.identify(record, spine.TERMS, method="rfs", mass=mass)
        return leaves({"rfs_known": spine._drop_volatile(fit.to_dict())}, "identify")

    assert_pinned(run(0.2), old, tol, "unchanged")
    with pytest.raises(AssertionError, match=r"identify\.rfs_known\.coefficients\."):
        assert_pinned(run(0.2 * (1 + 1e-6)), old, tol, "mass x (1 + 1e-6)")


def test_the_tolerance_file_says_how_it_was_measured():
    data = json.loads(TOLERANCE_PATH.read_text())
    assert "benchmarks/pin_spreads.py" in data["about"]
    configs = data["measured_on"]["configurations"]
    assert {"auto", "kernel=Haswell", "threads=1"} <= set(configs) and any(c.startswith("perturb=") for c in configs)
    for suite in ("issue22", "issue12"):
        for group, item in data["suites"][suite]["groups"].items():
            assert ("rel" in item and "measured" in item) or ("abs" in item and "monte_carlo" in item), group
