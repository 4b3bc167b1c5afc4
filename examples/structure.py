"""A structure of three degrees of freedom: simulate, identify with NSI and RFS, compare with the truth.

The `3dof-cubic` preset is the chain of reference [29] of the paper (Marchesiello & Garibaldi 2008): three
masses in a chain with a cubic spring from the third to the ground. The nonlinear element is named on its
connection, `z3^3` (to ground); `(z1-z2)^3` would name one between two masses.

Run: python examples/structure.py   (about 20 s; writes example-output/structure_frf.png)
"""

from pathlib import Path

import numpy as np

import nlid

record = nlid.simulate("3dof-cubic", duration=30, noise=0.02, seed=1)  # 2 % noise on every channel
truth = record.meta["reference"]
print(f"record: {record.n_dofs} DOFs, {record.n} samples at {record.fs:g} Hz")

true_modes = truth["modes"][0]  # the underlying linear modes (one stable equilibrium, the origin)
true_fn, true_zeta = np.asarray(true_modes["fn_hz"]), np.asarray(true_modes["zeta"])
for method in ("nsi-ip", "rfs"):
    fit = nlid.identify(record, "z3^3", method, mass=truth["M"])
    k3 = fit.coefficients["z3^3"]
    error = 100 * (k3 / truth["coefficients"]["z3^3"] - 1)
    print(f"\n{method}: z3^3 = {k3:.6g} N/m^3 ({error:+.3f} % against the truth)")
    modes = fit.linear_modes
    fn_error = 100 * (modes.fn_hz / true_fn - 1)
    zeta_error = 100 * (modes.zeta / true_zeta - 1)
    for k in range(record.n_dofs):
        print(
            f"  mode {k + 1}: {modes.fn_hz[k]:8.3f} Hz ({fn_error[k]:+.3f} %), "
            f"damping ratio {100 * modes.zeta[k]:.3f} % ({zeta_error[k]:+.2f} % relative)"
        )

folder = Path("example-output")
folder.mkdir(exist_ok=True)
axes = fit.plot_frf()  # the receptance matrix of the underlying linear system, one axis per entry
axes[0].figure.savefig(folder / "structure_frf.png", dpi=100)
print(f"\nwrote {folder / 'structure_frf.png'}")
