"""The slopes of the term language against finite differences, and where terms break."""

from __future__ import annotations

import numpy as np
import pytest

from nlid.model.terms import parse_term, px_coefficients
from nlid.model.terms.slopes import slopes, switches

PXC = px_coefficients(-0.02, 0.015)
SPELLINGS = [
    "z^3",
    "z*|z|",
    "|z|",
    "v*|v|",
    "v^3",
    "z^2*v",
    "sign(v)*|px(z)|",
    "v*|v|*|px(z)|",
    "px(z)^2",
    "tanh(v/0.01)",
    "sign(v)*exp(-|v|/0.01)",
    "sign(v)*exp(-(v/0.02)^2)",
    "gap(z, 0.001)",
    "stop(z, -0.0005)",
    "gap(z, 0.001)^3",
]


@pytest.mark.parametrize("spelling", SPELLINGS)
def test_slopes_are_the_value_and_its_derivatives(spelling):
    term = parse_term(spelling)
    rng = np.random.default_rng(0)
    z = rng.uniform(-0.03, 0.03, 200)
    v = rng.uniform(-0.5, 0.5, 200)
    g, gz, gv = slopes(term, z, v, PXC)
    cache: dict = {}
    assert np.allclose(g, term.evaluate(z, v, ((PXC[0] * z + PXC[1]) * z + PXC[2]) * z + PXC[3], cache), rtol=1e-12)
    h = 1e-7
    fz = (slopes(term, z + h, v, PXC)[0] - slopes(term, z - h, v, PXC)[0]) / (2 * h)
    fv = (slopes(term, z, v + h, PXC)[0] - slopes(term, z, v - h, PXC)[0]) / (2 * h)
    smooth = np.ones(z.size, dtype=bool)  # away from the breaks, where a difference quotient means nothing
    for var, level, _ in switches(term, PXC):
        x = z if var == "z" else v
        smooth &= np.abs(x - level) > 10 * h
    scale = max(1.0, float(np.max(np.abs(fz))), float(np.max(np.abs(fv))))
    assert np.allclose(gz[smooth], fz[smooth], atol=1e-5 * scale)
    assert np.allclose(gv[smooth], fv[smooth], atol=1e-5 * scale)


def test_switches_say_where_a_term_jumps_or_kinks():
    assert switches(parse_term("sign(v)")) == [("v", 0.0, True)]
    assert switches(parse_term("v*|v|")) == [("v", 0.0, False)]
    assert switches(parse_term("z^3")) == []
    found = switches(parse_term("sign(v)*|px(z)|"), PXC)
    assert ("v", 0.0, True) in found
    kinks = [level for var, level, jumps in found if var == "z"]
    assert any(abs(x + 0.02) < 1e-12 for x in kinks) and any(abs(x - 0.015) < 1e-12 for x in kinks)
    assert sorted(level for _, level, _ in switches(parse_term("gap(z, 0.001)"))) == [-0.001, 0.001]


def test_a_memory_term_has_no_slopes():
    with pytest.raises(ValueError, match="memory"):
        slopes(parse_term("bouc_wen(20, 200)"), np.zeros(3))
