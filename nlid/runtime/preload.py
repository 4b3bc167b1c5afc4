"""Imported last by nlid's fork server (:mod:`nlid.runtime.isolation`): load once what every run needs.

A run is a child forked from the fork server, so what the server has loaded
costs a run nothing: the identifier plugins (whose modules import scipy,
pysindy and scikit-learn, ~1 s) and the simulator's compiled kernels
(numba's on-disk cache, or one compilation when the cache is cold, ~0.5 s),
which the study's data and free-run scores use. Without this every run would
load them again.

Importing this module anywhere but in the fork server does nothing; a failure
here only means each run loads what it needs itself.
"""

from __future__ import annotations

import os

from .isolation import FORKSERVER_ENV

__all__ = ["warm_up"]


def warm_up() -> None:
    """Import the plugins and the numerical modules, and load the simulator's kernels."""
    import numpy as np
    import scipy.fft  # noqa: F401 - derivatives
    import scipy.signal  # noqa: F401 - resampling, filters, Welch

    from .. import scoring  # noqa: F401
    from ..registry import load_registry
    from ..simulation import simulate
    from ..terms import Model

    load_registry()
    model = Model.from_spec("z^3, sign(v)*|px(z)|").with_px_roots((-1.0, 1.0))
    force = np.zeros(64)
    simulate(model, np.zeros(len(model.names)), 1.0, force, 100.0)


if os.environ.get(FORKSERVER_ENV) == str(os.getpid()):
    try:
        warm_up()
    except Exception:  # noqa: BLE001 - the fork server must start whatever a plugin does
        pass
