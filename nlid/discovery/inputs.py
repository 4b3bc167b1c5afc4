"""What a search is given besides the identifier: the candidate effects and the division of the data.

Two small objects that replace half of the keywords of :func:`nlid.discovery.discover`:

* :class:`CandidateLibrary`: which candidate effects may be added (the
  library's, plugins', the user's, and the search's own ``mass`` and
  ``dictionary``); libraries compose with ``+``;
* :class:`Split`: how the record is divided into estimation and hold-out,
  and an optional validation record that informs but never decides.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from ..data.record import Record
from ..errors import DataError, InputError
from ..scoring import TransientRule, record_period, rule_from_spec
from .library import Candidate, resolve_candidates
from .paths import InputPathCandidate

__all__ = ["DEFAULT_HOLDOUT", "BUILTIN_CANDIDATES", "Split", "CandidateLibrary"]

#: Held-out fraction (last part of the record) when none is given.
DEFAULT_HOLDOUT = 0.25
#: Candidates the search builds itself (not in the library).
BUILTIN_CANDIDATES = ("mass", "dictionary")


@dataclass(frozen=True)
class Split:
    """How the data are divided: estimation and hold-out, and a validation record that informs but never decides.

    Parameters
    ----------
    holdout
        Fraction of the record held out (its last part), or a separate held-out record. A fraction of a
        periodic record (:func:`nlid.scoring.record_period`: declared, or a periodic force with a
        steady-state response) holds out whole periods: the nearest whole number of periods to the
        fraction, at least one, leaving at least one to estimate on; both parts keep the period
        (``meta["periodic"]``), so the held-out free run is scored in periodic steady state.
    validation
        A record on which every model is also scored (epsilon, force residual and free-run error)
        without taking part in any decision: e.g. a benchmark's validation set, whose excitation may
        differ from the estimation record's.
    freerun_rule
        The transient rule of the free runs on the held-out and validation records (a rule or its
        spelling, ``"window:50"``; :mod:`nlid.scoring.rules`); default: each record's own
        (:func:`nlid.scoring.default_rule`).

    Raises
    ------
    InputError
        ``holdout`` is neither a number nor a :class:`~nlid.data.record.Record`, or the rule is not one.
    DataError
        The held-out record has no sampling frequency.
    """

    holdout: float | Record = DEFAULT_HOLDOUT
    validation: Record | None = None
    freerun_rule: TransientRule | str | Mapping[str, Any] | None = None

    def __post_init__(self) -> None:
        if self.freerun_rule is not None:
            object.__setattr__(self, "freerun_rule", rule_from_spec(self.freerun_rule))
        if isinstance(self.holdout, Record) and not self.holdout.indexed:
            if self.holdout.fs <= 0:
                raise DataError("the held-out record has no sampling frequency")
            return
        try:
            float(self.holdout)
        except (TypeError, ValueError):
            raise InputError(f"holdout must be a fraction between 0 and 1 or a Record, got {self.holdout!r}") from None

    def divide(self, record: Record) -> tuple[Record, Record, str]:
        """The estimation record, the held-out record and a description of the hold-out."""
        if isinstance(self.holdout, Record) and not self.holdout.indexed:
            held = self.holdout
            return record, held, f"separate record ({held.n} samples, {held.meta.get('source', 'given')})"
        fraction = float(self.holdout)
        period, how = record_period(record)
        if period is not None and record.n // period >= 2:
            periods = record.n // period
            count = min(max(round(fraction * record.n / period), 1), periods - 1)
            marked = record.with_meta(periodic=period)
            cut = record.n - count * period
            estimation, held = marked[:cut], marked[cut:]
            whole = "period" if count == 1 else f"{count} periods"
            return estimation, held, f"last {whole} of the record ({held.n} samples; period {period} samples, {how})"
        estimation, held = record.split(fraction)
        return estimation, held, f"last {100 * fraction:g} % of the record ({held.n} samples)"


@dataclass(frozen=True)
class CandidateLibrary:
    """The candidate effects a search may add: named candidates, and the search's own ``mass`` and ``dictionary``.

    Build it with :meth:`select`; libraries compose with ``+`` (with another library, a
    :class:`~nlid.discovery.library.Candidate` or a ``"NAME=TERMS"`` string).

    Attributes
    ----------
    candidates
        The named candidates (the library's, plugins', the user's).
    mass
        Test the ``mass`` candidate (re-estimate a given mass).
    dictionary
        Test the ``dictionary`` candidate (sparse regression on an automatic dictionary, tried when no
        named candidate passes).
    """

    candidates: tuple[Candidate | InputPathCandidate, ...]
    mass: bool = True
    dictionary: bool = True

    @classmethod
    def select(
        cls,
        names: str | Iterable[str] | None = None,
        extra: Iterable[Candidate | str] = (),
        *,
        plugins: bool | Sequence[Candidate] = True,
    ) -> CandidateLibrary:
        """The candidates of a run.

        Parameters
        ----------
        names
            Names to test (comma-separated or an iterable; ``None`` or ``"all"``: every one): the
            library's, plugins', and the search's own ``mass`` and ``dictionary``.
        extra
            User candidates (:class:`~nlid.discovery.library.Candidate` or ``"NAME=TERMS"``).
        plugins
            Include candidates from installed plugins (``True``), none (``False``), or the given ones.

        Raises
        ------
        InputError
            An unknown name (with a suggestion), or two candidates with the same name.
        """
        if names is None or (isinstance(names, str) and names.strip().lower() in ("", "all")):
            return cls(tuple(resolve_candidates(names, extra, plugins=plugins)), True, True)
        items = [n.strip() for n in (names.split(",") if isinstance(names, str) else names) if n.strip()]
        rest = [n for n in items if n not in BUILTIN_CANDIDATES]
        return cls(tuple(resolve_candidates(rest, extra, plugins=plugins)), "mass" in items, "dictionary" in items)

    @property
    def names(self) -> list[str]:
        """The named candidates' names, in order."""
        return [c.name for c in self.candidates]

    def __add__(self, other: CandidateLibrary | Candidate | str) -> CandidateLibrary:
        if isinstance(other, CandidateLibrary):
            extra, mass, dictionary = other.candidates, other.mass, other.dictionary
        elif isinstance(other, (Candidate, str)):
            cand = other if isinstance(other, Candidate) else Candidate.from_spec(other)
            extra, mass, dictionary = (cand,), False, False
        else:
            return NotImplemented
        clash = sorted(set(self.names) & {c.name for c in extra})
        if clash:
            raise InputError(f"two candidates are called {clash[0]!r}; give user candidates distinct names")
        return CandidateLibrary(self.candidates + tuple(extra), self.mass or mass, self.dictionary or dictionary)
