"""Is the k-step veto neutral between models the equation error cannot tell apart? (issue 31)

On the held force read without its sidecar (``probe_hidden_effects.py``'s ``z-only-no-meta``: the
paper-numerical double well, z only, 1 % noise, chaotic), the declared model is fitted with each of three
near-equivalent input paths (the true force hold, a delay of 0.5 samples, a lag of 0.51 samples) on each
cross-fitting block's training part, exactly as :class:`nlid.discovery.judge.Judge` does, and the 100-step
prediction errors of every predicted sample are compared with the current model's (no input path), paired
per sample. Printed per path and block: the ratio of RMS errors, the mean paired change of the squared error
relative to the current model's mean, and the t statistic of the 20 chunk means of that change in time.

    python benchmarks/kstep_paired.py [--seeds 1,2]

Load: about 20 s of one core.
"""

from __future__ import annotations

import argparse

import numpy as np
from probe_hidden_effects import _DECLARED, _M, corrupt, one_dof_preset

from nlid.discovery.crossfit import PARTITIONS, fold_rule, make_folds
from nlid.estimation.inputpath import InputPath
from nlid.identification.pipeline import identify
from nlid.scoring.rules import default_rule
from nlid.signal import derivatives

STEPS, CHUNKS = 100, 20


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="1,2", help="comma-separated seeds")
    args = parser.parse_args()
    preset = one_dof_preset({})
    for seed in (int(s) for s in args.seeds.split(",")):
        record = corrupt(preset.simulate(seed, noise=0.01), "z-only-no-meta")
        cutoff = derivatives.suggest_cutoff(record.z[: int(0.75 * record.n)], record.fs)
        folds = make_folds(record, 2, fold_rule(record, None, cutoff))
        paths = {
            "current": None,
            "force-hold": InputPath(hold="zoh"),
            "delay 0.5": InputPath(delay=0.5 / record.fs),
            "lag 0.51": InputPath(lag=0.51 / record.fs),
        }
        errors = {}
        for name, path in paths.items():
            errors[name] = []
            for train, test in zip(folds.train, folds.test, strict=True):
                fit = identify(train, _DECLARED, "rfs", mass=_M, cutoff=cutoff, input_path=path)
                rule = folds.rule if folds.rule is not None else default_rule(test)
                errors[name].append(fit.predict(test, STEPS, rule=rule, partitions=PARTITIONS).z - test.z)
        for name in list(paths)[1:]:
            for block, (before, after) in enumerate(zip(errors["current"], errors[name], strict=True), 1):
                ok = np.isfinite(before) & np.isfinite(after)
                change = after[ok] ** 2 - before[ok] ** 2
                scale = np.mean(before[ok] ** 2)
                chunks = np.array([c.mean() for c in np.array_split(change, CHUNKS)]) / scale
                t = chunks.mean() / (chunks.std(ddof=1) / np.sqrt(CHUNKS))
                ratio = np.sqrt(np.mean(after[ok] ** 2) / scale)
                print(
                    f"seed {seed}  {name:10s} block {block}: RMS ratio {ratio:.4f}  samples {change.size}  "
                    f"mean change {change.mean() / scale:+.4f}  chunk t {t:+.2f}"
                )


if __name__ == "__main__":
    main()
