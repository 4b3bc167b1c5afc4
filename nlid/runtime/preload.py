"""What nlid's fork server (:mod:`nlid.runtime.forkserver`) loads once, so that every run starts warm.

A run is a child forked from the fork server, so what the server has loaded
costs a run nothing: the identification pipeline and a study run (its spec, run and worker), the
identifier plugins with every name they export (:func:`warm_plugins`: their
modules import scipy, pysindy and scikit-learn, some only on first use,
1.5-3 s) and, for studies, the simulator's compiled kernels (numba's on-disk
cache, or one compilation when the cache is cold, ~0.5 s), which the study's
data and free-run scores use, in both specialisations they are called with
(writable coefficients when simulating a preset, read-only ones when scoring an
identified model). Without this every run would load them again.

A single identification (``nlid identify``) needs only the pipeline: its
child imports the one plugin it uses. The fork server, and a spawned child
before it says it is ready, call :func:`warm_up_quietly`: :func:`warm_up`
with the output silenced and under a time limit; a failure only means each
run loads what it needs itself.
"""

from __future__ import annotations

import contextlib
import importlib
import os
import signal
import sys
from collections.abc import Callable, Iterable

__all__ = ["warm_up", "warm_up_quietly", "warm_plugins", "PRELOAD_ENV", "PRELOAD_LIMIT"]

#: What the server loads before serving (:func:`nlid.runtime.preload.warm_up`): ``"full"`` (studies: every
#: plugin and the simulator's kernels), ``"core"`` (the pipeline), or ``"none"`` (after a failed start).
PRELOAD_ENV = "NLID_PRELOAD"
#: Loaded by the ``"core"`` preload only while no run waits: ``scipy.signal`` costs ~0.5 s (it imports
#: ``scipy.stats``) and the pipeline and the scores do without it, so a single identification whose plugin
#: does too (rfs) starts that much sooner; one that needs it (nsi-ip's filters) imports it in its child,
#: unless the server loaded it while this process was still reading the data.
WHILE_IDLE = ("scipy.signal",)
#: Longest time the preload may take (s); past it the server serves anyway.
PRELOAD_LIMIT = 90


class _PreloadTimeout(BaseException):
    """Raised by the alarm inside a preload that takes too long (not an Exception: plugins may catch those)."""


def _alarm(signum: int, frame: object) -> None:
    raise _PreloadTimeout


def warm_up_quietly(kind: str, idle: Callable[[], bool] | None = None) -> None:
    """Import what every run needs, silently, within :data:`PRELOAD_LIMIT` seconds (``idle``: see :func:`warm_up`)."""
    if kind == "none":
        return
    import warnings

    saved = [os.dup(1), os.dup(2)]
    devnull = os.open(os.devnull, os.O_WRONLY)
    has_alarm = hasattr(signal, "SIGALRM")
    try:
        os.dup2(devnull, 1)
        os.dup2(devnull, 2)
        if has_alarm:
            signal.signal(signal.SIGALRM, _alarm)
            signal.alarm(PRELOAD_LIMIT)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            warm_up(kind, idle)
    except BaseException:  # noqa: BLE001 - the server serves whatever a plugin does at import
        pass
    finally:
        if has_alarm:
            signal.alarm(0)
            signal.signal(signal.SIGALRM, signal.SIG_DFL)
        with contextlib.suppress(OSError, ValueError):
            sys.stdout.flush()
            sys.stderr.flush()
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        for fd in (*saved, devnull):
            os.close(fd)


def warm_up(kind: str = "full", idle: Callable[[], bool] | None = None) -> None:
    """Load what every run needs.

    Parameters
    ----------
    kind
        ``"core"``: the pipeline and the numerical modules (a single
        identification, which imports only its own plugin), then
        :data:`WHILE_IDLE` if no run is waiting;
        ``"full"``: also every plugin and the simulator's kernels (studies).
    idle
        Whether no run is waiting yet (the fork server: nothing to read on its
        socket). ``None``: as if a run were waiting.
    """
    import numpy as np

    # by name: the runtime sits below the pipeline and the study, which call it (no import circle)
    for name in ("scipy.fft", "nlid.identification.pipeline", "nlid.scoring"):
        importlib.import_module(name)
    if kind != "full":
        for name in WHILE_IDLE:
            if idle is None or not idle():
                return
            importlib.import_module(name)
        return
    for name in WHILE_IDLE:
        importlib.import_module(name)
    registry = importlib.import_module("nlid.contract.registry").load_registry()
    warm_plugins(registry.identifiers.values())
    importlib.import_module("nlid.study.plan")  # a study run (its spec, the run, the worker)
    simulate = importlib.import_module("nlid.simulation").simulate
    Model = importlib.import_module("nlid.model.terms").Model

    model = Model.from_spec("z^3, sign(v)*|px(z)|").with_px_roots((-1.0, 1.0))
    force = np.zeros(64)
    theta = np.zeros(len(model.names))
    simulate(model, theta, 1.0, force, 100.0)
    # an identified model's coefficients are read-only, a type of their own to numba: the free-run scores of
    # every study run (nlid.simulation.free_run) use that specialisation (loading it costs a run ~0.1-0.2 s)
    theta.setflags(write=False)
    simulate(model, theta, 1.0, force, 100.0)


def warm_plugins(identifiers: Iterable[type]) -> list[str]:
    """Load every name each identifier's plugin package exports (``from package import *``), as a run would.

    A plugin may load its heavy modules on first use (``nlid_sindy`` imports pysindy and scikit-learn,
    1.5-3 s, only when it identifies): in a study every run is a fresh child of the fork server, so each
    run would pay for them inside its identification. Loaded here once, they cost a run nothing. A name that
    fails to load is skipped (the run then reports the failure itself). Returns the packages warmed.
    """
    packages = sorted({cls.__module__.split(".")[0] for cls in identifiers} - {"nlid"})
    for package in packages:
        try:
            module = importlib.import_module(package)
            for name in getattr(module, "__all__", ()):
                getattr(module, name, None)
        except Exception:  # noqa: BLE001 - a plugin's own failure is its run's to report
            continue
    return packages
