import numpy as np
import pytest

from nlid import scoring
from nlid.errors import InputError
from nlid.estimation import balance
from nlid.model import physics
from nlid.model.terms import Model
from nlid.simulation.presets import get_preset


def test_potential_is_integral_of_stiffness(numerical):
    model, theta = numerical.model(), numerical.truth()["coefficients"]
    z = np.linspace(-0.04, 0.04, 9)
    expected = 1e6 * z**4 / 4 + 5e3 * z**3 / 3 - 500 * z**2 / 2 + 0.2 * 9.81 * z  # Eq. 7
    np.testing.assert_allclose(physics.potential(model, theta, z), expected, rtol=1e-10, atol=1e-15)


def test_elastic_and_damping_split(numerical, exact_record):
    model, theta = numerical.model(), numerical.truth()["coefficients"]
    z, v = exact_record.z[:100], exact_record.v[:100]
    K = physics.elastic(model, theta, z)
    D = physics.damping(model, theta, z, v)
    np.testing.assert_allclose(K, 1e6 * z**3 + 5e3 * z**2 - 500 * z + 1.962)
    np.testing.assert_allclose(D, v + 5 * v * np.abs(v))


def test_numeric_equilibria_agree_with_polynomial():
    # z*|z| is not a polynomial: solved numerically on the data range.
    model = Model.from_spec("z^3, z*|z|", without="v")
    theta = {"z^3": 1e6, "z*|z|": 0.0, "z": -500.0, "1": 1.962}
    poly = physics.equilibria(Model.from_spec("z^3", without="v"), {"z^3": 1e6, "z": -500.0, "1": 1.962})
    numeric = physics.equilibria(model, theta, z_range=(-0.05, 0.05))
    assert numeric.stable == pytest.approx(poly.stable, abs=1e-12)
    assert numeric.unstable == pytest.approx(poly.unstable, abs=1e-12)


def test_modal_damping_uses_the_linearisation():
    model = Model.from_spec("z^3, v*|px(z)|, sign(v)").with_px_roots((-0.028, 0.0267))
    theta = {"z^3": 7.57e5, "z": -565.0, "1": 2.6, "v": 4.26, "v*|px(z)|": -1.32, "sign(v)": 1.0}
    for m in physics.modal(model, theta, 0.265):
        px = model.px(np.array([m.equilibrium]))[0]
        assert m.damping == pytest.approx(4.26 - 1.32 * abs(px))  # Coulomb term left out
        assert m.zeta == pytest.approx(m.damping / (2 * 0.265 * 2 * np.pi * m.fn_hz))


def test_stiffness_roots_for_px(numerical):
    roots = physics.stiffness_roots(numerical.model(), numerical.truth()["coefficients"])
    expected = np.sort(np.roots([1e6, 5e3, -500]))
    assert roots == pytest.approx(tuple(expected))
    with pytest.raises(InputError, match="double well"):
        physics.stiffness_roots(Model.from_spec("z^3"), {"z^3": 1.0, "z": 1.0})


def test_epsilon_eq26():
    measured = np.array([1.0, -1.0, 1.0, -1.0])
    assert scoring.epsilon(measured, measured) == 0.0
    assert scoring.epsilon(measured, 0.9 * measured) == pytest.approx(10.0)


def test_regression_data_filters_consistently_when_acceleration_is_estimated(exact_record, numerical):
    model = numerical.model()
    theta = model.vector(numerical.truth()["coefficients"])
    measured = balance.regression_data(exact_record, model)
    assert measured.filtered_at is None
    r = measured.restoring_force(0.2) - measured.G @ theta
    assert np.max(np.abs(r)) < 1e-9
    estimated = balance.regression_data(exact_record.without("v", "a"), model)
    assert estimated.filtered_at is not None
    eps = scoring.epsilon(estimated.restoring_force(0.2), estimated.G @ theta)
    assert eps < 0.5, "with f and regressors filtered alike, the true model fits in-band"


def test_damping_slice_matches_the_true_damping(exact_record, numerical):
    model, theta = numerical.model(), numerical.truth()["coefficients"]
    data = balance.regression_data(exact_record, model)
    sl = scoring.damping_slice(data, model, theta, numerical.mass, z0=-0.02, half_width=0.002)
    np.testing.assert_allclose(
        sl.measured, physics.damping(model, theta, data.z, data.v)[np.abs(data.z + 0.02) <= 0.002], atol=1e-9
    )
    assert sl.model[0] == pytest.approx(sl.v_grid[0] + 5 * sl.v_grid[0] * abs(sl.v_grid[0]))


