import dataclasses
import json

import pytest

from nlid import Estimate, Option, OptionError
from nlid.base.jsonable import to_jsonable
from nlid.contract.identifier import resolve_options


def test_option_parsing():
    assert Option("n", "int", 10, "").parse("12") == 12
    assert Option("x", "float", 1.0, "").parse("2.5e3") == 2500.0
    assert Option("b", "bool", False, "").parse("yes") is True
    assert Option("l", "floats", (), "").parse("-0.03, 0.02") == (-0.03, 0.02)
    assert Option("k", "float", None, "", nullable=True).parse("auto") is None
    assert Option("m", "str", "a", "", choices=("a", "b")).parse("b") == "b"


@pytest.mark.parametrize(
    "option, value, message",
    [
        (Option("n", "int", 10, "", minimum=1), "0", ">= 1"),
        (Option("n", "int", 10, ""), "1.5", "expects an integer"),
        (Option("x", "float", 1.0, ""), "abc", "expects a number"),
        (Option("x", "float", 1.0, ""), "nan", "finite"),
        (Option("x", "float", 1.0, ""), "auto", "needs a value"),
        (Option("b", "bool", False, ""), "maybe", "true or false"),
        (Option("m", "str", "a", "", choices=("a", "b")), "c", "one of a, b"),
    ],
)
def test_option_errors(option, value, message):
    with pytest.raises(OptionError, match=message):
        option.parse(value)


def test_resolve_fills_defaults_and_rejects_unknown():
    declared = (Option("alpha", "float", 1.0, ""), Option("beta", "int", 2, ""))
    assert resolve_options(declared, {"beta": "5"}) == {"alpha": 1.0, "beta": 5}
    with pytest.raises(OptionError, match="did you mean 'alpha'"):
        resolve_options(declared, {"alpah": 1})


def test_estimate_is_frozen_plain_data():
    est = Estimate(coefficients={"z": -1.0}, diagnostics={"x": float("nan"), "y": (1, 2)})
    with pytest.raises(dataclasses.FrozenInstanceError):
        est.mass = 1.0  # type: ignore[misc]
    assert json.loads(json.dumps(to_jsonable(dict(est.diagnostics)), allow_nan=False)) == {"x": None, "y": [1, 2]}
