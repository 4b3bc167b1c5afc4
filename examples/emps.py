"""The EMPS positioning stage (a measured benchmark): identify it, then let nlid find what a model lacks.

Run: ``NLID_DATA_DIR=/path/to/data python examples/emps.py`` (the folder holds
``emps/DATA_EMPS.mat``, see the README's data section). Without the data the
script says so and exits.
"""

import sys

import nlid
from nlid.data.datasets import EMPS_REFERENCE


def main() -> int:
    try:
        record = nlid.load("dataset:emps")
    except nlid.DataError as exc:
        print(f"EMPS data not available: {exc}")
        return 0
    # viscous and Coulomb friction and an offset; no spring; the mass is estimated
    fit = nlid.identify(record, "sign(v)", method="rfs", without="z")
    print(fit.summary())
    print(f"reference: {EMPS_REFERENCE}")

    # declare viscous friction and an offset only: the loop should find the Coulomb friction
    found = nlid.discover(record, "v, 1")
    print(found.summary())
    return 0


if __name__ == "__main__":
    sys.exit(main())
