"""What :func:`nlid.response.frequency_response` returns: curves, backbones, checks, band and measured points.

:class:`FrequencyResponse` is immutable; its methods that add something
(:meth:`~FrequencyResponse.verify`, :meth:`~FrequencyResponse.with_posterior`,
:meth:`~FrequencyResponse.compare`) return a new one. It renders as a tidy
frame (:meth:`~FrequencyResponse.to_frame`: one row per point and DOF),
plain data (:meth:`~FrequencyResponse.to_dict`), a
:class:`~nlid.report.summary.Summary` and a figure (:meth:`~FrequencyResponse.plot`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from ..base.jsonable import to_jsonable
from ..report.summary import Column, Summary
from .backbone import Backbone
from .curves import ResponseCurve
from .verify import BackboneCheck, PointCheck, SweepCheck

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd

    from .bands import ResponseBand
    from .measured import MeasuredResponse

__all__ = ["FrequencyResponse", "FRAME_COLUMNS", "SCHEMA"]

#: Identifies the JSON layout of :meth:`FrequencyResponse.to_dict`.
SCHEMA = "nlid.FrequencyResponse/1"
#: A point whose truncation residual (:func:`nlid.response.balance.time_residual`) is above this is flagged.
TRUNCATION_WARN = 1e-3
#: The columns of :meth:`FrequencyResponse.to_frame`.
FRAME_COLUMNS = (
    "curve",
    "force",
    "frequency_hz",
    "dof",
    "amplitude",
    "offset",
    "peak",
    "stable",
    "multiplier",
    "motion",
    "truncation",
    "point",
)


@dataclass(frozen=True, eq=False)
class FrequencyResponse:
    """The predicted nonlinear frequency response of a model (module docstring).

    Attributes
    ----------
    curves
        The continued curves, one per force level and starting equilibrium.
    band_hz
        The frequency band (Hz).
    harmonics, samples
        Number of harmonics and the quadrature size per period.
    dofs
        DOF names; ``forced`` the force pattern per DOF.
    notes
        How non-smooth and memory terms were treated, and anything else to know.
    backbones
        Backbone curves of the conservative part.
    checks, sweeps
        Time-integration checks (:meth:`verify`).
    uncertainty
        The band of the response over posterior draws (:meth:`with_posterior`).
    measured
        Measured points and the prediction's error on them (:meth:`compare`).
    seconds
        Wall time of the continuation.
    model
        The model it was computed from (not serialised).
    """

    curves: tuple[ResponseCurve, ...]
    band_hz: tuple[float, float]
    harmonics: int
    samples: int
    dofs: tuple[str, ...]
    forced: tuple[float, ...]
    notes: tuple[str, ...] = ()
    backbones: tuple[Backbone, ...] = ()
    checks: tuple[PointCheck, ...] = ()
    sweeps: tuple[SweepCheck, ...] = ()
    backbone_checks: tuple[BackboneCheck, ...] = ()
    uncertainty: ResponseBand | None = None
    measured: MeasuredResponse | None = None
    seconds: float = 0.0
    model: Any = field(default=None, repr=False)
    settings: Any = field(default=None, repr=False)

    # ------------------------------------------------------------------ numbers
    @property
    def forces(self) -> tuple[float, ...]:
        """The force amplitudes (N), each once, in order."""
        return tuple(dict.fromkeys(float(c.force[0]) for c in self.curves if c.parameter == "frequency"))

    @property
    def folds(self) -> list[dict[str, Any]]:
        """Every turning point: ``{"curve", "force", "frequency_hz", "amplitude"}`` (amplitude of the forced DOF)."""
        k = self._lead
        return [
            {"curve": i, "force": e.force, "frequency_hz": e.frequency_hz, "amplitude": e.amplitude[k]}
            for i, c in enumerate(self.curves)
            for e in c.folds
        ]

    @property
    def _lead(self) -> int:
        return int(np.argmax(np.abs(self.forced)))

    @property
    def max_error_percent(self) -> float | None:
        """The largest difference of a stable point from time integration (percent), if checked."""
        errs = [c.error_percent for c in self.checks if c.stable]
        return max(errs) if errs else None

    @property
    def unstable_reached(self) -> int | None:
        """How many unstable points a perturbed time integration settled on (0 expected), if checked."""
        tried = [c for c in self.checks if not c.stable]
        return sum(c.reached for c in tried) if tried else None

    # ------------------------------------------------------------------ adding to it
    def verify(self, points: int = 8, unstable: int = 3, sweep_rate: float | None = None) -> FrequencyResponse:
        """Check against time integration (:mod:`nlid.response.verify`); a new response with :attr:`checks`.

        Parameters
        ----------
        points, unstable
            Stable and unstable points per curve integrated in time.
        sweep_rate
            Also simulate sweeps up and down at this rate (Hz/s) and put their jumps beside the folds.
        """
        from .verify import check_backbones, check_points, check_sweeps

        pattern = np.asarray(self.forced)
        checks = check_points(self.model, self.curves, pattern, points=points, unstable=unstable)
        sweeps: list[SweepCheck] = []
        if sweep_rate is not None:
            sweeps = check_sweeps(self.model, self.curves, pattern, self.band_hz, float(sweep_rate), dof=self._lead + 1)
        bb = check_backbones(self.model, self.backbones) if self.backbones else []
        return dataclasses.replace(self, checks=tuple(checks), sweeps=tuple(sweeps), backbone_checks=tuple(bb))

    def with_posterior(
        self, posterior, draws: int = 100, *, level: float = 0.9, seed: int = 0, jobs: int | None = None
    ):
        """The band of the response over posterior draws (:func:`nlid.response.bands.response_band`)."""
        from .bands import response_band

        band = response_band(self, posterior, draws=draws, level=level, seed=seed, jobs=jobs)
        return dataclasses.replace(self, uncertainty=band)

    def compare(self, measured, *, direction: str | None = None) -> FrequencyResponse:
        """Measured points against the prediction (:func:`nlid.response.measured.score`)."""
        from .measured import score

        return dataclasses.replace(self, measured=score(self, measured, direction=direction))

    # ------------------------------------------------------------------ views
    def to_frame(self) -> pd.DataFrame:
        """One row per point and DOF: :data:`FRAME_COLUMNS` (amplitudes in m, force in N)."""
        import pandas as pd

        rows = []
        for i, c in enumerate(self.curves):
            for d, name in enumerate(c.dofs):
                amp, off, peak = c.amplitude(d + 1), c.offset(d + 1), c.peak(d + 1)
                trunc = c.truncation if c.truncation is not None else np.full(len(c), np.nan)
                for k in range(len(c)):
                    rows.append(
                        (i, c.force[k], c.frequency_hz[k], name, amp[k], off[k], peak[k], bool(c.stable[k]))
                        + (c.multiplier[k], c.labels[k], trunc[k], k)
                    )
        return pd.DataFrame(rows, columns=list(FRAME_COLUMNS))

    def to_dict(self) -> dict[str, Any]:
        """JSON-serialisable (what ``nlid response --json`` prints)."""
        return to_jsonable(
            {
                "schema": SCHEMA,
                "band_hz": list(self.band_hz),
                "harmonics": self.harmonics,
                "samples": self.samples,
                "dofs": list(self.dofs),
                "forced": list(self.forced),
                "notes": list(self.notes),
                "curves": [c.to_dict() for c in self.curves],
                "folds": self.folds,
                "backbones": [b.to_dict() for b in self.backbones],
                "checks": [c.to_dict() for c in self.checks],
                "max_error_percent": self.max_error_percent,
                "unstable_reached": self.unstable_reached,
                "sweeps": [s.to_dict() for s in self.sweeps],
                "backbone_checks": [c.to_dict() for c in self.backbone_checks],
                "uncertainty": None if self.uncertainty is None else self.uncertainty.to_dict(),
                "measured": None if self.measured is None else self.measured.to_dict(),
                "seconds": self.seconds,
            }
        )

    def summary(self) -> Summary:
        """The table ``nlid response`` prints: curves, turning points, checks, band and measured error."""
        k = self._lead
        out = Summary(
            f"frequency response: {len(self.curves)} curve(s), {self.band_hz[0]:g}-{self.band_hz[1]:g} Hz, "
            f"{self.harmonics} harmonics"
        )
        rows = []
        for i, c in enumerate(self.curves):
            a = c.amplitude(k + 1)
            motions = ", ".join(sorted({x for x in c.labels if x})) or "-"
            rows.append(
                [
                    str(i),
                    f"{c.force[0]:.4g}",
                    ", ".join(f"{x:.4g}" for x in c.start),
                    str(len(c)),
                    f"{int(np.sum(~c.stable))}",
                    f"{float(np.max(a)):.4g}",
                    f"{c.frequency_hz[int(np.argmax(a))]:.4g}",
                    motions,
                    c.stopped,
                ]
            )
        out.add_table(
            [
                Column("curve"),
                Column("force N", "right"),
                Column("from z* m", "right"),
                Column("points", "right"),
                Column("unstable", "right"),
                Column(f"max amplitude {self.dofs[k]} m", "right"),
                Column("at Hz", "right"),
                Column("motion"),
                Column("stopped"),
            ],
            rows,
        )
        events = [(i, e) for i, c in enumerate(self.curves) for e in c.events]
        if events:
            out.add_table(
                [
                    Column("curve"),
                    Column("special point"),
                    Column("Hz", "right"),
                    Column(f"amplitude {self.dofs[k]} m", "right"),
                ],
                [[str(i), e.kind, f"{e.frequency_hz:.5g}", f"{e.amplitude[k]:.4g}"] for i, e in events],
                gap=True,
            )
        if self.backbones:
            out.add_table(
                [Column("backbone"), Column("points", "right"), Column("Hz", "right"), Column("stopped")],
                [
                    [
                        b.label,
                        str(b.frequency_hz.size),
                        f"{b.frequency_hz.min():.4g}-{b.frequency_hz.max():.4g}",
                        b.stopped,
                    ]
                    for b in self.backbones
                ],
                gap=True,
            )
        lines: list[tuple[str, str]] = []
        worst = [
            float(np.nanmax(c.truncation))
            for c in self.curves
            if c.truncation is not None and np.isfinite(c.truncation).any()
        ]
        if worst:
            many = sum(int(np.sum(c.truncation > TRUNCATION_WARN)) for c in self.curves if c.truncation is not None)
            text = f"the harmonics left out would move the response by at most {max(worst):.2g} of its amplitude"
            if many:
                text += f"; {many} point(s) above {TRUNCATION_WARN:g}: more harmonics= would change them"
            lines.append(("truncation", text))
        if self.checks:
            stable = [c for c in self.checks if c.stable]
            tried = [c for c in self.checks if not c.stable]
            if stable:
                lines.append(
                    (
                        "checked against time integration",
                        f"{len(stable)} stable points, largest difference {self.max_error_percent:.3g} % "
                        f"(first-harmonic amplitude, every DOF)",
                    )
                )
            if tried:
                lines.append(
                    (
                        "unstable points",
                        f"{len(tried)} tried from 1 % away: {self.unstable_reached} reached by time integration",
                    )
                )
        if self.backbone_checks:
            worst = max(c.error_percent for c in self.backbone_checks)
            lines.append(
                (
                    "backbones against free runs",
                    f"{len(self.backbone_checks)} points, largest difference {worst:.3g} % (every DOF)",
                )
            )
        for s in self.sweeps:
            lines.append(
                (
                    f"sweep {s.direction} at {s.rate_hz_s:g} Hz/s (curve {s.curve})",
                    f"jump at {s.jump_hz:.5g} Hz, fold at {s.fold_hz:.5g} Hz ({s.difference_percent:+.2f} %)",
                )
            )
        if self.uncertainty is not None:
            lines += self.uncertainty.summary_lines()
        if self.measured is not None:
            lines += self.measured.summary_lines()
        lines += [("note", n) for n in self.notes]
        lines.append(("time", f"{self.seconds:.3g} s"))
        out.add_fields(lines, gap=True)
        return out

    def save(self, out_dir: Any, *, figure: bool = True, force: bool = False) -> list:
        """Write ``response.json`` (:meth:`to_dict`), ``response.csv`` (:meth:`to_frame`), ``response.md``
        (:meth:`summary`), ``response.png`` (:meth:`plot`) and, with measured points, ``measured.csv``.

        nlid writes only into folders it created or that were empty; ``force=True`` writes beside files
        it did not write, never replacing them (:mod:`nlid.runtime.outputs`).
        """
        import json

        from ..runtime.outputs import RESPONSE_OUTPUTS, output_folder

        with output_folder(out_dir, RESPONSE_OUTPUTS, force=force) as out:
            paths = [out / "response.json", out / "response.csv", out / "response.md"]
            paths[0].write_text(json.dumps(self.to_dict(), allow_nan=False) + "\n")
            self.to_frame().to_csv(paths[1], index=False)
            paths[2].write_text(self.summary().as_markdown() + "\n")
            if self.measured is not None:
                paths.append(out / "measured.csv")
                self.measured.to_frame().to_csv(paths[-1], index=False)
            if figure:
                from ..report.plotting import save_figure

                paths += save_figure(self.plot().figure, out / "response", formats=("png",))
        return paths

    def __repr__(self) -> str:
        return (
            f"<FrequencyResponse: {len(self.curves)} curve(s), forces {list(self.forces)} N, "
            f"{self.band_hz[0]:g}-{self.band_hz[1]:g} Hz, {len(self.folds)} fold(s)>"
        )

    def _repr_html_(self) -> str:
        return self.summary().as_html()

    def plot(self, ax: Any = None, *, dof: int | str | None = None, quantity: str = "amplitude") -> Any:
        """Amplitude against frequency (:func:`nlid.response.plots.plot_response`); returns the axes."""
        from .plots import plot_response

        return plot_response(self, ax=ax, dof=dof, quantity=quantity)
