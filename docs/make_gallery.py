"""Make the images of the figure gallery (docs/gallery.md) under docs/_static/gallery/.

Run from a clone, after a change to a figure:

    python docs/make_gallery.py

The code between the ``# [name]`` and ``# [/name]`` markers is what docs/gallery.md shows (``literalinclude``),
so the page shows the code that made each image. The images are committed (about 80 dpi), so the docs build
does not run this script. It runs a small study (worker processes), so its body sits under a ``__main__`` guard.
"""

from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
OUT = HERE / "_static" / "gallery"
DPI = 80
sys.path[:0] = [str(HERE.parent), str(HERE.parent / "plugins")]


def save(artist, name: str) -> None:
    """Write the figure of ``artist`` (an Axes or a Figure) as ``OUT/name.png``."""
    fig = getattr(artist, "figure", None) or artist
    fig.savefig(OUT / f"{name}.png", dpi=DPI)
    _shrink(OUT / f"{name}.png")
    print(f"wrote {name}.png")


def copy(png: Path, name: str, dpi: float = 120.0) -> None:
    """Copy a PNG nlid wrote (at ``dpi``) as ``OUT/name.png``, scaled to :data:`DPI`."""
    _shrink(png, OUT / f"{name}.png", DPI / dpi)
    print(f"wrote {name}.png")


def _shrink(src: Path, dst: Path | None = None, scale: float = 1.0) -> None:
    """Rewrite a PNG as a palette image (256 colours: plenty for line figures), scaled by ``scale``."""
    from PIL import Image

    image = Image.open(src).convert("RGB")
    if scale != 1.0:
        image = image.resize((round(image.width * scale), round(image.height * scale)), Image.LANCZOS)
    image.quantize(256).save(dst or src, optimize=True)


def main() -> None:
    OUT.mkdir(parents=True, exist_ok=True)
    # [setup]
    import nlid
    from nlid.simulation.presets import get_preset

    preset = get_preset("paper-numerical").with_overrides(duration=10.0)
    record = preset.simulate(seed=1, noise={"z": 0.02})  # carries its truth: record.meta["reference"]
    fit = nlid.identify(record, "z^3, z^2, z, 1, v, v*|v|", "rfs", mass=preset.mass)
    # [/setup]

    # [stiffness]
    ax = fit.plot_stiffness()
    # [/stiffness]
    save(ax, "stiffness")
    # [potential]
    ax = fit.plot_stiffness(potential=True)
    # [/potential]
    save(ax, "potential")
    # [surface]
    ax = fit.plot_surface(record)
    # [/surface]
    save(ax, "surface")
    # [damping_slice]
    ax = fit.plot_damping_slice(record, z0=fit.equilibria.stable[0])
    # [/damping_slice]
    save(ax, "damping_slice")
    # [residual]
    ax = fit.plot_residual(record, against="v")
    # [/residual]
    save(ax, "residual")
    # [freerun]
    ax = fit.plot_freerun(record, rule="window:200")
    # [/freerun]
    save(ax, "freerun")
    # [frf]
    ax = fit.plot_frf()
    # [/frf]
    save(ax, "frf")
    # [frf_nsi]
    nsi = nlid.identify(record, "z^3, z^2, z, 1, v, v*|v|", "nsi-ip", mass=preset.mass)
    ax = nsi.plot_frf()
    # [/frf_nsi]
    save(ax, "frf_nsi")
    # [own_axes]
    from nlid.report.plotting import new_figure

    fig, axes = new_figure(1, 2, width=10.0, height=3.6)
    fit.plot_stiffness(ax=axes[0])
    nsi.plot_stiffness(ax=axes[1])
    # [/own_axes]
    save(fig, "own_axes")

    # [posterior]
    from nlid.bayes.plots import corner_figure, damping_figure, trace_figure

    post = nlid.posterior(record, fit, params="damping", seed=3)
    corner = corner_figure(post)  # the truth the record carries is drawn in black
    trace = trace_figure(post)
    damping = damping_figure(post.damping_bands())
    # post.save("out/") writes the same three as posterior_*.png
    # [/posterior]
    save(corner, "posterior_corner")
    save(trace, "posterior_trace")
    save(damping, "posterior_damping")

    # [response]
    resp = fit.frequency_response(force=[0.5, 0.8], band=(4, 12), starts=[fit.equilibria.stable[1]])
    ax = resp.plot()  # stable solid, unstable dashed, folds and the jumps of slow sweeps, the backbone
    # [/response]
    save(ax, "response")
    # [response_band]
    record_x = get_preset("paper-numerical").with_overrides(duration=20.0).simulate(seed=2, noise={"z": 0.02})
    fit_x = nlid.identify(record_x, "z^3, z^2, z, 1, v, v*|v|", "rfs", mass=preset.mass)
    post_x = nlid.posterior(record_x, fit_x, params="all", seed=2)
    banded = fit_x.frequency_response(force=0.8, band=(4, 12)).with_posterior(post_x, draws=40)
    test = {"kind": "stepped", "amplitude": 0.8, "band": (4.0, 12.0), "steps": 33, "periods": 40}
    measured = nlid.simulate("paper-numerical-stepped", sine=test, x0=(0.0173, 0.0))  # in the right well
    ax = banded.compare(measured).plot()  # the 90 % band (hatched: unresolved), measured points
    # [/response_band]
    save(ax, "response_band")

    here = Path.cwd()
    with tempfile.TemporaryDirectory() as tmp:
        os.chdir(tmp)  # the reports below are written into a temporary folder
        try:
            # [discover]
            found = nlid.discover(record, "z^3, z^2, z, 1, v", "rfs", mass=preset.mass)
            found.write_report("discovery")  # discovery/figures/residual_<k>.png, discovery/figures/progress.png
            # [/discover]
            copy(Path("discovery/figures/residual_0.png"), "discover_residual")
            copy(Path("discovery/figures/progress.png"), "discover_progress")

            Path("gallery.toml").write_text(STUDY)
            # [study]
            outcome = nlid.run_study("gallery.toml", "study", jobs=2)  # gallery.toml: below
            # its figures are in study/figures: summary_*, kz_*, rms_*, and sv_*, frf_*, coef_* per method
            # [/study]
            for png in sorted((outcome.folder / "figures").glob("*.png")):
                kind = png.stem.split("_")[0]
                method = png.stem.rsplit("_", 1)[-1] if kind in ("sv", "frf", "coef", "slices") else ""
                copy(png, f"study_{kind}" + (f"_{method}" if method else ""))
        finally:
            os.chdir(here)


STUDY = """\
# [study.toml]
[study]
name = "gallery"
seed = 7
repetitions = 3
identifiers = ["rfs", "sindy", "nsi-ip"]

[[datasets]]
name = "short"
preset = "paper-numerical"
overrides = { duration = 10.0 }
noise = { z = 0.02 }
terms = "z^3, z^2, z, 1, v, v*|v|"
# [/study.toml]
"""

if __name__ == "__main__":
    main()
