import numpy as np
import pytest

from nlid import InputError, TermError
from nlid.model.terms import Model, px_coefficients


def test_defaults_and_canonical_order():
    m = Model.from_spec("v*|v|, z^3, z^2")
    assert m.names == ("1", "z", "z^2", "z^3", "v", "v*|v|")
    assert Model.from_spec("z^3", without="1").names == ("z", "z^3", "v")
    with pytest.raises(InputError, match="no terms"):
        Model.from_spec("", defaults=False)
    assert Model.from_spec("z^3, z^2") == Model.from_spec("z^2, z^3")


def test_listing_a_default_is_allowed_but_duplicates_are_not():
    assert Model.from_spec("z, v, z^3").names == ("1", "z", "z^3", "v")
    with pytest.raises(TermError, match="same function"):
        Model.from_spec("v*|v|, sign(v)*|v|^2")
    with pytest.raises(TermError, match="listed twice"):
        Model.from_spec("z^3, z^3")


def test_px_coefficients_satisfy_eq9():
    zm, zp = -0.028, 0.0267
    alpha, beta, gamma, delta = px_coefficients(zm, zp)
    px = np.poly1d([alpha, beta, gamma, delta])
    assert px(zm) == pytest.approx(0, abs=1e-12)
    assert px(zp) == pytest.approx(0, abs=1e-12)
    assert px(0.0) == 1.0 and px.deriv()(0.0) == 0.0
    with pytest.raises(InputError):
        px_coefficients(0.01, 0.02)


def test_evaluate_needs_velocity_and_roots():
    m = Model.from_spec("z^3, sign(v)*|px(z)|")
    z = np.linspace(-0.03, 0.03, 7)
    with pytest.raises(InputError, match="no velocity"):
        m.evaluate(z)
    with pytest.raises(InputError, match="roots"):
        m.evaluate(z, z)
    G = m.with_px_roots((-0.028, 0.0267)).evaluate(z, np.ones_like(z))
    assert G.shape == (7, len(m))


def test_vector_and_dict_round_trip():
    m = Model.from_spec("z^3")
    theta = m.vector({"z^3": 2.0, "z": -1.0, "sign(v)*|v|^1": 0.5})
    assert m.as_dict(theta) == {"1": 0.0, "z": -1.0, "z^3": 2.0, "v": 0.5}
    with pytest.raises(InputError, match="not in the model"):
        m.vector({"z^5": 1.0})
