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

Replicates are cached in ``--out`` (one ``.npz`` per cell, a rerun adds the
missing seeds), so the summary can be reprinted with other combinations.

    python benchmarks/calibration_sandwich.py --preset paper-numerical --channels z --noise 0.01 --seeds 1000:1050

Load: one core, about 2-6 s a replicate (the bias correction's 8 simulations).
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


def replicate(preset_name: str, channels: tuple[str, ...], noise: float, seed: int) -> dict[str, np.ndarray]:
    """The estimates and covariance parts of one replicate (all coefficients, model order)."""
    preset = get_preset(preset_name)
    model = preset.model()
    record = preset.simulate(seed, noise=noise, channels=channels)
    data = regression_data(record, model)
    y = data.restoring_force(preset.mass)
    _, theta_hat, V, dof, info = sandwich(data.G, y, model.names)
    parts: dict = {}
    center, cov, _ = indirect_inference(
        record, model, theta_hat, preset.mass, data, V, rng=np.random.default_rng(seed), parts=parts
    )
    p = len(model.names)
    moves = np.array(parts["level_moves"]).reshape(-1, p)
    return {
        "seed": np.array(seed),
        "theta_hat": theta_hat,
        "center": center,
        "sandwich": V,
        "sampling": parts["sampling"],
        "spread": parts["spread"],
        "levels": moves.T @ moves,
        "cov": cov,
        "dof": np.array(dof),
        "block": np.array(info["block_samples"]),
        "samples": np.array(info["samples"]),
    }


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
    args = ap.parse_args()
    lo, hi = (int(x) for x in args.seeds.split(":"))
    channels = tuple(args.channels.split(","))
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
