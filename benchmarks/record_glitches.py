"""What a clipped channel or isolated spikes do to an identification, and whether nlid says so (nlid.signal.glitches).

For each preset record (1 % noise) and each channel (z, f), the channel is cut at a fraction of its peak
(as a sensor or an amplifier past its range would cut it), the declared model is identified with rfs (mass
given), and the script prints: the share of samples cut, the error of each nonlinear coefficient against
the truth, epsilon, and what :func:`nlid.signal.glitches.find_clipping` finds. Then 20 isolated spikes of
0.5, 1 and 2 std(z) are added to z at random samples, with the same figures and what
:func:`nlid.signal.glitches.find_spikes` finds. Last it checks every preset, noisy and noise-free, and the
measured benchmarks (when ``NLID_DATA_DIR`` holds them) for false alarms of either kind.

    python benchmarks/record_glitches.py [--preset paper-numerical] [--seeds 1,2,3]

Load: about 80 s of one core.
"""

from __future__ import annotations

import argparse
import dataclasses

import numpy as np

import nlid
from nlid.errors import DataError
from nlid.signal.glitches import find_clipping, find_glitches, find_spikes
from nlid.simulation.presets import PRESETS, get_preset

FRACTIONS = (1.0, 0.99, 0.95, 0.9, 0.8, 0.6)
#: Spikes added to z: how many, and their sizes in std(z).
SPIKES, SPIKE_SIZES = 20, (0.5, 1.0, 2.0)
#: Quanta the false-alarm records are also rounded to (fractions of each channel group's std; 0: as simulated).
QUANTA = (0.0, 0.1, 0.01, 0.001)


def _quantised(record, fraction: float):
    """Every channel rounded to ``fraction`` of its group's std (a coarse converter, a CSV of few digits)."""
    rounded = {}
    for group in record.groups:
        x = np.asarray(getattr(record, group))
        rounded[group] = fraction * np.std(x) * np.round(x / (fraction * np.std(x)))
    return dataclasses.replace(record, **rounded)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--preset", default="paper-numerical", help="a one-DOF preset")
    parser.add_argument("--seeds", default="1,2,3", help="comma-separated seeds")
    args = parser.parse_args()
    preset = get_preset(args.preset)
    truth = dict(preset.coefficients)
    terms = ", ".join(t for t in truth if t != "1")
    print(f"{args.preset}: terms {terms}; rfs, mass given; 1 % noise")
    print("channel  cut at  seed  samples cut  " + "  ".join(f"{t:>9}" for t in truth if t not in ("1", "z", "v")))
    for seed in (int(s) for s in args.seeds.split(",")):
        record = preset.simulate(seed, noise=0.01)
        for channel in ("z", "f"):
            x = getattr(record, channel)
            for fraction in FRACTIONS:
                limit = fraction * np.max(np.abs(x))
                cut = dataclasses.replace(record, **{channel: np.clip(x, -limit, limit)})
                fit = nlid.identify(cut, terms, "rfs", mass=record.mass)
                errors = "  ".join(
                    f"{100 * (fit.coefficients[t] - v) / v:+8.2f}%"
                    for t, v in truth.items()
                    if t not in ("1", "z", "v")
                )
                share = 100 * np.mean(np.abs(x) > limit)
                found = "; ".join(f"{c.side} ({c.visits} visits, {c.samples} samples)" for c in find_clipping(cut))
                print(
                    f"{channel:7s}  {fraction:6.2f}  {seed:4d}  {share:10.2f}%  {errors}  eps {fit.eps_percent:5.2f} %"
                    f"  found: {found or '-'}"
                )
    print(f"\n{SPIKES} isolated spikes in z (random samples and signs, seed 7)")
    for seed in (int(s) for s in args.seeds.split(",")):
        record = preset.simulate(seed, noise=0.01)
        rng = np.random.default_rng(7)
        where = rng.choice(record.n, SPIKES, replace=False)
        for size in SPIKE_SIZES:
            z = np.array(record.z, copy=True)
            z[where] += size * np.std(z) * rng.choice([-1.0, 1.0], SPIKES)
            spiked = dataclasses.replace(record, z=z)
            fit = nlid.identify(spiked, terms, "rfs", mass=record.mass)
            errors = "  ".join(
                f"{100 * (fit.coefficients[t] - v) / v:+8.2f}%" for t, v in truth.items() if t not in ("1", "z", "v")
            )
            found = "; ".join(f"{s.count} spikes" for s in find_spikes(spiked))
            print(f"spikes {size:3.1f} std  seed {seed}  {errors}  eps {fit.eps_percent:5.2f} %  found: {found or '-'}")
    print(
        "\nfalse alarms (every preset, 1 % noise and noise-free, seeds 1-3, as simulated and rounded to 0.1, 0.01 "
        "and 0.001 of each channel's std; the measured benchmarks):"
    )
    alarms = 0
    for name, p in sorted(PRESETS.items()):
        for seed in (1, 2, 3):
            for noise in (0.01, 0.0):
                record = p.simulate(seed, noise=noise)
                for fraction in QUANTA:
                    found = find_glitches(_quantised(record, fraction) if fraction else record)
                    alarms += bool(found)
                    if found:
                        print(f"  {name} seed {seed} noise {noise} quantum {fraction}: {[c.short() for c in found]}")
    for name in ("dataset:emps", "dataset:silverbox", "dataset:bouc-wen"):
        try:
            found = find_glitches(nlid.load(name))
        except DataError as exc:
            print(f"  {name}: not read ({exc})")
            continue
        alarms += bool(found)
        print(f"  {name}: {[c.short() for c in found] or 'none'}")
    print(f"records with an alarm: {alarms}")


if __name__ == "__main__":
    main()