def test_regression_data_untrimmed_keeps_every_sample(short_record, numerical):
    model = numerical.model()
    record = short_record.without("v", "a")
    trimmed = balance.regression_data(record, model)
    full = balance.regression_data(record, model, trim=False)
    assert full.G.shape[0] == record.n and full.kept == trimmed.kept
    np.testing.assert_array_equal(full.G[full.kept], trimmed.G)
    np.testing.assert_array_equal(full.a[full.kept], trimmed.a)
    without = balance.regression_data(record, model, trim=False, regressors=False)
    assert without.G.shape == (record.n, 0)
    np.testing.assert_array_equal(without.a, full.a)
    np.testing.assert_array_equal(without.v, full.v)


def test_damping_slice_of_a_filtered_balance_keeps_the_stiffness_out():
    # with z and a noisy the balance is filtered (~26 Hz): K must be removed in the same band
    preset = get_preset("paper-experimental")
    model, theta = preset.model(), preset.truth()["coefficients"]
    record = preset.simulate(3, noise=0.02, channels=("z", "a"))
    data = balance.regression_data(record, model)
    assert data.filtered_at is not None
    sl = scoring.damping_slice(data, model, theta, preset.mass, z0=-0.03)
    true = physics.damping(model, theta, np.full(sl.v.size, -0.03), sl.v)
    # measured 0.50 of rms(D); subtracting K(z) sample by sample gave 1.3
    assert np.sqrt(np.mean((sl.measured - true) ** 2)) < 0.75 * np.sqrt(np.mean(true**2))


def test_records_sharing_their_force_give_the_force_balances_they_give_alone(short_record, numerical):
    """share_channels re-uses the filtered force and acceleration of equal channels only, to the bit."""
    from nlid.data.record import Record

    model = numerical.model()
    rng = np.random.default_rng(2)
    fc = 40.0

    def noisy(z_sd, a=short_record.a):
        z = short_record.z + z_sd * rng.standard_normal(short_record.n)
        return Record(f=short_record.f, fs=short_record.fs, z=z, a=a)

    first = noisy(1e-5)
    balance.regression_data(first, model, cutoff=fc)
    for record in (noisy(2e-5), noisy(1e-5, a=short_record.a + 1e-3)):
        copy = Record(f=record.f, fs=record.fs, z=record.z, a=record.a)  # the same record, nothing cached
        balance.share_channels(first, record)
        shared, fresh = (
            balance.regression_data(record, model, cutoff=fc),
            balance.regression_data(copy, model, cutoff=fc),
        )
        for name in ("f", "a", "G", "z", "v"):
            np.testing.assert_array_equal(getattr(shared, name), getattr(fresh, name))
        # the equal force is the first record's; an acceleration that differs is filtered anew
        cache, first_cache = balance._record_cache(record), balance._record_cache(first)
        assert cache[("f", fc)] is first_cache[("f", fc)]
        assert (cache[("a", fc)] is first_cache[("a", fc)]) == np.array_equal(record.a, first.a)


def test_filtered_regressors_are_each_terms_lowpass_and_their_cache_is_not_the_callers(short_record, numerical):
    """The columns filtered in a column-major matrix and cached as its read-only columns are the low-pass of each
    term's values to the bit; the caller's G is its own row-major array, and writing to it leaves the cache."""
    from nlid.data.record import Record
    from nlid.signal import derivatives

    model = numerical.model()
    record = short_record.without("v", "a")
    data = balance.regression_data(record, model, trim=False)
    assert data.G.flags.c_contiguous and data.G.flags.writeable
    fc = data.filtered_at
    expected = model.evaluate(data.z, data.v)
    for j in range(expected.shape[1]):
        column = expected[:, j]
        if np.any(column != column[0]):
            expected[:, j] = derivatives.lowpass(column, record.fs, fc)
    np.testing.assert_array_equal(data.G, expected)
    data.G[:] = 0.0
    again = balance.regression_data(record, model, trim=False)  # from the cache
    np.testing.assert_array_equal(again.G, expected)
    copy = Record(f=record.f, fs=record.fs, z=record.z)  # nothing cached: computed afresh
    np.testing.assert_array_equal(balance.regression_data(copy, model, trim=False).G, expected)


def test_regressor_matrix_in_either_layout_has_the_same_numbers(short_record, numerical):
    model = numerical.model()
    rows = model.evaluate(short_record.z, short_record.v)
    columns = model.evaluate(short_record.z, short_record.v, order="F")
    assert rows.flags.c_contiguous and columns.flags.f_contiguous
    np.testing.assert_array_equal(rows, columns)
    with pytest.raises(InputError, match="order="):
        model.evaluate(short_record.z, short_record.v, order="K")
