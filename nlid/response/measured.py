"""Measured points: the first-harmonic amplitude per frequency of a stepped-sine or swept-sine record.

:func:`measure` reads any one-DOF :class:`nlid.Record` (a file through
:func:`nlid.load`, with any column map). The force's phase is taken from its
upward zero crossings (``2 pi k`` at the ``k``-th, linear in between), so the
frequency at every cycle is known without being told. Consecutive cycles
whose frequency stays within :data:`STEP_TOLERANCE` of the first make a
*step*; a record of long steps is a stepped sine, anything else a sweep. When
the record says where its steps are (``meta["signal"]["steps"]``, as the
sine presets write), that is used instead.

Each step (or, for a sweep, each window of ``cycles`` cycles) is fitted by
least squares with ``c0 + a cos(phase) + b sin(phase)``, for the displacement
and for the force, over its settled part (a stepped sine's last ``1 - settle``
of the step, whole cycles): the point is the step's frequency, the force
amplitude, the displacement's first-harmonic amplitude and offset, and the
direction the frequency was moving.

:func:`score` puts the points beside a prediction
(:class:`~nlid.response.FrequencyResponse`): the curve of the same force whose
offset at the first point is nearest the measured one (the well the test was
in), read along the frequencies in the order they were played, staying on a
branch while it lasts and landing on the other one where it ends
(:meth:`~nlid.response.ResponseCurve.follow`: the hysteresis of a slow test),
and reports the prediction error ``100 |predicted - measured| / |measured|``
(norms over the points).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import InputError

__all__ = ["MeasuredResponse", "measure", "score", "STEP_TOLERANCE"]

#: Cycles belong to one step while their frequency stays within this fraction of the step's first cycle.
STEP_TOLERANCE = 2e-3
#: Least cycles of a step (fewer: the record is read as a sweep).
MIN_CYCLES = 8


@dataclass(frozen=True, eq=False)
class MeasuredResponse:
    """Points of a measured frequency response (module docstring).

    Attributes
    ----------
    frequency_hz, force, amplitude, offset
        Per point: frequency (Hz), force amplitude (N), first-harmonic amplitude and offset of ``z`` (m).
    direction
        ``"up"`` or ``"down"`` per point.
    kind
        ``"stepped"`` or ``"swept"``.
    source
        Where the record came from.
    predicted
        The prediction at each point (NaN where the response has none), after :func:`score`.
    error_percent
        ``100 |predicted - measured| / |measured|`` over the predicted points, after :func:`score`.
    """

    frequency_hz: np.ndarray
    force: np.ndarray
    amplitude: np.ndarray
    offset: np.ndarray
    direction: tuple[str, ...]
    kind: str
    source: str = ""
    predicted: np.ndarray | None = None
    error_percent: float | None = None

    def __len__(self) -> int:
        return int(self.frequency_hz.size)

    def to_frame(self) -> Any:
        """One row per point: frequency, force, amplitude, offset, direction, predicted."""
        import pandas as pd

        return pd.DataFrame(
            {
                "frequency_hz": self.frequency_hz,
                "force": self.force,
                "amplitude": self.amplitude,
                "offset": self.offset,
                "direction": list(self.direction),
                "predicted": np.full(len(self), np.nan) if self.predicted is None else self.predicted,
            }
        )

    def to_dict(self) -> dict[str, Any]:
        """Plain data."""
        return {
            "kind": self.kind,
            "source": self.source,
            "frequency_hz": self.frequency_hz.tolist(),
            "force": self.force.tolist(),
            "amplitude": self.amplitude.tolist(),
            "offset": self.offset.tolist(),
            "direction": list(self.direction),
            "predicted": None if self.predicted is None else self.predicted.tolist(),
            "error_percent": self.error_percent,
        }

    def summary_lines(self) -> list[tuple[str, str]]:
        """``(key, value)`` lines for :meth:`nlid.response.FrequencyResponse.summary`."""
        where = f" ({self.source})" if self.source else ""
        out = [("measured", f"{len(self)} {self.kind}-sine points{where}")]
        if self.error_percent is not None and self.predicted is not None:
            missed = int(np.sum(~np.isfinite(self.predicted)))
            extra = f"; {missed} point(s) outside the prediction" if missed else ""
            out.append(("prediction error", f"{self.error_percent:.3g} % of the measured amplitude{extra}"))
        return out

    def draw(self, ax: Any, dof: int) -> None:
        """The points as open markers (up: circles, down: squares)."""
        if dof != 0:
            return
        for direction, marker in (("up", "o"), ("down", "s")):
            k = np.array([d == direction for d in self.direction])
            if k.any():
                ax.plot(
                    self.frequency_hz[k],
                    self.amplitude[k],
                    marker,
                    mfc="none",
                    color="k",
                    ms=4,
                    label=f"measured ({direction})",
                )


def _phase(f: np.ndarray, fs: float) -> tuple[np.ndarray, np.ndarray]:
    """The force's upward zero crossings (s) and its phase at every sample (rad; NaN outside the crossings)."""
    x = f - np.median(f)
    up = np.flatnonzero((x[:-1] < 0) & (x[1:] >= 0))
    if up.size < 4:
        raise InputError("the record's force has fewer than 4 cycles: it is not a stepped or swept sine")
    frac = -x[up] / (x[up + 1] - x[up])
    t_up = (up + frac) / fs
    t = np.arange(f.size) / fs
    phase = np.interp(t, t_up, 2 * np.pi * np.arange(t_up.size), left=np.nan, right=np.nan)
    return t_up, phase


