"""rfs, sindy and oe on structures of several DOFs (short records, so the suite stays fast)."""

from __future__ import annotations

import numpy as np
import pytest

import nlid
from nlid.contract.structure_estimate import StructureEstimate
from nlid.errors import InputError
from nlid.identified.structure import IdentifiedStructure

WELL_TERMS = "(z1-z2)^3, (z1-z2)^2, (v1-v2)*|v1-v2|"


def _errors(fit, record) -> dict[str, float]:
    truth = record.meta["reference"]["coefficients"]
    return {k: abs(fit.coefficients[k] / v - 1) for k, v in truth.items()}


@pytest.mark.parametrize("method", ["rfs", "sindy"])
@pytest.mark.parametrize("given_mass", [True, False])
def test_noise_free_chain_recovers_element_and_linear_system(chain_record, method, given_mass):
    rec = chain_record
    fit = nlid.identify(rec, "z3^3", method, mass=rec.mass if given_mass else "estimate")
    assert isinstance(fit, IdentifiedStructure)
    assert max(_errors(fit, rec).values()) < 1e-4
    ref = rec.meta["reference"]
    K, C = np.asarray(ref["K"]), np.asarray(ref["C"])
    assert np.abs(fit.K - K).max() < 1e-4 * np.abs(K).max()
    assert np.abs(fit.C - C).max() < 1e-3 * np.abs(C).max()
    assert fit.mass_estimated is not given_mass
    assert np.allclose(fit.M, np.asarray(ref["M"]), rtol=1e-4)
    truth_fn = np.asarray(ref["linear_modes"]["fn_hz"])
    assert np.allclose(fit.linear_modes.fn_hz, truth_fn, rtol=1e-5)


@pytest.mark.parametrize("method", ["rfs", "sindy"])
def test_noise_free_double_well_shares_the_element_between_both_masses(well_record, method):
    rec = well_record
    fit = nlid.identify(rec, WELL_TERMS, method, mass=rec.mass)
    assert max(_errors(fit, rec).values()) < 1e-4
    # the two wells of the truth, from the identified structure
    truth = sorted(p[0] - p[1] for p in rec.meta["reference"]["equilibria"]["stable"])
    found = sorted(p[0] - p[1] for p in fit.equilibria.stable)
    assert np.allclose(found, truth, rtol=1e-4)


def test_reversed_spelling_gives_the_same_element_with_its_sign(well_record):
    rec = well_record
    fit = nlid.identify(rec, "(z2-z1)^3, (z1-z2)^2, (v2-v1)*|v2-v1|", "rfs", mass=rec.mass)
    truth = rec.meta["reference"]["coefficients"]
    assert fit.coefficient("(z2-z1)^3") == pytest.approx(-truth["(z1-z2)^3"], rel=1e-4)


def test_rfs_low_noise_estimated_derivatives(chain):
    rec = chain.simulate(3, noise={"z": 0.005}, channels=("z",))
    fit = nlid.identify(rec, "z3^3", "rfs", mass=rec.mass)
    assert _errors(fit, rec)["z3^3"] < 0.02
    truth_fn = np.asarray(rec.meta["reference"]["linear_modes"]["fn_hz"])
    assert np.allclose(fit.linear_modes.fn_hz, truth_fn, rtol=0.005)
    assert fit.standard_errors["z3^3"] > 0
    assert all(np.isfinite(fit.eps_percent))


def test_sindy_automatic_library_finds_the_connection(chain_record):
    rec = chain_record
    fit = nlid.identify(rec, "z3^3", "sindy", mass=rec.mass, options={"library": "automatic", "degree": 3})
    assert _errors(fit, rec)["z3^3"] < 1e-3
    assert fit.diagnostics["extra_elements"] == {}
    library = fit.diagnostics["library"]
    assert "(z1-z2)^3" in library and "z1^3" in library and "sign(v2-v3)" in library


def test_linear_element_is_refused(chain_record):
    with pytest.raises(InputError, match="linear"):
        nlid.identify(chain_record, "z3^3, z1-z2", "rfs", mass=chain_record.mass)


