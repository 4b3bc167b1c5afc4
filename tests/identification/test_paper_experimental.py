"""Issue 8: the paper's experimental study (Sec. 4) on the paper-experimental preset.

Every installed identifier, on one record with 2 % noise on displacement and
acceleration: the friction law of Eq. 24 lowers the residual against the
stiffness terms alone (the paper: 4.42 % against 8.38 % on its rig), and the
fixed point on the px(z) roots converges.
"""

import numpy as np
import pytest

from nlid import identify
from nlid.contract.registry import default_registry
from nlid.model import physics
from nlid.simulation.presets import get_preset

FULL = "z^3, z^2, sign(v)*|px(z)|, v*|px(z)|, v*|v|*|px(z)|, v^3*|px(z)|"
STIFFNESS_ONLY = "z^3, z^2"  # with 1, z, v: the paper's NSI always keeps the underlying-linear system


@pytest.fixture(scope="module")
def record():
    return get_preset("paper-experimental").simulate(0, noise={"z": 0.02, "a": 0.02}, channels=("z", "a"))


# the equation-error identifiers; oe (output error) on this 120-s chaotic record needs ~270 shooting segments
# and does not converge within its default evaluations (docs/oe.md, "Not when")
EQUATION_ERROR = [name for name in default_registry().names() if name != "oe"]


@pytest.mark.slow
@pytest.mark.parametrize("method", EQUATION_ERROR)
def test_damping_terms_lower_the_residual_and_px_converges(record, method):
    full = identify(record, FULL, method, mass=0.265)
    stiff = identify(record, STIFFNESS_ONLY, method, mass=0.265)
    assert full.eps_percent < stiff.eps_percent, (full.eps_percent, stiff.eps_percent)
    it = full.diagnostics["px_iteration"]
    assert it["converged"] and it["iterations"] <= 10
    truth = get_preset("paper-experimental").model().px_roots
    assert full.px_roots == pytest.approx(truth, rel=0.02)


@pytest.mark.slow
def test_built_in_study_summary_has_every_c_j_with_quality_and_interval(tmp_path):
    """The built-in study, cut to one shorter record and nsi-ip: what issue 8 wants in its summary."""
    from nlid.study import LocalExecutor, parse_study, run_study
    from nlid.study.config import builtin_studies

    text = builtin_studies()["paper-experimental"].read_text()
    for old, new in (
        ("repetitions = 3", "repetitions = 1"),
        ('identifiers = ["rfs", "sindy", "nsi-ip", "nsi-shift"]', 'identifiers = ["nsi-ip"]'),
        ('[options.sindy]\nlibrary = "automatic"\n', ""),  # sindy is not in this cut-down study
        ('preset = "paper-experimental"', 'preset = "paper-experimental"\noverrides = { duration = 60.0 }'),
    ):
        assert old in text, old
        text = text.replace(old, new)
    outcome = run_study(parse_study(text), tmp_path, executor=LocalExecutor(jobs=1), progress=False)
    summary = outcome.summary
    main = next(s for s in summary.split("\n## ") if s.startswith("experimental / main"))
    quality = main.split("### Quality indicator")[1].split("###")[0]
    posterior = main.split("### Posterior (emcee): 90 % credible interval")[1].split("###")[0]
    for term in ("sign(v)*\\|px(z)\\|", "v*\\|px(z)\\|", "v*\\|v\\|*\\|px(z)\\|", "v^3*\\|px(z)\\|"):
        assert term in quality and term in posterior, term
    row = next(line for line in posterior.splitlines() if line.startswith("| nsi-ip |"))
    assert row.count("[") == 5 and "covers" in row  # v and c0-c3: an interval each, checked against the truth
    assert "## experimental / stiffness-only" in summary