def _segments(t_up: np.ndarray, fs: float, steps: Any) -> tuple[list[tuple[int, int, float]], str]:
    """``[(first sample, end sample, frequency)]`` of each step, and the kind."""
    if steps:
        return [(int(a), int(b), float(fr)) for fr, a, b in steps], "stepped"
    freq = 1.0 / np.diff(t_up)
    groups = []
    k = 0
    while k < freq.size:
        j = k
        while j + 1 < freq.size and abs(freq[j + 1] - freq[k]) <= STEP_TOLERANCE * freq[k]:
            j += 1
        groups.append((k, j))
        k = j + 1
    long = [g for g in groups if g[1] - g[0] + 1 >= MIN_CYCLES]
    if long and sum(g[1] - g[0] + 1 for g in long) >= 0.8 * freq.size:
        out = []
        for a, b in long:
            out.append((int(t_up[a] * fs), int(t_up[b + 1] * fs), float(np.mean(freq[a : b + 1]))))
        return out, "stepped"
    return [], "swept"


def _fit(y: np.ndarray, phase: np.ndarray) -> tuple[float, float]:
    """Offset and first-harmonic amplitude of ``y`` on ``[1, cos phase, sin phase]``."""
    basis = np.column_stack([np.ones(y.size), np.cos(phase), np.sin(phase)])
    coef, *_ = np.linalg.lstsq(basis, y, rcond=None)
    return float(coef[0]), float(np.hypot(coef[1], coef[2]))


