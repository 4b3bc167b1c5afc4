"""NSI (nsi-ip, nsi-shift) on structures of several DOFs: short noise-free records recover the truth tightly."""

from __future__ import annotations

import numpy as np
import pytest

import nlid
from nlid.errors import InputError
from nlid.simulation.presets import get_preset

DOUBLE_WELL = "(z1-z2)^3, (z1-z2)^2, (v1-v2)*|v1-v2|"
# The noise correction estimates each DOF's noise from its spectrum above 0.35 fs; on a noise-free double well the
# signal's own content there is read as noise (measured: well-2 mode-1 frequency 0.54 % off with it, 0.02 % without),
# so the noise-free double-well tests switch it off.
EXACT = {"noise_correction": False}


def _rel(got, true):
    return np.abs(np.asarray(got, dtype=float) / np.asarray(true, dtype=float) - 1.0)


@pytest.fixture(scope="module")
def chain20():
    """3dof-cubic, 20 s, noise-free."""
    return get_preset("3dof-cubic").with_overrides(duration=20.0).simulate(1)


@pytest.fixture(scope="module")
def well20():
    """2dof-double-well, 20 s, noise-free."""
    return get_preset("2dof-double-well").with_overrides(duration=20.0).simulate(2)


@pytest.mark.parametrize("method", ["nsi-ip", "nsi-shift"])
def test_chain_cubic_and_underlying_linear_system(chain20, method):
    ref = chain20.meta["reference"]
    res = nlid.identify(chain20, "z3^3", method, mass="estimate")  # not the record's meta['mass']
    assert _rel(res.structure.coefficient("z3^3"), ref["coefficients"]["z3^3"]) < 5e-3
    assert np.all(_rel(res.linear_modes.fn_hz, ref["linear_modes"]["fn_hz"]) < 5e-4)
    assert np.all(_rel(res.linear_modes.zeta, ref["linear_modes"]["zeta"]) < 2e-2)
    assert np.all(_rel(np.diag(res.structure.M), np.diag(ref["M"])) < 5e-3)  # the mass matrix is estimated
    assert np.allclose(res.structure.K, ref["K"], rtol=0, atol=2e-3 * np.abs(ref["K"]).max())
    assert res.mass_estimated and res.diagnostics["order"] == 6
    h = res.arrays["frf_matrix"]
    assert h.shape[1:] == (3, 3) and np.allclose(h, np.swapaxes(h, 1, 2))  # reciprocity of the ULS FRF matrix
    # nsi-shift's spectra are those of its shifted inputs (z3 - z3*)^k
    assert ("coef_spectrum:z3^3" if method == "nsi-ip" else "coef_spectrum:xi_3-0^3") in res.arrays


def test_chain_with_a_given_mass_matrix(chain20):
    ref = chain20.meta["reference"]
    res = nlid.identify(chain20, "z3^3", "nsi-ip", mass=ref["M"])
    assert not res.mass_estimated and res.diagnostics["mass_source"] == "given"
    assert _rel(res.structure.coefficient("z3^3"), ref["coefficients"]["z3^3"]) < 5e-3


def test_double_well_input_perturbation(well20):
    ref = well20.meta["reference"]
    res = nlid.identify(well20, DOUBLE_WELL, "nsi-ip", mass="estimate", options=EXACT)
    d = res.diagnostics
    assert d["k_tilde"] > 0 and not d["k_tilde_trials"][0]["accepted"]  # K alone is unstable: perturbed
    for name, value in ref["coefficients"].items():
        assert _rel(res.structure.coefficient(name), value) < 1e-2, name
    got = np.array(res.equilibria.stable)
    true = np.array(ref["equilibria"]["stable"])
    assert got.shape == true.shape and np.allclose(got, true, atol=2e-4)
    for mode, tm in zip(res.modes, ref["modes"], strict=True):
        assert np.all(_rel(mode.fn_hz, tm["fn_hz"]) < 5e-3)


def test_double_well_zero_reference_shift_per_well(well20):
    ref = well20.meta["reference"]
    res = nlid.identify(well20, DOUBLE_WELL, "nsi-shift", mass="estimate", options=EXACT)
    wells = res.diagnostics["wells"]
    assert len(wells) == 2 and len(res.modes) == 2
    for name, value in ref["coefficients"].items():
        assert _rel(res.structure.coefficient(name), value) < 1e-2, name
    for mode, tm, z in zip(res.modes, ref["modes"], ref["equilibria"]["stable"], strict=True):
        assert np.allclose(mode.equilibrium, z, atol=2e-4)
        assert np.all(_rel(mode.fn_hz, tm["fn_hz"]) < 5e-3)
        assert mode.source.startswith("ULS of the well")
    assert "frf_matrix@well1" in res.arrays


