"""Simulation of the single-degree-of-freedom oscillator ``m z'' + R(z, z') = f(t)``.

``R`` is any model of the term language with its coefficients (the constant
term carries static loads such as gravity ``m g``). Integration is the
classical fixed-step fourth-order Runge-Kutta scheme with one step per sample
and the force held constant over each sample interval (zero-order hold), as
in the paper's numerical example (Sec. 3). The acceleration returned at
sample ``k`` is ``(f_k - R(z_k, v_k)) / m``, exactly consistent with the force
and the state.

The integrator is compiled with numba: the model is encoded as integer and
float arrays (:func:`encode_model`) so one compiled kernel serves every model.
numba is a dependency for this reason alone (a pure-Python RK4 loop is about
1000 times slower; ``scipy.integrate`` cannot hold the force per sample
without restarting at every sample).

The package holds one job per module:

:mod:`~nlid.simulation.encode`
    the model as the arrays the kernels read;
:mod:`~nlid.simulation.kernels`
    the compiled integrators (:func:`simulate`, :func:`free_run`);
:mod:`~nlid.simulation.excitation`
    the forces (:func:`random_force`, :class:`SineTest`, :func:`fine_force`);
:mod:`~nlid.simulation.sensitivity`
    free runs of segments with their forward sensitivities
    (:func:`simulate_segments`), used by the scores and the output-error identifier.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..base.lazy import lazy_face

if TYPE_CHECKING:  # loaded on first use by __getattr__ below: importing one submodule loads no other
    from .encode import encode_memory, encode_model
    from .excitation import INTERPOLATION_BETA, INTERPOLATION_TAPS, SineTest, fine_force, random_force
    from .kernels import FREE_RUN_OVERSAMPLE, SimulationError, free_run, simulate
    from .sensitivity import SegmentRun, sensitivity_columns, simulate_segments

#: Public name -> module that defines it (imported on first access).
_LAZY: dict[str, str] = {
    "encode_memory": "nlid.simulation.encode",
    "encode_model": "nlid.simulation.encode",
    "INTERPOLATION_BETA": "nlid.simulation.excitation",
    "INTERPOLATION_TAPS": "nlid.simulation.excitation",
    "SineTest": "nlid.simulation.excitation",
    "fine_force": "nlid.simulation.excitation",
    "random_force": "nlid.simulation.excitation",
    "FREE_RUN_OVERSAMPLE": "nlid.simulation.kernels",
    "SimulationError": "nlid.simulation.kernels",
    "free_run": "nlid.simulation.kernels",
    "simulate": "nlid.simulation.kernels",
    "SegmentRun": "nlid.simulation.sensitivity",
    "sensitivity_columns": "nlid.simulation.sensitivity",
    "simulate_segments": "nlid.simulation.sensitivity",
}

__all__ = [
    "simulate",
    "free_run",
    "fine_force",
    "INTERPOLATION_TAPS",
    "INTERPOLATION_BETA",
    "simulate_segments",
    "SegmentRun",
    "sensitivity_columns",
    "encode_model",
    "encode_memory",
    "random_force",
    "SineTest",
    "SimulationError",
    "FREE_RUN_OVERSAMPLE",
]


__getattr__, __dir__ = lazy_face(__name__, _LAZY, __all__)
