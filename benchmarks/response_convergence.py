"""Harmonic convergence of the response (issue 33): Duffing's backbone and forced peak, and the double well's.

1. The backbone of the hardening Duffing oscillator (1 kg, 1e4 N/m, 5e9 N/m^3) up to a first-harmonic
   amplitude of 2 mm, with H = 1, 3, 5, 7, 9 harmonics (continued to the amplitude whatever the truncation):
   the largest relative error of the frequency against the exact backbone (an elliptic integral of the peak
   displacement), and against the textbook single-harmonic formula ``omega^2 = omega0^2 + 3/4 k3/m A^2``.
2. The forced response of the same oscillator (2 % damping) at 1 N: the upper fold's frequency and amplitude
   for each H, and their change from the previous H.
3. The paper's double well (``paper-numerical``) at 2 N from its left well: the first-harmonic amplitude and the
   offset at 12 Hz (near its softened resonance, 12.1 Hz) for each H.

    python benchmarks/response_convergence.py
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))

import numpy as np  # noqa: E402

from nlid.identified.model import IdentifiedModel  # noqa: E402
from nlid.model import physics  # noqa: E402
from nlid.model.terms import Model  # noqa: E402
from nlid.response import backbone, frequency_response  # noqa: E402
from nlid.response.backbone import duffing_exact, duffing_frequency  # noqa: E402
from nlid.simulation.presets import get_preset  # noqa: E402

OMEGA0, BETA = 100.0, 5e9


def main() -> None:
    print("load {:.1f} {:.1f} {:.1f}".format(*os.getloadavg()))
    fit = IdentifiedModel(
        model=Model.from_spec("z^3"), coefficients={"z^3": 5e9, "z": 1e4, "v": 4.0, "1": 0.0}, mass=1.0, method="-"
    )
    print("\n| H | backbone points | error vs exact (elliptic) | error vs one-harmonic formula |")
    print("|---|---|---|---|")
    for h in (1, 3, 5, 7, 9):
        b = backbone(fit, 2e-3, harmonics=h, truncation=None)[0]
        w = 2 * np.pi * b.frequency_hz
        exact = np.max(np.abs(w - duffing_exact(OMEGA0, BETA, b.peak())) / w)
        textbook = np.max(np.abs(w - duffing_frequency(OMEGA0, BETA, b.amplitude())) / w)
        print(f"| {h} | {len(w)} | {exact:.2e} | {textbook:.2e} |")
    print("\n| H | upper fold (Hz) | its amplitude (mm) | change of the fold frequency from the previous H |")
    print("|---|---|---|---|")
    last = None
    for h in (1, 3, 5, 7, 9, 11):
        resp = frequency_response(fit, 1.0, (12, 28), harmonics=h, backbone=False)
        fold = max(resp.curves[0].folds, key=lambda e: e.frequency_hz)
        change = "-" if last is None else f"{(fold.frequency_hz - last) / last:.1e}"
        print(f"| {h} | {fold.frequency_hz:.6f} | {1e3 * fold.amplitude[0]:.6f} | {change} |")
        last = fold.frequency_hz
    p = get_preset("paper-numerical")
    model = p.model()
    well = IdentifiedModel(
        model=model,
        coefficients=p.truth()["coefficients"],
        mass=p.mass,
        method="truth",
        equilibria=physics.equilibria(model, model.vector(p.truth()["coefficients"]), (-0.05, 0.05)),
    )
    print("\n| H | amplitude at 12 Hz (mm) | offset (mm) | change of the amplitude from the previous H | truncation |")
    print("|---|---|---|---|---|")
    left = well.equilibria.stable[0]
    last = None
    for h in (3, 5, 7, 11, 15, 21):
        resp = frequency_response(well, 2.0, (12.0, 12.01), harmonics=h, backbone=False, starts=[left])
        c = resp.curves[0]  # its first point is solved at 12 Hz exactly
        a = float(c.amplitude()[0])
        change = "-" if last is None else f"{(a - last) / last:.1e}"
        print(f"| {h} | {1e3 * a:.6f} | {1e3 * c.offset()[0]:.4f} | {change} | {c.truncation[0]:.1e} |")
        last = a
    print("\nload {:.1f} {:.1f} {:.1f}".format(*os.getloadavg()))


if __name__ == "__main__":
    main()
