"""The verdict of a study section: which method is best at what, by how much, and why.

For every metric where lower is better (coefficient, mass, modal and
equilibrium errors, held-out ε, free-run error, time) the methods are
ordered by their median over the repetitions; the best is compared with the
next one:

* the **margin** is the difference of the two medians (and their ratio);
* the **spread** is the larger of the two methods' ranges (max - min over the
  repetitions). A margin smaller than the spread is reported as *within the
  spread*: the repetitions do not separate the two methods;
* methods run on the same records, so the comparison is also made **record by
  record**: on how many of the shared repetitions the best one is lower.

Methods whose values are identical on every record are one entry
(``rfs = sindy``). The overall ranking is the mean rank over the accuracy
metrics (time excluded; tied methods share the mean of their ranks). The
"why" of each method is drawn from its diagnostics: where its velocity came
from (the typed ``diagnostics["channel_sources"]`` of
:mod:`nlid.signal.channelsource`; a plugin that gives only text has its text
quoted, never parsed), its largest signed coefficient bias, what it did
(virtual perturbation and the number of k~1 averaged, from the accepted
members of ``diagnostics["k_tilde_ensemble"]``; one fit per well, terms kept
by sparse selection), whether it coincides with another method, its cost,
and the page of the documentation that explains it.

Every number of the verdict is a median, minimum or maximum that appears in
the section's tables (same significant digits), so the verdict can be checked
against them.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from ...base.formatting import column_digits, sig, spread_cell, wrap
from ...contract.methods import doc_pages
from ...signal.channelsource import ChannelSource, read_channel_sources
from .. import columns as col
from ..columns import COST_DIGITS

__all__ = ["Finding", "Verdict", "build_verdict", "METHOD_DOCS"]

#: Documentation page of each identifier, from its own ``docs`` attribute (the "see ..." of the verdict).
METHOD_DOCS: Mapping[str, str] = doc_pages

_SAME = 1e-6  # relative difference under which two runs' coefficients are the same number


@dataclass(frozen=True)
class Entry:
    """One method (or several with identical values on every record) on one metric."""

    methods: tuple[str, ...]
    median: float
    lo: float
    hi: float
    n: int
    values: pd.Series  # per repetition

    @property
    def name(self) -> str:
        """``rfs`` or ``rfs = sindy``."""
        return " = ".join(self.methods)

    @property
    def tied(self) -> bool:
        """True when the entry stands for several methods with identical values on every record."""
        return len(self.methods) > 1


def _and(names: list[str] | tuple[str, ...]) -> str:
    """``a``, ``a and b``, ``a, b and c``."""
    return names[0] if len(names) == 1 else ", ".join(names[:-1]) + " and " + names[-1]


@dataclass(frozen=True)
class Finding:
    """The best method on one metric and how it compares with the next one.

    Attributes
    ----------
    metric
        Label with its unit, e.g. ``"v (|error| %)"``.
    key
        The results column.
    kind
        ``"accuracy"`` or ``"cost"``.
    entries
        Every method (identical ones merged), best first.
    digits
        Significant digits of the metric (those of its table column).
    """

    metric: str
    key: str
    kind: str
    entries: tuple[Entry, ...]
    digits: int

    @property
    def best(self) -> Entry:
        """The entry with the lowest median."""
        return self.entries[0]

    @property
    def runner_up(self) -> Entry | None:
        """The next entry, if any."""
        return self.entries[1] if len(self.entries) > 1 else None

    @property
    def margin(self) -> float:
        """Median of the next entry minus the best one's (NaN without a next one)."""
        nxt = self.runner_up
        return float("nan") if nxt is None else nxt.median - self.best.median

    @property
    def spread(self) -> float:
        """The larger range (max - min over the repetitions) of the best and the next entry."""
        nxt = self.runner_up
        if nxt is None:
            return self.best.hi - self.best.lo
        return max(self.best.hi - self.best.lo, nxt.hi - nxt.lo)

    @property
    def within_spread(self) -> bool:
        """True when the margin is smaller than the spread: the repetitions do not separate the two."""
        return bool(self.runner_up is not None and self.margin < self.spread)

    @property
    def paired(self) -> tuple[int, int]:
        """``(records where the best is lower than the next, records both have)``."""
        nxt = self.runner_up
        if nxt is None:
            return 0, 0
        both = pd.concat([self.best.values, nxt.values], axis=1, join="inner").dropna()
        return int((both.iloc[:, 0] < both.iloc[:, 1]).sum()), len(both)

    def _value(self, e: Entry) -> str:
        return f"{e.name} {spread_cell(e.median, e.lo, e.hi, self.digits) if e.n > 1 else sig(e.median, self.digits)}"

    def cells(self) -> list[str]:
        """``[metric, best, next, margin, verdict]`` as text (the verdict table's row)."""
        nxt = self.runner_up
        if nxt is None:
            return [self.metric, self._value(self.best), "–", "–", self._alone()]
        return [self.metric, self._value(self.best), self._value(nxt), self.margin_text(), self.judgement()]

    def _alone(self) -> str:
        """Why the best entry has no next one: a tie of identical methods, or the only method with a value."""
        if self.best.tied:
            return f"{_and(self.best.methods)} tie: identical on every record"
        return "the only method with a value"

    def margin_text(self) -> str:
        """``0.68 (2.4x)``: the difference of the medians and their ratio."""
        nxt = self.runner_up
        if nxt is None:
            return "–"
        text = sig(self.margin, self.digits)
        if self.best.median > 0:
            ratio = nxt.median / self.best.median
            text += f" ({sig(ratio, 2)}x)"
        return text

    def judgement(self) -> str:
        """Clear or within the spread, and the record-by-record count."""
        wins, shared = self.paired
        what = "within the spread" if self.within_spread else "clear"
        text = f"{what} (spread {sig(self.spread, self.digits)})"
        if shared:
            text += f"; lower on {wins} of {shared} records"
        return text

    def sentence(self) -> str:
        """One line: ``v error (%): nsi-ip 0.48 [...] vs nsi-shift 1.2 [...]: lower by ...``."""
        nxt = self.runner_up
        if nxt is None:
            return f"{self.metric}: {self._value(self.best)} ({self._alone()})"
        return (
            f"{self.metric}: {self._value(self.best)} vs {self._value(nxt)}; "
            f"lower by {self.margin_text()}, {self.judgement()}"
        )


