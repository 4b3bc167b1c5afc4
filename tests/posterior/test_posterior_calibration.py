"""Calibration: 90 % credible intervals of the friction coefficients cover the truth 80-97 % of the time.

50 replicates of each preset (seeds 1000-1049) with 2 % noise on z and a (the
velocity is estimated), started from rfs with the known mass. The
paper-experimental model uses px(z) with its roots fixed at the true ones (the
preset's model), so every replicate has the same terms. The posterior runs
with its defaults (bias correction by simulation, unsampled coefficients fixed
at rfs's estimate). Each damping-family coefficient is checked.
"""

import numpy as np
import pytest

from nlid import identify
from nlid.posterior import sample_posterior
from nlid.presets import get_preset

SEEDS = range(1000, 1050)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["paper-numerical", "paper-experimental"])
def test_ninety_percent_intervals_cover_the_truth(name):
    preset = get_preset(name)
    model = preset.model()
    truth = preset.truth()["coefficients"]
    covers: dict[str, list[bool]] = {}
    for seed in SEEDS:
        record = preset.simulate(seed, noise=0.02, channels=("z", "a"))
        result = identify(record, model, "rfs", mass=preset.mass)
        post = sample_posterior(record, result, model, params="damping", seed=seed)
        for term, (lo, hi) in post.interval(0.9).items():
            covers.setdefault(term, []).append(lo <= truth[term] <= hi)
    coverage = {term: float(np.mean(c)) for term, c in covers.items()}
    print(f"{name}: 90 % interval coverage over {len(SEEDS)} replicates: {coverage}")
    assert len(covers) == len([t for t in model.terms if t.family == "damping"])
    bad = {t: c for t, c in coverage.items() if not 0.80 <= c <= 0.97}
    assert not bad, f"{name}: coverage outside 80-97 %: {bad} (all: {coverage})"
