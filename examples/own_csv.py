"""Your own measurement: a CSV with its own column names and units, read with a column map.

Run: ``python examples/own_csv.py``. The script first writes a stand-in for a
measured file (time in ms, force in kN, displacement in mm, acceleration in
g) so that it runs anywhere; with your own file, start at ``nlid.load``.
"""

from pathlib import Path

import pandas as pd

import nlid

OUT = Path("example-output")


def write_stand_in(path: Path) -> None:
    """A 'measured' file in lab units (from a simulation of the paper's rig analogue, Sec. 4)."""
    rec = nlid.simulate("paper-experimental", seed=2, noise=0.02, channels="z,a", duration=60)
    pd.DataFrame(
        {"time_ms": 1e3 * rec.t, "force_kN": 1e-3 * rec.f, "disp_mm": 1e3 * rec.z, "acc_g": rec.a / 9.81}
    ).to_csv(path, index=False)


def main() -> None:
    OUT.mkdir(exist_ok=True)
    path = OUT / "rig.csv"
    write_stand_in(path)

    # map the file's columns to the channels t, f, z, a in SI units (scale factors after '*')
    record = nlid.load(path, columns="t=time_ms*0.001, f=force_kN*1000, z=disp_mm*0.001, a=acc_g*9.81")
    print(record)

    # the friction law of Eq. 24 with the normal-force polynomial px(z); its roots are iterated
    terms = "z^3, z^2, sign(v)*|px(z)|, v*|px(z)|, v*|v|*|px(z)|, v^3*|px(z)|"
    fit = nlid.identify(record, terms, method="rfs", mass=0.265)
    print(fit.summary())
    print(fit.to_frame())


if __name__ == "__main__":
    main()