@dataclass
class Verdict:
    """The verdict of one study section (see the module documentation)."""

    findings: list[Finding]
    ranking: list[tuple[str, float, int]]  # (entry name, mean rank, metrics ranked on)
    reasons: dict[str, list[str]] = field(default_factory=dict)
    records: int = 0

    @property
    def best(self) -> str | None:
        """The method (or identical methods) with the best mean rank."""
        return self.ranking[0][0] if self.ranking else None

    def headline(self) -> str:
        """The overall ranking in one sentence; ties (equal mean ranks, identical methods) are said to tie."""
        tail = f"Medians over {self.records} repetition(s); lower is better."
        if not self.ranking:
            accuracy = [f for f in self.findings if f.kind == "accuracy"]
            if not accuracy:
                return "No method has a scored metric yet."
            names = list(dict.fromkeys(f.best.name for f in accuracy))
            if len(names) == 1 and accuracy[0].best.tied:
                methods = accuracy[0].best.methods
                return (
                    f"Overall: {_and(methods)} tie: their coefficients are identical on every record, so every "
                    f"accuracy metric ({len(accuracy)}) is the same. {tail}"
                )
            return f"Overall: only {_and(names)} {'has' if len(names) == 1 else 'have'} scored metrics. {tail}"
        count = max(n for _, _, n in self.ranking)
        ranks = ", ".join(f"{name} {r:.2g}" for name, r, _ in self.ranking)
        top = [name for name, r, _ in self.ranking if math.isclose(r, self.ranking[0][1])]
        lead = top[0] if len(top) == 1 else f"{_and(top)} tie"
        return f"Overall: {lead} (mean rank over {count} accuracy metrics, 1 = best on every one: {ranks}). {tail}"

    def separation(self) -> str:
        """Which metrics separate the methods beyond the spread, and which only record by record."""
        clear = [f.metric for f in self.findings if f.runner_up is not None and not f.within_spread]
        every = [f.metric for f in self.findings if f.within_spread and f.paired[1] > 1 and f.paired[0] == f.paired[1]]
        tied = [f for f in self.findings if f.runner_up is None and f.best.tied]
        parts = [f"Separated beyond the spread: {', '.join(clear) if clear else 'none'}."]
        if every:
            parts.append(f"Within the spread but lower on every record: {', '.join(every)}.")
        if tied:
            groups = list(dict.fromkeys(f.best.methods for f in tied))
            parts.append(
                f"Tied (identical on every record): {'; '.join(_and(g) for g in groups)} on {len(tied)} metric(s)."
            )
        if len(self.findings) > len(clear) + len(every) + len(tied):
            parts.append("Every other metric: within the spread over the repetitions.")
        return " ".join(parts)

    def wins(self) -> dict[str, int]:
        """How many metrics each entry is best at."""
        out: dict[str, int] = {}
        for f in self.findings:
            out[f.best.name] = out.get(f.best.name, 0) + 1
        return out

    def text(self, width: int = 100) -> str:
        """The verdict for a terminal, wrapped at ``width``."""
        lines = [wrap(self.headline(), width, subsequent="  "), wrap(self.separation(), width, subsequent="  ")]
        lines.append("Best per metric (best vs next: median [min, max]; margin (ratio); spread = larger range):")
        lines += [wrap(f.sentence(), width, indent="  ", subsequent="      ") for f in self.findings]
        lines.append("Why:")
        for method, why in self.reasons.items():
            lines.append(wrap(f"{method}: " + "; ".join(why), width, indent="  ", subsequent="      "))
        return "\n".join(lines)

    def table_rows(self) -> tuple[list[str], list[list[str]]]:
        """Header and rows of the per-metric table (Markdown and HTML)."""
        header = ["metric", "best: median [min, max]", "next", "margin (ratio)", "verdict"]
        return header, [f.cells() for f in self.findings]


