import numpy as np
import pytest

from nlid import Estimate, IdentificationError, Identifier, PluginError, identify
from nlid.simulation.presets import get_preset


@pytest.fixture(scope="module")
def experimental():
    p = get_preset("paper-experimental").with_overrides(duration=30.0)
    return p, p.simulate(0, channels=("z", "v", "a"))


def test_px_fixed_point_converges_to_the_true_roots(experimental):
    preset, rec = experimental
    res = identify(rec, preset.terms, "rfs", mass=preset.mass)
    it = res.diagnostics["px_iteration"]
    assert it["converged"] and 1 <= it["iterations"] <= 10
    assert res.px_roots == pytest.approx(preset.model().px_roots, rel=1e-4)  # the iteration's tolerance
    truth = preset.truth()["coefficients"]
    for name, value in res.coefficients.items():
        assert value == pytest.approx(truth[name], rel=1e-4), name


class _Scripted(Identifier):
    """Returns a double-well stiffness whose roots follow a script."""

    name = "scripted"
    needs_mass = True

    def __init__(self, roots):
        super().__init__()
        self.roots = iter(roots)

    def identify(self, record, model, *, mass=None):
        zm, zp = next(self.roots)
        k3 = 1e6
        coeffs = dict.fromkeys(model.names, 0.0)
        coeffs.update({"z^3": k3, "z^2": -k3 * (zm + zp), "z": k3 * zm * zp})
        return Estimate(coefficients=coeffs)


def test_px_iteration_stops_when_diverging(experimental):
    _, rec = experimental
    roots = [(-0.02 * 1.1**k, 0.02 * 1.1**k) for k in range(40)]
    with pytest.raises(IdentificationError, match="diverging"):
        identify(rec, "z^3, z^2, sign(v)*|px(z)|", _Scripted(roots), mass=0.265)


def test_px_iteration_stops_when_oscillating(experimental):
    _, rec = experimental
    roots = [(-0.02, 0.02), (-0.03, 0.03)] * 20
    with pytest.raises(IdentificationError, match="oscillating"):
        identify(rec, "z^3, z^2, sign(v)*|px(z)|", _Scripted(roots), mass=0.265)


def test_core_recomputes_epsilon_and_fills_physics(short_record):
    class Liar(_Scripted):
        def identify(self, record, model, *, mass=None):
            coeffs = {n: record.meta["truth"]["coefficients"][n] for n in model.names}
            return Estimate(coefficients=coeffs, diagnostics={"eps_percent": 123.0})  # never trusted

    res = identify(short_record, "z^3, z^2, v*|v|", Liar([]), mass=0.2)
    assert res.eps_percent < 1e-6 and res.scores.eps_percent == res.eps_percent
    assert res.diagnostics["eps_percent"] == 123.0  # kept as the plugin's diagnostic, not used
    assert len(res.equilibria.stable) == 2 and len(res.modal) == 2
    assert res.method == "scripted" and res.options == {}
    assert np.isfinite(res.seconds)


def test_core_refuses_a_wrong_estimate(short_record):
    class Wrong(_Scripted):
        def __init__(self, answer):
            super().__init__([])
            self.answer = answer

        def identify(self, record, model, *, mass=None):
            return self.answer(model)

    with pytest.raises(PluginError, match="not nlid.Estimate"):
        identify(short_record, "z^3", Wrong(lambda m: dict.fromkeys(m.names, 1.0)), mass=0.2)
    with pytest.raises(PluginError, match="but the model is"):
        identify(short_record, "z^3", Wrong(lambda m: Estimate({"z^3": 1.0})), mass=0.2)
    with pytest.raises(IdentificationError, match="non-finite"):
        identify(short_record, "z^3", Wrong(lambda m: Estimate(dict.fromkeys(m.names, float("nan")))), mass=0.2)