def test_fusion_gives_the_damping_terms_a_cleaner_velocity(record):
    """acceleration=fuse: the v (and z) the damping terms are built from are closer to the truth than with ignore.

    Measured on seeds 0-3 and 7: velocity error 0.69-0.70 % of std(v) fused against 4.0-4.5 % ignored, and
    the noise model's sigma_v within 2 % of the actual error (fused). The coefficients themselves are not
    better on every record (docs/nsi.md): this checks the mechanism, with wide margins.
    """
    from nlid_nsi.common import reconstruction, velocity_estimate
    from nlid_nsi.intersample import force_interval_mean

    preset = get_preset("paper-experimental")
    clean = preset.simulate(0, channels=("z", "v", "a"))
    vel = velocity_estimate(record, None, None)
    f_held = force_interval_mean(record.f, "zoh")
    inner = slice(record.n // 20, -record.n // 20)
    uls = (preset.mass, 4.0, 250.0)  # a stable surrogate near nsi-ip's perturbed ULS
    err = {}
    for acc in ("ignore", "fuse"):
        opt = {"acceleration": acc, "crossover": None, "denoise_cutoff": None}
        rec, _ = reconstruction(record, vel, f_held, uls, opt)
        err[acc] = (np.std((rec.v - clean.v)[inner]), np.std((rec.z - clean.z)[inner]))
        if acc == "fuse":
            assert rec.crossover is not None and 1.0 < rec.crossover < 0.4 * record.fs
            assert np.sqrt(rec.velocity_noise_var) == pytest.approx(err[acc][0], rel=0.2)
    assert err["fuse"][0] < 0.5 * err["ignore"][0], err
    assert err["fuse"][1] < 0.8 * err["ignore"][1], err


@pytest.mark.slow
def test_fusion_lowers_the_damping_force_error_against_ignore(record):
    """The identified damping force D(z, v) (Eq. 24) is closer to the truth with acceleration=fuse.

    Relative RMS error of D over the noise-free motion, seeds 0-23 (docs/nsi.md): 1.66 % mean fused
    against 3.41 % ignored, fused lower on 23 of the 24 records (seed 18: 3.08 against 2.66 %); this
    record (seed 0): 1.17 against 2.65 %.
    """
    preset = get_preset("paper-experimental")
    model, truth = preset.model(), preset.truth()["coefficients"]
    clean = preset.simulate(0, channels=("z", "v", "a"))
    d_true = physics.damping(model, truth, clean.z, clean.v)
    err = {}
    for acc in ("ignore", "fuse"):
        res = identify(record, FULL, "nsi-ip", options={"acceleration": acc}, px_roots=model.px_roots)
        d_id = physics.damping(model, res.coefficients, clean.z, clean.v)
        err[acc] = float(np.sqrt(np.mean((d_id - d_true) ** 2) / np.mean(d_true**2)))
    assert err["fuse"] < err["ignore"], err


@pytest.mark.slow
def test_a_given_mass_does_not_degrade_stiffness_or_modal_estimates():
    """A given mass is not forced into the ULS fit (mass_in_uls_fit=false).

    Record of the built-in study (seed 2424290875) on which forcing it gave z +1.67 %, fn+ +1.94 %,
    eq+ +1.15 % (ignore, one k~1) and +1.46 / +1.92 / +1.24 % (fuse, 5 k~1, mass_in_uls_fit=true);
    now 0.55 / 0.43 / 0.17 %. The stiffness coefficients must not depend on whether the mass is given.
    """
    preset = get_preset("paper-experimental")
    rec = preset.simulate(2424290875, noise={"z": 0.02, "a": 0.02}, channels=("z", "a"))
    roots = preset.model().px_roots
    truth = preset.truth()["coefficients"]
    known = identify(rec, FULL, "nsi-ip", mass=preset.mass, px_roots=roots)
    estimated = identify(rec, FULL, "nsi-ip", px_roots=roots)
    for name in ("z", "z^2", "z^3"):
        assert known.coefficients[name] == pytest.approx(estimated.coefficients[name], rel=1e-3)
    for name in ("z", "z^3"):
        assert known.coefficients[name] == pytest.approx(truth[name], rel=0.01)
    true_modal = physics.modal(preset.model(), truth, preset.mass, physics.equilibria(preset.model(), truth).stable)
    found = sorted(known.modal, key=lambda m: m.equilibrium)
    for got, want in zip(found, true_modal, strict=True):
        assert got.fn_hz == pytest.approx(want.fn_hz, rel=0.01)
        assert got.equilibrium == pytest.approx(want.equilibrium, rel=0.01)


@pytest.mark.slow
def test_nsi_ip_meets_issue_8_targets_on_the_built_in_study_records():
    """z^3, z^2, z, fn and equilibria within 1 %, c0 within 10 %, on the records the study runs.

    The records (seeds) come from the study's plan, not from this test; mass given as in the
    study's config, px(z) roots iterated. Measured: z^2 at most 0.54 %, c0 at most 1.1 %.
    (On other seeds z^2 exceeds 1 % on about 7 records in 24: docs/results.md.)
    """
    from nlid.study import load_study, plan_study

    preset = get_preset("paper-experimental")
    truth = preset.truth()["coefficients"]
    model = preset.model()
    true_modal = physics.modal(model, truth, preset.mass, physics.equilibria(model, truth).stable)
    runs = [r for r in plan_study(load_study("paper-experimental")) if r.run_id.startswith("experimental/main/nsi-ip/")]
    assert len(runs) == 3
    for run in runs:
        rec = preset.simulate(run.spec.seed, noise={"z": 0.02, "a": 0.02}, channels=("z", "a"))
        res = identify(rec, FULL, "nsi-ip", mass=preset.mass)
        for name, tol in (("z^3", 0.01), ("z^2", 0.01), ("z", 0.01), ("sign(v)*|px(z)|", 0.10)):
            assert res.coefficients[name] == pytest.approx(truth[name], rel=tol), (run.run_id, name)
        found = sorted(res.modal, key=lambda m: m.equilibrium)
        assert len(found) == 2, run.run_id
        for got, want in zip(found, true_modal, strict=True):
            assert got.fn_hz == pytest.approx(want.fn_hz, rel=0.01), run.run_id
            assert got.equilibrium == pytest.approx(want.equilibrium, rel=0.01), run.run_id