# --------------------------------------------------------------------------- metrics
def _metrics(section: Any) -> list[tuple[str, str, bool, str]]:
    """``(column, label, absolute, kind)`` of the section's lower-is-better metrics."""
    cols = section.frame.columns
    out: list[tuple[str, str, bool, str]] = []

    def add(family: col.ColumnFamily, label: str | None = None, kind: str = "accuracy") -> None:
        out.append((family.key(label), family.verdict_title(label), bool(family.error), kind))

    for t in section.terms:
        if col.COEF_ERROR.key(t) in cols:
            add(col.COEF_ERROR, t)
    if col.MASS_ERROR.key() in cols:
        add(col.MASS_ERROR)
    for label in sorted(col.FN_ERROR.labels(cols), key=col.label_order):
        for family in (col.FN_ERROR, col.ZETA_ERROR):
            if family.key(label) in cols:
                add(family, label)
    if col.EQ_ERROR_MAX.key() in cols:
        add(col.EQ_ERROR_MAX)
    if col.EPS_HOLDOUT.key() in cols:
        add(col.EPS_HOLDOUT)
    elif col.EPS.key() in cols:
        add(col.EPS)
    if col.FREERUN_NRMSE.key() in cols:
        add(col.FREERUN_NRMSE)
    if col.SECONDS.key() in cols:
        add(col.SECONDS, kind="cost")
    return out


def _series(section: Any, method: str, key: str, absolute: bool) -> pd.Series:
    ok = section.ok(method)
    if key not in ok.columns:
        return pd.Series(dtype=float)
    x = pd.to_numeric(ok[key], errors="coerce")
    x.index = ok[col.REPETITION.key()].to_numpy()
    x = x[np.isfinite(x)]
    return x.abs() if absolute else x


def _same(a: pd.Series, b: pd.Series, rel: float = _SAME) -> bool:
    """Equal (to ``rel``) on every repetition, and present on the same ones."""
    if len(a) == 0 or set(a.index) != set(b.index):
        return False
    a, b = a.sort_index(), b.sort_index()
    scale = np.maximum(np.abs(a.to_numpy()), np.abs(b.to_numpy()))
    return bool(np.all(np.abs(a.to_numpy() - b.to_numpy()) <= rel * np.maximum(scale, 1e-300)))


def _finding(
    section: Any, key: str, label: str, absolute: bool, kind: str, same: dict[str, tuple[str, ...]]
) -> Finding | None:
    series = {m: _series(section, m, key, absolute) for m in section.present_methods}
    series = {m: s for m, s in series.items() if len(s)}
    if not series:
        return None
    groups: list[tuple[str, ...]] = []
    for m in series:
        g = tuple(x for x in same.get(m, (m,)) if x in series) if kind == "accuracy" else (m,)
        if g not in groups:
            groups.append(g)
    entries = []
    for g in groups:
        s = series[g[0]]
        entries.append(Entry(g, float(np.median(s)), float(s.min()), float(s.max()), len(s), s))
    entries.sort(key=lambda e: e.median)
    digits = COST_DIGITS if kind == "cost" else column_digits([(e.median, e.lo, e.hi) for e in entries])
    return Finding(label, key, kind, tuple(entries), digits)