def test_structure_options_refused(chain_record):
    with pytest.raises(InputError, match="order 6"):
        nlid.identify(chain_record, "z3^3", "nsi-ip", options={"order": 2})
    with pytest.raises(InputError, match="linear"):
        nlid.identify(chain_record, "z3^3, (z2-z3)", "nsi-ip")


def test_one_dof_identifiers_still_refuse_structures(chain_record):
    """An identifier that keeps the default declaration (``dofs = "single"``) is refused, naming it."""
    from nlid_rfs import RestoringForceSurface

    class OneDof(RestoringForceSurface):
        name = "one-dof-rfs"
        dofs = "single"

    with pytest.raises(InputError, match="'one-dof-rfs' identifies one degree of freedom"):
        nlid.identify(chain_record, "z3^3", OneDof())


def test_sharpened_interval_means_have_the_held_value_gain_of_a_mass():
    """Interval means of ``cos(w t)`` sharpened: gain ``tan(x)/x`` (``x = w dt / 2``) to O(x^4), unlike the mean."""
    from nlid_nsi.structure import sharpen

    dt, w = 1e-3, 0.3e3  # w dt = 0.3
    t = np.arange(4000) * dt
    means = (np.sin(w * (t + dt)) - np.sin(w * t)) / (w * dt)  # exact interval means of cos(w t)
    plain = np.abs(np.fft.rfft(means[1000:3000] * np.hanning(2000))).max()
    sharp = np.abs(np.fft.rfft(sharpen(means)[1000:3000] * np.hanning(2000))).max()
    x = w * dt / 2
    assert abs(sharp / plain - np.tan(x) / x) < 3e-4
    assert sharp / plain - 1.0 > 5e-3


def test_band_floor_raises_only_cutoffs_inside_the_band_of_a_used_dof():
    from nlid_nsi.structure_motion import BAND_FACTOR, Motion, band_floor

    motion = Motion(np.zeros((4, 2)), np.zeros((4, 2)), "measured", (67.0, 400.0))
    fn = np.array([13.0, 50.7])
    assert band_floor(motion, fn, {}, 2048.0, {0, 1}) == pytest.approx(BAND_FACTOR * 50.7)
    assert band_floor(motion, fn, {}, 2048.0, {1}) is None  # DOF 1 is in no channel
    assert band_floor(motion, fn, {"denoise_cutoff": 67.0}, 2048.0, {0, 1}) is None  # the user's cut-off is kept


def test_gram_clipping_from_the_low_eigenpairs_matches_the_full_decomposition():
    from nlid_nsi.structure import _definite

    rng = np.random.default_rng(3)
    s, c = 6, 4
    n = s * c
    vec = np.linalg.qr(rng.standard_normal((n, n)))[0]
    ev = np.r_[-3e-3, -1e-4, 1e-9 * np.ones(3), np.logspace(-6, 0, n - 5)]  # two negative, three below the floor
    flat = (vec * ev) @ vec.T
    flat = 0.5 * (flat + flat.T)
    out = _definite(flat.reshape(s, c, s, c)).reshape(n, n)
    scale = np.trace(flat) / n
    w, v = np.linalg.eigh(flat)
    full = (v * np.maximum(w, 1e-8 * scale)) @ v.T  # the eigenvalues raised to the floor, every pair
    assert np.abs(out - full).max() < 1e-12 * np.abs(full).max()
    assert np.linalg.eigvalsh(0.5 * (out + out.T)).min() > 0.99e-8 * scale
    definite = (vec * np.logspace(-6, 0, n)) @ vec.T
    definite = 0.5 * (definite + definite.T)
    assert np.array_equal(_definite(definite.reshape(s, c, s, c)).reshape(n, n), definite)  # kept as it is


def test_shared_noise_paths_give_the_same_noise_model():
    from nlid_nsi.structure import SHARPEN
    from nlid_nsi.structure_motion import structure_motion
    from nlid_nsi.structure_noise import noise_paths, noise_variances, structure_noise_model

    rec = get_preset("3dof-cubic").with_overrides(duration=4.0).simulate(0, noise=0.02)
    motion = structure_motion(rec, {})
    b = np.array([0.0, 0.0, 1.0])
    columns = [("x^3", (lambda x, v: x**3, b)), ("x^2", (lambda x, v: x**2, b))]
    scales = np.ones(1 + len(columns) + rec.n_dofs)
    fresh = structure_noise_model(rec, motion, columns, scales, 1, (), 16, SHARPEN)
    paths = noise_paths(rec, motion, 16, SHARPEN, noise_variances(rec, motion))
    shared = structure_noise_model(rec, motion, columns, scales, 1, (), 16, SHARPEN, paths)
    assert np.array_equal(fresh.xcorr, shared.xcorr)
    assert np.array_equal(fresh.moments, shared.moments)
    again = structure_motion(rec, {}, 0.0, motion.suggested_hz)
    assert motion.cutoffs_hz == again.cutoffs_hz and np.array_equal(motion.z, again.z)
