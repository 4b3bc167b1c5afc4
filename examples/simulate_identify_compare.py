"""Simulate the paper's numerical example, identify it, compare methods, and put a posterior on the friction.

Run: ``python examples/simulate_identify_compare.py`` (about 10 s). Writes
``example-output/compare.csv`` and ``example-output/fit.png``.
"""

from pathlib import Path

import nlid
from nlid.report.plotting import new_figure, save_figure

OUT = Path("example-output")


def main() -> None:
    OUT.mkdir(exist_ok=True)
    # 30 s of the double-well Duffing oscillator of Sec. 3, 2 % noise on the displacement only
    record = nlid.simulate("paper-numerical", seed=4, noise=0.02, channels="z", duration=30)
    terms = "z^3, z^2, v*|v|"

    fit = nlid.identify(record, terms, method="nsi-ip", mass=0.2)
    print(fit.summary())

    # every installed method but the refining oe (name it to add it) on the same record, errors against the truth
    table = nlid.compare(record, terms, mass=0.2)
    table.to_csv(OUT / "compare.csv", index=False)
    errors = table.query("quantity in ['coefficient', 'fn_hz', 'zeta']")
    print(errors.pivot_table(index=["quantity", "name"], columns="method", values="error_pct").round(3))

    # the damping coefficients' posterior, started from the rfs estimate
    rfs = table.attrs["models"]["rfs"]
    post = nlid.posterior(record, rfs, seed=0)
    print(post.format_table())

    fig, axes = new_figure(1, 2, width=10, height=4)
    fit.plot_stiffness(ax=axes[0])
    fit.plot_residual(record, against="v", ax=axes[1])
    save_figure(fig, OUT / "fit", formats=("png",))
    print(f"wrote {OUT / 'compare.csv'} and {OUT / 'fit.png'}")


if __name__ == "__main__":
    main()
