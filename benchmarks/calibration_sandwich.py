"""Where the posterior's covariance is miscalibrated, without emcee (issue 35).

For one calibration cell (preset x channels x noise) and a range of seeds,
each replicate forms the posterior's likelihood the way
:func:`nlid.bayes.build_likelihood` does (force balance, sandwich, bias
correction by simulation) and keeps the parts of the corrected estimate's
covariance ``V_c = J^-1 V J^-T + (1 + 1/pairs) S + sum_l m_l m_l^T``:

* ``sampling``: ``J^-1 V J^-T``, the sandwich carried through the correction;
* ``spread``: ``S``, the spread of one antithetic pair's corrected estimate;
* ``levels``: the noise levels' rank-one moves.

Over the replicates it compares, for each damping coefficient, the spread of
the estimates with the standard deviations each combination of the parts
gives (the posterior's marginals in the likelihood's Gaussian limit, the
stiffness integrated out):

* ``sd(ls)/rms(sandwich)``: the least-squares estimate's spread over the
  sandwich's standard deviation (1 when the sandwich is right);
* for the corrected estimate, the sd of the standardised error
  ``(centre - truth) / sd`` and the 90 % coverage with the normal quantile,
  for ``V_c`` as sampled today, for ``V_c`` with the spread counted as Monte
  Carlo error only (``S / pairs``), and for the sandwich part alone.

With ``widened for dof`` the summary also shows the intervals an
alternative would give (tried for issue 35 and not adopted): each
coefficient's standard deviation widened by ``sqrt(nu / (nu - 2))``, ``nu``
the degrees of freedom of its estimated variance (:func:`variance_dof` from
the fourth moment of the batch sums, Satterthwaite with the spread's).

``--noise-draws K`` fixes each seed's force and draws the noise ``K`` times
instead (:func:`given_force`): the sandwich against the conditional scatter of
the least-squares estimates, and the degrees of freedom of its variance,
observed and estimated.

``--slope 3`` compares, on each seed's record, the binding function's slope
(:func:`binding_slope`, central differences at +-3 sd) with the attenuation
``J`` the covariance uses.

Replicates are cached in ``--out`` (one ``.npz`` per cell, a rerun adds the
missing seeds), so the summary can be reprinted with other combinations.

    python benchmarks/calibration_sandwich.py --preset paper-numerical --channels z --noise 0.01 --seeds 1000:1050
    python benchmarks/calibration_sandwich.py --preset paper-experimental --channels z,a --noise 0.02 \
        --seeds 3000:3002 --noise-draws 40

Load: one core; 1-4 s a replicate (the bias correction's 8 simulations), 0.3 s a noise draw
(measured at a load average of 5-7 on the shared 2-core machine).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from nlid.bayes.bias import indirect_inference
from nlid.bayes.likelihood import sandwich
from nlid.estimation.balance import regression_data
from nlid.simulation.presets import get_preset

Z90 = 1.6448536269514722
#: Fewest degrees of freedom a coefficient's variance is given (the widening is at most sqrt(3)).
MIN_VARIANCE_DOF = 3.0


def variance_dof(scores: np.ndarray, weights: np.ndarray, block: int) -> np.ndarray:
    """Degrees of freedom of the batch-means variance of each weighted sum of the scores.

    A variance estimated from ``K`` independent, Gaussian batch sums scatters
    like ``chi^2_K / K``; heavy-tailed batch sums (bursts) scatter more. The
    effective degrees of freedom ``2 K E[B^2]^2 / Var(B^2)`` (Satterthwaite) are
    estimated from the ``K = N // block`` non-overlapping batch sums ``B`` of
    ``scores @ w`` for each row ``w`` of ``weights``: ``K`` for Gaussian sums,
    fewer when they are heavy-tailed. The overlapping batch means of
    :func:`long_run_covariance` scatter somewhat less than the
    non-overlapping ones (1.5 times the degrees of freedom for Gaussian
    sums), so this is on the safe side.

    Parameters
    ----------
    scores
        Zero-mean series, shape ``(N, k)``.
    weights
        Shape ``(q, k)``: one weighted sum per row (e.g. a coefficient's row
        of ``H^-1``).
    block
        Batch length (samples), as for :func:`long_run_covariance`.

    Returns
    -------
    numpy.ndarray
        Shape ``(q,)``, at least :data:`MIN_VARIANCE_DOF`.
    """
    s = np.asarray(scores, dtype=float)
    s = s.reshape(s.shape[0], -1)
    batches = s.shape[0] // int(block)
    if batches < 2:
        raise ValueError(f"block length {block} leaves fewer than 2 batches of the {s.shape[0]} samples")
    sums = s[: batches * block].reshape(batches, block, -1).sum(axis=1) @ np.asarray(weights, dtype=float).T
    sq = sums**2
    mean = np.mean(sq, axis=0)
    var = np.var(sq, axis=0, ddof=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        dof = np.where(var > 0, 2.0 * batches * mean**2 / var, float(batches))
    return np.maximum(dof, MIN_VARIANCE_DOF)


def widen_for_dof(
    covariance: np.ndarray,
    sampling: np.ndarray,
    sampling_dof: np.ndarray,
    spread: np.ndarray | None = None,
    spread_dof: float = np.inf,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Widen each coefficient's standard deviation for the degrees of freedom of its estimated variance.

    Satterthwaite's rule for a variance that is the sum of a sampling part
    (``sampling``, with ``sampling_dof`` per coefficient) and a simulated
    spread (``spread``, ``spread_dof``): ``nu = (a + s)^2 / (a^2 / nu_a + s^2 / nu_s)``
    over the diagonal (the rest of ``covariance``, e.g. the noise levels'
    moves, is counted as exact); then ``D covariance D`` with
    ``D = diag(sqrt(nu / (nu - 2)))``.

    Returns
    -------
    covariance, nu, factor
        The widened covariance, each coefficient's degrees of freedom and
        its widening factor.
    """
    a = np.diag(sampling)
    s = np.zeros_like(a) if spread is None else np.diag(spread)
    parts = a**2 / np.asarray(sampling_dof, dtype=float) + (s**2 / spread_dof if np.isfinite(spread_dof) else 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        nu = np.where(parts > 0, (a + s) ** 2 / parts, np.inf)
    nu = np.maximum(nu, MIN_VARIANCE_DOF)
    factor = np.sqrt(nu / (nu - 2.0))
    cov = np.asarray(covariance, dtype=float) * np.outer(factor, factor)
    return 0.5 * (cov + cov.T), nu, factor


def _fit(record, model, mass: float):
    """The regression data, least squares with its sandwich, and the degrees of freedom of each variance."""
    data = regression_data(record, model)
    y = data.restoring_force(mass)
    stats, theta_hat, V, dof, info = sandwich(data.G, y, model.names)
    s = stats.scale
    scores = (data.G / s) * (y - data.G @ theta_hat)[:, None]
    nu = variance_dof(scores, np.linalg.inv(stats.gtg / np.outer(s, s)), info["block_samples"])
    return data, theta_hat, V, dof, info, nu


def replicate(preset_name: str, channels: tuple[str, ...], noise: float, seed: int) -> dict[str, np.ndarray]:
    """The estimates and covariance parts of one replicate (all coefficients, model order)."""
    preset = get_preset(preset_name)
    model = preset.model()
    record = preset.simulate(seed, noise=noise, channels=channels)
    data, theta_hat, V, dof, info, sampling_dof = _fit(record, model, preset.mass)
    parts: dict = {}
    center, cov, _ = indirect_inference(
        record, model, theta_hat, preset.mass, data, V, rng=np.random.default_rng(seed), parts=parts
    )
    p = len(model.names)
    moves = np.array(parts["level_moves"]).reshape(-1, p)
    pairs = 4
    widened, nu, _ = widen_for_dof(
        cov, parts["sampling"], sampling_dof, (1 + 1 / pairs) * parts["spread"], parts["spread_dof"]
    )
    return {
        "seed": np.array(seed),
        "theta_hat": theta_hat,
        "center": center,
        "sandwich": V,
        "sampling": parts["sampling"],
        "spread": parts["spread"],
        "levels": moves.T @ moves,
        "cov": cov,
        "widened": widened,
        "nu": nu,
        "dof": np.array(dof),
        "block": np.array(info["block_samples"]),
        "samples": np.array(info["samples"]),
    }


def given_force(preset_name: str, channels: tuple[str, ...], noise: float, seed: int, draws: int) -> list[str]:
    """The sandwich of one force's trajectory under ``draws`` independent noise draws (no correction).

    With the trajectory fixed, the least-squares estimates scatter by the
    conditional sampling variance alone, which the sandwich estimates; the
    scatter of the sandwich's own variance over the draws gives its degrees
    of freedom (``2 / cv^2``), to compare with :func:`variance_dof`.
    """
    from nlid.data.record import Record

    preset = get_preset(preset_name)
    model = preset.model()
    dam = [i for i, t in enumerate(model.terms) if t.family == "damping"]
    clean = preset.simulate(seed, noise=0.0, channels=("z", "v", "a"))
    est, var, nus = [], [], []
    for k in range(draws):
        rng = np.random.default_rng([seed, k])
        noisy = {
            c: getattr(clean, c) + noise * getattr(clean, c).std() * rng.standard_normal(clean.n) for c in channels
        }
        record = Record(f=clean.f, fs=clean.fs, meta=clean.meta, **noisy)
        _, theta_hat, V, _, _, nu = _fit(record, model, preset.mass)
        est.append(theta_hat[dam])
        var.append(np.diag(V)[dam])
        nus.append(nu[dam])
    est, var, nus = np.array(est), np.array(var), np.array(nus)
    observed = 2.0 / (np.std(var, axis=0, ddof=1) / np.mean(var, axis=0)) ** 2
    ratio = np.std(est, axis=0, ddof=1) / np.sqrt(np.mean(var, axis=0))
    return [
        f"  {model.names[i]:>22}: sd(ls)/rms(sandwich) {ratio[j]:.2f}; dof of the sandwich's variance: "
        f"observed {observed[j]:.0f}, estimated (median) {np.median(nus[:, j]):.0f}"
        for j, i in enumerate(dam)
    ]


def binding_slope(preset_name: str, channels: tuple[str, ...], noise: float, seed: int, step: float) -> list[str]:
    """The slope of the binding function ``b(theta) = E[theta_hat]`` against the attenuation ``J``, on one record.

    ``b`` is simulated at the corrected estimate moved by ``+-step`` of its
    sd along each coefficient, with the same trajectories' shifts and noise
    draws (common random numbers, 8 pairs); the central differences give
    ``B = db/dtheta``. Indirect inference's covariance uses ``J``; with ``B``
    it would be ``B^-1 V B^-T``.
    """
    from nlid.bayes.bias import _bindings

    preset = get_preset(preset_name)
    model = preset.model()
    dam = [i for i, t in enumerate(model.terms) if t.family == "damping"]
    record = preset.simulate(seed, noise=noise, channels=channels)
    data = regression_data(record, model)
    _, theta_hat, V, _, _ = sandwich(data.G, data.restoring_force(preset.mass), model.names)
    centre, cov, info = indirect_inference(
        record, model, theta_hat, preset.mass, data, V, rng=np.random.default_rng(seed)
    )

    def binding(theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        (corr,) = _bindings(
            record,
            model,
            theta,
            preset.mass,
            data,
            [info["noise_sd"]],
            pairs=8,
            rng=np.random.default_rng(7),
            phase=0.0,
        )
        return corr.binding @ theta + corr.offset, corr.binding

    _, J = binding(centre)
    sd = np.sqrt(np.diag(cov))
    B = np.zeros_like(J)
    for j in range(len(centre)):
        e = np.zeros_like(centre)
        e[j] = step * sd[j]
        B[:, j] = (binding(centre + e)[0] - binding(centre - e)[0]) / (2 * step * sd[j])
    with_j = np.linalg.solve(J, np.linalg.solve(J, V).T)
    with_b = np.linalg.solve(B, np.linalg.solve(B, V).T)
    return [
        f"  {model.names[i]:>22}: J_ii {J[i, i]:.3f} B_ii {B[i, i]:.3f}; sd with B over sd with J "
        f"{np.sqrt(with_b[i, i] / with_j[i, i]):.3f}"
        for i in dam
    ]


def load(path: Path) -> dict[int, dict[str, np.ndarray]]:
    """The cached replicates of a cell, by seed."""
    if not path.exists():
        return {}
    with np.load(path) as f:
        seeds = f["seed"]
        return {int(s): {k: f[k][i] for k in f.files} for i, s in enumerate(seeds)}


def save(path: Path, reps: dict[int, dict[str, np.ndarray]]) -> None:
    """Write the replicates of a cell (stacked by seed)."""
    seeds = sorted(reps)
    keys = reps[seeds[0]].keys()
    np.savez(path, **{k: np.stack([reps[s][k] for s in seeds]) for k in keys})


def summarise(preset_name: str, reps: dict[int, dict[str, np.ndarray]], pairs: int = 4) -> list[str]:
    """One line per damping coefficient comparing the spread with each covariance."""
    preset = get_preset(preset_name)
    model = preset.model()
    truth = model.vector(preset.truth()["coefficients"])
    dam = [i for i, t in enumerate(model.terms) if t.family == "damping"]
    seeds = sorted(reps)
    st = {k: np.stack([reps[s][k] for s in seeds]) for k in reps[seeds[0]]}
    combos = {
        "as sampled": st["cov"],
        **({"widened for dof": st["widened"]} if "widened" in st else {}),
        "S/pairs": st["sampling"] + st["spread"] / pairs + st["levels"],
        "sandwich only": st["sampling"],
    }
    lines = [f"{len(seeds)} replicates; block {int(np.median(st['block']))} of {int(st['samples'][0])} samples"]
    for i in dam:
        ls_ratio = np.std(st["theta_hat"][:, i], ddof=1) / np.sqrt(np.mean(st["sandwich"][:, i, i]))
        share = np.mean(st["spread"][:, i, i] * (1 + 1 / pairs) / st["cov"][:, i, i])
        lev = np.mean(st["levels"][:, i, i] / st["cov"][:, i, i])
        parts = []
        for name, c in combos.items():
            z = (st["center"][:, i] - truth[i]) / np.sqrt(c[:, i, i])
            parts.append(f"{name}: sd(z) {np.std(z, ddof=1):.2f} cover {100 * np.mean(np.abs(z) <= Z90):.0f}%")
        mean_z = np.mean((st["center"][:, i] - truth[i]) / np.sqrt(st["cov"][:, i, i]))
        if "nu" in st:
            parts.append(f"median dof {np.median(st['nu'][:, i]):.0f}")
        lines.append(
            f"  {model.names[i]:>22}: sd(ls)/rms(sandwich) {ls_ratio:.2f}; spread {100 * share:.0f}% "
            f"levels {100 * lev:.0f}% of V_c; mean z {mean_z:+.2f}; " + "; ".join(parts)
        )
    return lines


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--preset", required=True)
    ap.add_argument("--channels", required=True)
    ap.add_argument("--noise", type=float, required=True)
    ap.add_argument("--seeds", default="1000:1050")
    ap.add_argument("--out", type=Path, default=Path("/work/scratch/calib"))
    ap.add_argument("--summary-only", action="store_true")
    ap.add_argument("--slope", type=float, default=0.0, help="the binding function's slope at +-SLOPE sd instead")
    ap.add_argument("--noise-draws", type=int, default=0, help="fix each seed's force, draw the noise this many times")
    args = ap.parse_args()
    lo, hi = (int(x) for x in args.seeds.split(":"))
    channels = tuple(args.channels.split(","))
    if args.slope:
        for seed in range(lo, hi):
            print(f"{args.preset} {args.channels} {args.noise:g}, seed {seed}: binding slope at +-{args.slope:g} sd")
            print("\n".join(binding_slope(args.preset, channels, args.noise, seed, args.slope)))
        return
    if args.noise_draws:
        for seed in range(lo, hi):
            print(
                f"{args.preset} {args.channels} {args.noise:g}, the force of seed {seed}, "
                f"{args.noise_draws} noise draws"
            )
            print("\n".join(given_force(args.preset, channels, args.noise, seed, args.noise_draws)))
        return
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / f"sandwich_{args.preset}_{args.channels.replace(',', '')}_{args.noise:g}.npz"
    reps = load(path)
    start = time.perf_counter()
    if not args.summary_only:
        for seed in range(lo, hi):
            if seed in reps:
                continue
            reps[seed] = replicate(args.preset, channels, args.noise, seed)
            if len(reps) % 10 == 0:
                save(path, reps)
        save(path, reps)
    chosen = {s: r for s, r in reps.items() if lo <= s < hi}
    print(f"{args.preset} {args.channels} {args.noise:g}: {time.perf_counter() - start:.0f} s")
    print("\n".join(summarise(args.preset, chosen)))


if __name__ == "__main__":
    main()