def identical_methods(section: Any) -> dict[str, tuple[str, ...]]:
    """Methods whose coefficients agree (to 1e-6, relative) on every record, as groups: ``{method: group}``.

    Their metrics are then one entry of the verdict (``rfs = sindy``): derived quantities such as
    the modal errors, small differences of nearly equal numbers, would otherwise order them by rounding.
    """
    methods = section.present_methods
    out: dict[str, tuple[str, ...]] = {}
    for m in methods:
        if m in out:
            continue
        group = tuple(x for x in methods if x not in out and (x == m or _coefficients_same(section, m, x)))
        for x in group:
            out[x] = group
    return out


def _ranking(findings: list[Finding]) -> list[tuple[str, float, int]]:
    ranks: dict[str, list[float]] = {}
    for f in findings:
        if f.kind != "accuracy" or len(f.entries) < 2:
            continue
        medians = [e.median for e in f.entries]
        for e in f.entries:
            equal = [i for i, m in enumerate(medians) if m == e.median]
            ranks.setdefault(e.name, []).append(1 + float(np.mean(equal)))
    table = [(name, float(np.mean(r)), len(r)) for name, r in ranks.items()]
    return sorted(table, key=lambda t: (t[1], t[0]))


# --------------------------------------------------------------------------- why
def _velocity_sources(d: Mapping[str, Any]) -> list[ChannelSource]:
    """The typed sources of the velocity (``v``, or a structure's ``v1`` ... ``vn``) a run reported."""
    sources = read_channel_sources(d)
    if "v" in sources:
        return [sources["v"]]
    return [s for c, s in sorted(sources.items()) if c[:1] == "v" and c[1:].isdigit()]


def _velocity(diags: list[dict[str, Any]]) -> str | None:
    """Where the velocity came from: the typed ``channel_sources`` of the diagnostics, else the text as given.

    A plugin that reports only a line of text (``diagnostics["velocity"]`` or ``["channels"]["v"]``) has it
    quoted, never read: ``velocity: <its text>``.
    """
    for d in diags:
        sources = _velocity_sources(d)
        if sources:
            return _velocity_typed(sources)
        text = d.get("velocity") or (d.get("channels") or {}).get("v")
        if isinstance(text, str):
            return f"velocity: {text}"
    return None


def _velocity_typed(sources: list[ChannelSource]) -> str:
    if all(s.measured for s in sources):
        return "velocity measured"
    if all(s.operation == "differentiated" and (s.derived_from or "")[:1] == "z" for s in sources):
        cutoffs = sorted({s.cutoff_hz for s in sources if s.cutoff_hz is not None})
        text = "velocity from a low-passed derivative of z"
        if len(cutoffs) == 1:
            text += f" (fc {cutoffs[0]:.4g} Hz)"
        elif cutoffs:
            text += f" (fc {cutoffs[0]:.4g} to {cutoffs[-1]:.4g} Hz)"
        return text
    return "velocity: " + "; ".join(dict.fromkeys(s.text for s in sources))


def _k_tilde_members(d: Mapping[str, Any]) -> int:
    """How many values of k~1 the coefficients are the mean of: the accepted members of ``k_tilde_ensemble``."""
    members = d.get("k_tilde_ensemble")
    if not isinstance(members, list):
        return 0
    return sum(isinstance(m, Mapping) and m.get("accepted") is True for m in members)


def _bias(section: Any, method: str) -> str | None:
    """The coefficient with the largest median |error|, and whether its sign is systematic (a bias)."""
    worst: tuple[float, str, pd.Series] | None = None
    for t in section.terms:
        s = _series(section, method, col.COEF_ERROR.key(t), absolute=False)
        if len(s) and (worst is None or float(np.median(s.abs())) > worst[0]):
            worst = (float(np.median(s.abs())), t, s)
    if worst is None:
        return None
    med, term, s = worst
    a = s.abs()
    digits = column_digits([(med, float(a.min()), float(a.max()))])
    if len(s) > 1 and (np.all(s > 0) or np.all(s < 0)):
        sign = "+" if s.iloc[0] > 0 else "-"
        return (
            f"{term} biased {sign}{sig(med, digits)} % ({sign}{sig(float(a.min()), digits)} to "
            f"{sign}{sig(float(a.max()), digits)} %, the same sign on all {len(s)} records)"
        )
    return f"largest |error| on {term}: {sig(med, digits)} % (its sign changes over the records: scatter, not bias)"


