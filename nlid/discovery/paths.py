"""Candidate effects in the input path: the force acts delayed, lagged or held differently
(:mod:`nlid.estimation.inputpath`).

They add no term to the model: the loop fits the same model with the force passed through the path
(:func:`nlid.discovery.trials.test_input_path`), and they are judged like the terms (the equation-error rule,
the cross-fitted prediction).
"""

from __future__ import annotations

from dataclasses import dataclass

from ..data.forcehold import force_hold_source

__all__ = ["InputPathCandidate", "INPUT_PATH", "INPUT_PATH_GRID", "HALF_SAMPLE", "held_force_note"]


@dataclass(frozen=True)
class InputPathCandidate:
    """An effect in the input path (:mod:`nlid.estimation.inputpath`): the force acts delayed, lagged or held
    differently.

    It adds no term: the loop fits the same model with the force passed through the path, the path's
    time chosen on a grid of multiples of the sampling interval by the estimation residual and refined
    between the grid neighbours, as a shape parameter is (:func:`nlid.discovery.trials.test_input_path`).

    Parameters
    ----------
    name
        What reports and ``candidates=`` call it.
    kind
        ``"delay"``, ``"lag"`` (a time, fitted) or ``"hold"`` (the other force hold between samples).
    grid
        Multiples of the sampling interval tried (``delay``, ``lag``).
    description
        One line for reports.
    """

    name: str
    kind: str
    grid: tuple[float, ...] = ()
    description: str = ""
    requires: tuple[str, ...] = ()

    @property
    def terms(self) -> tuple[str, ...]:
        """No terms: the effect is in the input."""
        return ()

    @property
    def shapes(self) -> tuple[()]:
        """No shape grid of the term language (the path's grid is :attr:`grid`)."""
        return ()

    @property
    def uses_px(self) -> bool:
        """Never: the effect is in the input."""
        return False

    def describe(self) -> dict[str, object]:
        """JSON-friendly description."""
        return {
            "name": self.name,
            "terms": [],
            "input_path": self.kind,
            "grid_samples": list(self.grid),
            "description": self.description,
            "requires": list(self.requires),
        }


#: Delays and lags tried, in samples (refined between neighbours).
INPUT_PATH_GRID: tuple[float, ...] = (0.25, 0.5, 1.0, 2.0, 3.0, 5.0, 8.0)
#: The input-path effects (:class:`InputPathCandidate`).
INPUT_PATH: tuple[InputPathCandidate, ...] = (
    InputPathCandidate(
        "input-delay",
        "delay",
        INPUT_PATH_GRID,
        "the force acts delayed behind the force channel (a drive's current loop), or ahead of it (a filter or "
        "clock offset on the force channel): delay on a grid of +/- "
        + ", ".join(f"{g:g}" for g in INPUT_PATH_GRID)
        + " samples, refined",
    ),
    InputPathCandidate(
        "actuator-lag",
        "lag",
        INPUT_PATH_GRID,
        "the force acts through a first-order lag (an actuator or amplifier): time constant on a grid of "
        + ", ".join(f"{g:g}" for g in INPUT_PATH_GRID)
        + " samples, refined",
    ),
    InputPathCandidate(
        "force-hold",
        "hold",
        (),
        "the force is held between samples where the record says band-limited, or the reverse",
    ),
)


#: Delays and lags (in samples) that a force held over each sample (zoh) and read as sampled looks like: half a
#: sample, give or take (:func:`held_force_note`).
HALF_SAMPLE = (0.35, 0.65)


def held_force_note(path, record) -> str:
    """A note when an accepted delay or lag is about half a sample on a record that does not say how its force was
    held: a force held over each sample and read as band-limited acts half a sample late (issue 31's probe: such a
    record was given a lag of 0.51 samples and no word about the hold)."""
    if path is None or force_hold_source(record.meta) != "default" or record.force_hold != "sampled":
        return ""
    for what, seconds in (("delay", path.delay), ("lag", path.lag)):
        samples = float(seconds) * record.fs
        if HALF_SAMPLE[0] <= samples <= HALF_SAMPLE[1]:
            return (
                f"a {what} of {samples:.2g} samples is what a force held constant over each sample looks like when "
                "it is read as a sampled, band-limited signal, and the record does not say how its force was held: "
                "if it was held (a DAC's output, a simulation), give force_hold='zoh' and run again"
            )
    return ""
