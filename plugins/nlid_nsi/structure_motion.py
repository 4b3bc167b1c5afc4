"""The motion NSI reads on a structure: each DOF's displacement and velocity, de-noised per DOF.

Each DOF is low-passed at a cut-off from its own noise floor (``denoise_cutoff``
unless given); :func:`band_floor` raises a cut-off that falls inside the
structure's band (below :data:`BAND_FACTOR` times its highest identified mode)
for a DOF an element uses, so that no mode's motion is attenuated in the basis
functions.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from nlid.plugin import ChannelSource, DataError, InputError, Record, derivatives

from .common import CUTOFF_FACTOR

__all__ = ["Motion", "structure_motion", "band_floor", "BAND_FACTOR"]


@dataclass(frozen=True)
class Motion:
    """The de-noised displacement and the velocity of every DOF the basis functions are evaluated on."""

    z: np.ndarray
    v: np.ndarray
    velocity: str
    cutoffs_hz: tuple[float, ...]
    #: Each DOF's cut-off from its noise floor alone (before ``floor_hz`` and the cap), for a second pass.
    suggested_hz: tuple[float, ...] = ()
    #: How each DOF's velocity was obtained (``{"v1": ..., "vn": ...}``, reported under ``channel_sources``).
    sources: dict[str, ChannelSource] = field(default_factory=dict)


def structure_motion(
    record: Record, opt: dict[str, Any], floor_hz: float = 0.0, suggested: tuple[float, ...] = ()
) -> Motion:
    """Each DOF's ``z`` low-passed and ``v`` (measured and low-passed, or differentiated from ``z``).

    ``floor_hz`` raises the automatic cut-offs (not a given ``denoise_cutoff``) to at least that
    (:func:`band_floor`), capped at 0.4 fs. ``suggested``: :attr:`Motion.suggested_hz` of an earlier
    pass on the same record (the noise-floor cut-offs depend on the record alone).
    """
    fs = record.fs
    z = np.asarray(record.z, dtype=float)
    zd, vd, cutoffs, bases, sources = np.empty_like(z), np.empty_like(z), [], [], {}
    how = opt.get("velocity")
    measured = record.v is not None and how != "differentiate"
    if how == "measured" and record.v is None:
        raise DataError("velocity=measured needs the velocity channels v1..vn")
    for k in range(record.n_dofs):
        base = suggested[k] if suggested else derivatives.suggest_cutoff(z[:, k], fs)
        bases.append(float(base))
        cap = derivatives.CUTOFF_MAX_FRACTION * fs
        fc = opt.get("denoise_cutoff") or min(max(CUTOFF_FACTOR * base, floor_hz), cap)
        if not 0 < fc < fs / 2:
            raise InputError(f"denoise_cutoff must lie between 0 and the Nyquist frequency {fs / 2:g} Hz, got {fc:g}")
        zd[:, k] = derivatives.lowpass(z[:, k], fs, fc)
        if measured:
            vd[:, k] = derivatives.lowpass(np.asarray(record.v[:, k], dtype=float), fs, fc)
            what = f"zero-phase low-pass at {fc:.4g} Hz"
            sources[f"v{k + 1}"] = ChannelSource(True, f"measured, {what}", filter=what, cutoff_hz=float(fc))
        else:
            fcv = opt.get("velocity_cutoff") or fc
            vd[:, k], used = derivatives.differentiate(z[:, k], fs, order=1, cutoff=fcv)
            sources[f"v{k + 1}"] = ChannelSource.differentiated(used, f"z{k + 1}")
        cutoffs.append(float(fc))
    velocity = "measured v, low-passed" if measured else "differentiated from z"
    return Motion(zd, vd, velocity, tuple(cutoffs), tuple(bases), sources)


#: The automatic cut-offs are raised to this multiple of the highest identified natural frequency.
BAND_FACTOR = 3.0


def band_floor(motion: Motion, fn_hz: np.ndarray, opt: dict[str, Any], fs: float, dofs: set[int]) -> float | None:
    """The cut-off floor of a second pass, or ``None`` when the automatic cut-offs already pass the structure's band.

    ``dofs`` (from 0): the DOFs whose de-noised motion enters a channel (the elements' and, with
    ``k~1 > 0``, the driven DOFs'); only their cut-offs are checked.

    Each DOF's automatic cut-off comes from its own spectrum's noise floor, but
    every mode is in every DOF's motion: a mode that is weak at one DOF (the
    second mode in ``z1`` of ``2dof-double-well``) can sit where that DOF's
    low-pass already attenuates it (order-4 zero-phase Butterworth at 67 Hz:
    -9 % at 50.7 Hz). The basis functions then lack part of the true motion,
    a bias the noise correction cannot see; there the quadratic damping came
    out ~2-3 % low and, as ``v`` and ``v|v|`` are nearly collinear, the linear
    damping +20-30 %. A cut-off of at least :data:`BAND_FACTOR` times the
    highest identified mode attenuates the band by < 0.02 %.
    """
    if opt.get("denoise_cutoff") or not len(fn_hz):
        return None
    floor = BAND_FACTOR * float(np.max(fn_hz))
    cap = derivatives.CUTOFF_MAX_FRACTION * fs
    if all(motion.cutoffs_hz[k] >= min(floor, cap) * (1 - 1e-9) for k in dofs):
        return None
    return floor
