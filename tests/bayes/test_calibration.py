"""Calibration: 90 % credible intervals of the friction coefficients cover the truth 80-97 % of the time.

50 replicates of each preset (seeds 1000-1049) with 2 % noise on z and a (the
velocity is estimated), started from rfs with the known mass. The
paper-experimental model uses px(z) with its roots fixed at the true ones (the
preset's model), so every replicate has the same terms. The posterior runs
with its defaults (bias correction by simulation, the stiffness coefficients
integrated out). Each damping-family coefficient is checked.

The replicates are independent and run in two processes (the CI machine has
two cores); about 3 s of CPU each.
"""

import multiprocessing
import os
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pytest

SEEDS = range(1000, 1050)


def _replicate(name: str, seed: int) -> dict[str, bool]:
    """Whether each damping coefficient's 90 % interval contains the truth, for one seed."""
    from nlid import identify
    from nlid.bayes import sample_posterior
    from nlid.presets import get_preset

    preset = get_preset(name)
    model = preset.model()
    truth = preset.truth()["coefficients"]
    record = preset.simulate(seed, noise=0.02, channels=("z", "a"))
    result = identify(record, model, "rfs", mass=preset.mass)
    post = sample_posterior(record, result, params="damping", seed=seed)
    return {term: bool(lo <= truth[term] <= hi) for term, (lo, hi) in post.interval(0.9).items()}


@pytest.mark.slow
@pytest.mark.parametrize("name", ["paper-numerical", "paper-experimental"])
def test_ninety_percent_intervals_cover_the_truth(name):
    workers = max(1, min(2, os.cpu_count() or 1))
    with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn")) as pool:
        results = list(pool.map(_replicate, [name] * len(SEEDS), SEEDS))
    coverage = {term: float(np.mean([r[term] for r in results])) for term in results[0]}
    print(f"{name}: 90 % interval coverage over {len(SEEDS)} replicates: {coverage}")
    from nlid.presets import get_preset

    damping = [t.name for t in get_preset(name).model().terms if t.family == "damping"]
    assert sorted(coverage) == sorted(damping)
    bad = {t: c for t, c in coverage.items() if not 0.80 <= c <= 0.97}
    assert not bad, f"{name}: coverage outside 80-97 %: {bad} (all: {coverage})"