def measure(record, *, settle: float = 0.5, cycles: int = 10) -> MeasuredResponse:
    """The measured points of a one-DOF stepped-sine or swept-sine record (module docstring).

    Parameters
    ----------
    record
        A :class:`nlid.Record` with ``f`` and ``z`` (or what :func:`nlid.load` reads).
    settle
        The fraction of each step left to the transient.
    cycles
        Cycles per point of a sweep.

    Raises
    ------
    InputError
        A record without a force of at least 4 cycles, or without steps or windows to fit.
    """
    from ..data.sources import as_record

    record = as_record(record)
    if not 0 <= settle < 1:
        raise InputError(f"settle= must be from 0 to 1 (excluded), got {settle!r}")
    if isinstance(cycles, bool) or not isinstance(cycles, int) or cycles < 2:
        raise InputError(f"cycles= must be an integer of at least 2, got {cycles!r}")
    f, z, fs = np.asarray(record.f, dtype=float), np.asarray(record.z, dtype=float), float(record.fs)
    t_up, phase = _phase(f, fs)
    steps = dict(record.meta.get("signal") or {}).get("steps")
    if steps and int(steps[-1][2]) != z.size:  # a part of the record: the saved steps do not apply
        steps = None
    segments, kind = _segments(t_up, fs, steps)
    rows = []
    if kind == "stepped":
        for a, b, freq in segments:
            n_cycles = (b - a) / fs * freq
            keep = int(np.floor(n_cycles * (1 - settle)))
            if keep < 2:
                continue
            start = b - int(round(keep / freq * fs))
            ph = phase[start:b]
            ok = np.isfinite(ph)
            if ok.sum() < 8:
                continue
            off, amp = _fit(z[start:b][ok], ph[ok])
            _, fa = _fit(f[start:b][ok], ph[ok])
            rows.append((freq, fa, amp, off))
    else:
        edges = (t_up[::cycles] * fs).astype(int)
        for a, b in zip(edges[:-1], edges[1:], strict=True):
            ph = phase[a:b]
            ok = np.isfinite(ph)
            if ok.sum() < 8:
                continue
            freq = cycles * fs / (b - a)
            off, amp = _fit(z[a:b][ok], ph[ok])
            _, fa = _fit(f[a:b][ok], ph[ok])
            rows.append((freq, fa, amp, off))
    if len(rows) < 2:
        raise InputError("no steps or sweep windows could be fitted in the record")
    arr = np.array(rows)
    freq = arr[:, 0]
    step = np.diff(freq)
    direction = ["up" if d > 0 else "down" for d in step]
    direction.append(direction[-1])
    return MeasuredResponse(
        freq, arr[:, 1], arr[:, 2], arr[:, 3], tuple(direction), kind, str(record.meta.get("source", ""))
    )


def score(response, measured, *, direction: str | None = None) -> MeasuredResponse:
    """The prediction at every measured point and its error (module docstring).

    Parameters
    ----------
    response
        A :class:`~nlid.response.FrequencyResponse` continued in frequency, at the measured force.
    measured
        A :class:`MeasuredResponse` or a record (read by :func:`measure`).
    direction
        ``"up"`` or ``"down"`` to read every point along that sweep path from the band's end; default:
        the points in the order played (:meth:`~nlid.response.ResponseCurve.follow`).

    Raises
    ------
    InputError
        When the response has no curve at the measured force (within 5 %).
    """
    if not isinstance(measured, MeasuredResponse):
        measured = measure(measured)
    if direction not in (None, "up", "down"):
        raise InputError(f"direction= must be 'up' or 'down', got {direction!r}")
    curves = [c for c in response.curves if c.parameter == "frequency"]
    d = response._lead
    forces = sorted({round(float(F), 12) for F in measured.force})
    predicted = np.full(len(measured), np.nan)
    for F in (
        {float(np.median(measured.force))} if np.ptp(measured.force) <= 0.05 * np.median(measured.force) else forces
    ):
        near = [c for c in curves if abs(c.force[0] - F) <= 0.05 * F]
        if not near:
            shown = ", ".join(f"{c.force[0]:.4g}" for c in curves)
            raise InputError(
                f"the measured force is {F:.4g} N but the response has curves at {shown} N: "
                "compute it at the measured force (force=)"
            )
        mine = np.abs(measured.force - F) <= 0.05 * F
        # the curve of the well the test was in: the offset of its first point
        first = int(np.flatnonzero(mine)[0])
        curve = min(
            near,
            key=lambda c: abs(
                float(
                    np.interp(
                        measured.frequency_hz[first],
                        np.sort(c.frequency_hz),
                        c.offset(d + 1)[np.argsort(c.frequency_hz)],
                    )
                )
                - measured.offset[first]
            ),
        )
        if direction is None:
            predicted[mine] = curve.follow(measured.frequency_hz[mine], d + 1, measured.amplitude[first])
        else:
            predicted[mine] = curve.along(measured.frequency_hz[mine], direction, d + 1)[0]
    ok = np.isfinite(predicted)
    err = None
    if ok.any():
        err = float(
            100 * np.linalg.norm(predicted[ok] - measured.amplitude[ok]) / np.linalg.norm(measured.amplitude[ok])
        )
    return dataclasses.replace(measured, predicted=predicted, error_percent=err)