def _mechanics(diags: list[dict[str, Any]], section: Any) -> list[str]:
    d = diags[0]
    out = []
    if "k_tilde" in d:
        text = f"virtual input perturbation k~1 = {sig(float(d['k_tilde']), 3)} N/m"
        members = _k_tilde_members(d)
        if members:
            text += f", coefficients averaged over {members} values of k~1"
        out.append(text)
    if "wells" in d:
        out.append(f"one identification per well (zero-reference shift), combined by their {d.get('combine', 'mean')}")
    if d.get("errors_in_variables_correction"):
        out.append("errors-in-variables correction of the noisy regressors")
    if "block_rows" in d:
        out.append(f"{d['block_rows']} block rows")
    kept = [x for x in diags if isinstance(x.get("kept_terms"), list)]
    if kept:
        library = kept[0].get("library") or []
        model = set(kept[0].get("_model_terms") or section.terms)
        exact = sum(set(x["kept_terms"]) == model for x in kept)
        extras: dict[str, int] = {}
        for x in kept:
            for t in x["kept_terms"]:
                if t not in model:
                    extras[t] = extras.get(t, 0) + 1
        text = f"sparse selection from {len(library)} candidate terms"
        rule = kept[0].get("threshold_rule")
        if rule:
            text += f" (threshold by {rule})"
        text += f": kept exactly the model's {len(model)} terms on {exact} of {len(kept)} records"
        if extras:
            text += "; also kept " + ", ".join(f"{t} ({n}/{len(kept)})" for t, n in extras.items())
        out.append(text)
    return out


def _coefficients_same(section: Any, a: str, b: str) -> bool:
    keys = [col.COEF.key(t) for t in section.terms_with(col.COEF)]
    return bool(keys) and all(_same(_series(section, a, k, False), _series(section, b, k, False)) for k in keys)


def _reasons(section: Any, findings: list[Finding]) -> dict[str, list[str]]:
    out: dict[str, list[str]] = {}
    time = next((f for f in findings if f.key == col.SECONDS.key()), None)
    fastest = time.best.median if time else None
    methods = section.present_methods
    for method in methods:
        why: list[str] = []
        frame = section.runs(method)
        ok = section.ok(method)
        if len(ok) < len(frame):
            why.append(f"{len(frame) - len(ok)} of {len(frame)} runs failed or timed out (see the failed runs)")
        diags = section.diagnostics.get(method, [])
        if diags:
            v = _velocity(diags)
            if v:
                why.append(v)
            why += _mechanics(diags, section)
        bias = _bias(section, method)
        if bias:
            why.append(bias)
        for other in methods:
            if (
                other != method
                and methods.index(other) < methods.index(method)
                and _coefficients_same(section, method, other)
            ):
                text = f"coefficients identical to {other}'s on every record"
                if any(isinstance(d.get("kept_terms"), list) for d in diags):
                    text += " (with the same terms kept, its final fit is least squares on the same columns)"
                why.append(text)
        if time is not None and fastest:
            s = _series(section, method, col.SECONDS.key(), False)
            if len(s):
                med = float(np.median(s))
                ratio = med / fastest
                why.append(
                    f"{sig(med, time.digits)} s per identification"
                    + (" (the fastest)" if math.isclose(med, fastest) else f" ({sig(ratio, 2)}x the fastest)")
                )
        if method in METHOD_DOCS:
            why.append(f"see {METHOD_DOCS[method]}")
        out[method] = why
    return out


def build_verdict(section: Any) -> Verdict:
    """The :class:`Verdict` of a section with results (see the module documentation)."""
    same = identical_methods(section)
    findings = [f for spec in _metrics(section) if (f := _finding(section, *spec, same)) is not None]
    repetition = col.REPETITION.key()
    records = int(section.frame[repetition].nunique()) if repetition in section.frame else 0
    return Verdict(findings, _ranking(findings), _reasons(section, findings), records)