def test_oe_improves_a_perturbed_start(chain, monkeypatch):
    import nlid_oe.structure as oe_structure

    rec = chain.with_overrides(duration=2.0).simulate(5, noise={"z": 0.01})
    truth = rec.meta["reference"]
    K, C, M = (np.asarray(truth[k]) for k in ("K", "C", "M"))
    start_theta = 1.2 * truth["coefficients"]["z3^3"]

    def perturbed(record, elements, method, mass=None):
        estimate = StructureEstimate(coefficients={"z3^3": start_theta}, K=K * 1.01, C=C * 0.9, static=np.zeros(3))
        return IdentifiedStructure.from_estimate(estimate, elements=elements, record=record, method="start", mass=M)

    monkeypatch.setattr(oe_structure, "identify", perturbed)
    fit = nlid.identify(rec, "z3^3", "oe", mass=M, options={"init": "rfs"})
    d = fit.diagnostics
    assert sum(d["free_run_error_percent"]) < 0.5 * sum(d["free_run_error_percent_start"])
    before = abs(start_theta / truth["coefficients"]["z3^3"] - 1)
    assert _errors(fit, rec)["z3^3"] < 0.25 * before
    assert np.abs(fit.K - K).max() < 0.005 * np.abs(K).max()


def test_oe_fits_the_segment_states_and_recovers_a_noise_free_structure(chain, monkeypatch):
    # v is estimated from z by the differentiating filter, so the segments' states taken from the data are off:
    # only with the states fitted does the free run match the record at the true model
    import nlid_oe.structure as oe_structure

    rec = chain.with_overrides(duration=2.0).simulate(1, channels=("z",))
    truth = rec.meta["reference"]
    K, C, M = (np.asarray(truth[k]) for k in ("K", "C", "M"))

    def perturbed(record, elements, method, mass=None):
        coefficients = {"z3^3": 1.2 * truth["coefficients"]["z3^3"]}
        estimate = StructureEstimate(coefficients=coefficients, K=K * 1.01, C=C * 0.9, static=np.zeros(3))
        return IdentifiedStructure.from_estimate(estimate, elements=elements, record=record, method="start", mass=M)

    monkeypatch.setattr(oe_structure, "identify", perturbed)
    # the preset's integrator (8 RK4 steps per sample), so the true model reproduces the record
    fit = nlid.identify(rec, "z3^3", "oe", mass=M, options={"init": "rfs", "oversample": 8})
    assert _errors(fit, rec)["z3^3"] < 1e-5
    assert np.abs(fit.K - K).max() < 1e-6 * np.abs(K).max()
    assert np.abs(fit.C - C).max() < 1e-4 * np.abs(C).max()
    assert max(fit.diagnostics["free_run_error_percent"]) < 1e-4


def test_oe_on_a_noisy_structure_reaches_the_noise_and_improves_on_rfs(chain):
    # with every segment's state fitted the free run reaches the noise floor: the least squares is at most the
    # noise's, its value at the truth (from the data's states the free run misses by several times the noise);
    # the element lands within its standard errors, and the underlying linear modes (which rfs biases through
    # the noise on z) come closer than rfs's
    short = chain.with_overrides(duration=2.0)
    rec, clean = short.simulate(0, noise={"z": 0.02}, channels=("z",)), short.simulate(0)
    noise = 100 * np.sqrt(np.mean((rec.z - clean.z) ** 2, axis=0) / np.mean(rec.z**2, axis=0))
    truth = rec.meta["reference"]
    rfs = nlid.identify(rec, "z3^3", "rfs", mass=rec.mass)
    fit = nlid.identify(rec, "z3^3", "oe", mass=rec.mass, options={"init": "rfs"})
    assert fit.diagnostics["init_coefficients"] == pytest.approx(dict(rfs.coefficients))
    assert np.sum(np.square(fit.diagnostics["free_run_error_percent"])) <= np.sum(noise**2)
    assert min(fit.diagnostics["free_run_error_percent_start"]) > 2 * max(noise)
    error = abs(fit.coefficient("z3^3") - truth["coefficients"]["z3^3"])
    assert error < 4 * fit.standard_errors["z3^3"]
    fn = np.asarray(truth["linear_modes"]["fn_hz"])
    assert np.abs(fit.linear_modes.fn_hz / fn - 1).max() <= np.abs(rfs.linear_modes.fn_hz / fn - 1).max()


def test_free_run_segments_continue_one_free_run(chain_record):
    from nlid.simulation.structure import free_run, free_run_segments

    rec = chain_record
    model = nlid.identify(rec, "z3^3", "rfs", mass=rec.mass).structure
    z, v, _ = free_run(model, rec.f, rec.fs, force_hold="zoh", oversample=4)
    starts = np.array([0, 700, 1500])
    states = np.column_stack([z, v])[starts]
    zs, ends = free_run_segments(model, rec.f, rec.fs, starts, states, force_hold="zoh", oversample=4)
    assert np.allclose(zs, z, rtol=0, atol=1e-12 * np.abs(z).max())
    assert np.allclose(ends[:-1], states[1:], rtol=0, atol=1e-12 * np.abs(states).max())
    with pytest.raises(InputError, match="starts"):
        free_run_segments(model, rec.f, rec.fs, [5, 10], states[:2], force_hold="zoh")
