"""The result types of :func:`nlid.discovery.structure.discover_structure` (plain data, ``to_dict``, reports)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import InputError
from ..model.terms import Term
from .evidence import AcceptanceRule
from .probes import MIN_STRUCTURE

__all__ = [
    "DOF_PROBES",
    "ConnectionEvidence",
    "StructureStage",
    "StructureStep",
    "ConnectionProbe",
    "StructureRemaining",
    "StructureDiscoveryResult",
    "write_structure_report",
    "connection_name",
    "parse_connections",
]

Connection = tuple[int, int]


def connection_name(c: Connection) -> str:
    """``5-ground`` or ``4-5``."""
    return f"{c[0]}-ground" if c[1] == 0 else f"{c[0]}-{c[1]}"


def parse_connections(spec: Any, n_dofs: int) -> tuple[Connection, ...]:
    """The connections to test: every pair and every DOF to the ground (``None``), or the ones given.

    ``spec`` is a list of ``(i, j)`` (``j = 0``: the ground) or a string ``"4-5, 5-0, z3"`` (``z3`` or ``3-0``:
    DOF 3 to the ground; ``z4-z5`` or ``4-5``: the pair).

    Raises
    ------
    InputError
        A malformed connection or one naming a DOF the record does not have.
    """
    if spec is None or (isinstance(spec, str) and spec.strip().lower() in ("", "all")):
        pairs = [(i, j) for i in range(1, n_dofs + 1) for j in range(i + 1, n_dofs + 1)]
        return tuple(pairs + [(k, 0) for k in range(1, n_dofs + 1)])
    items: list[Any] = [s.strip() for s in spec.split(",") if s.strip()] if isinstance(spec, str) else list(spec)
    out: list[Connection] = []
    for item in items:
        if isinstance(item, str):
            text = item.replace("z", "").replace("ground", "0").replace(" ", "")
            parts = text.split("-") if "-" in text else [text, "0"]
            try:
                i, j = (int(x) for x in parts)
            except ValueError:
                raise InputError(
                    f"connection {item!r}: write 'i-j' (two DOFs), 'k-0' or 'zk' (DOF k to the ground)"
                ) from None
        else:
            try:
                i, j = (int(x) for x in item)
            except (TypeError, ValueError):
                raise InputError(f"connection {item!r}: give (i, j), j = 0 for the ground") from None
        if i == j or min(i, j) < 0 or max(i, j) > n_dofs or max(i, j) < 1:
            raise InputError(f"connection {item!r} is not between two DOFs (1..{n_dofs}) or a DOF and the ground (0)")
        c = (i, 0) if j == 0 else ((j, 0) if i == 0 else (min(i, j), max(i, j)))
        if c not in out:
            out.append(c)
    if not out:
        raise InputError("connections= names no connection")
    return tuple(out)


# --------------------------------------------------------------------------- result types
@dataclass(frozen=True)
class ConnectionEvidence:
    """A candidate placed on one connection, and what it explained.

    Attributes
    ----------
    effect
        The candidate's name (``cubic-stiffness``).
    connection
        ``(i, j)``, ``j = 0`` the ground.
    elements
        The element(s) it adds, canonical spelling (``z5^3``); empty when not applicable.
    coefficients
        Their coefficients fitted on the selection record.
    shape
        The shape parameter(s) chosen on the grid (by the same cross-fitted score), or ``None``.
    explained
        Cross-fitted held-out fraction of the residual of the DOFs it acts on (the ranking score).
    explained_holdout, explained_estimation
        The two directions: fitted on the other part, scored on this one.
    explained_all
        The cross-fitted fraction over every DOF.
    explained_per_dof
        Cross-fitted fraction per DOF.
    delta_bic
        Change of the effective-sample-size BIC on the estimation part.
    parameters
        Parameters it adds (coefficients plus shapes chosen on a grid).
    status, reason
        ``accepted``, ``passes``, ``below threshold``, ``not significant``, ``rejected``, ``not applicable``.
    terms
        The one-DOF terms of its elements (what is added when it is accepted).
    """

    effect: str
    connection: Connection
    elements: tuple[str, ...] = ()
    coefficients: Mapping[str, float] = field(default_factory=dict)
    shape: Any = None
    explained: float | None = None
    explained_holdout: float | None = None
    explained_estimation: float | None = None
    explained_all: float | None = None
    explained_per_dof: tuple[float, ...] = ()
    delta_bic: float | None = None
    parameters: int = 0
    status: str = "not applicable"
    reason: str = ""
    terms: tuple[Term, ...] = field(default=(), repr=False)

    @property
    def where(self) -> str:
        """The connection as text, ``5-ground`` or ``4-5``."""
        return connection_name(self.connection)

    def to_dict(self) -> dict[str, Any]:
        """JSON-friendly dictionary."""
        return {
            "effect": self.effect,
            "connection": list(self.connection),
            "where": self.where,
            "elements": list(self.elements),
            "coefficients": dict(self.coefficients),
            "shape": list(self.shape) if isinstance(self.shape, tuple) else self.shape,
            "explained": self.explained,
            "explained_holdout": self.explained_holdout,
            "explained_estimation": self.explained_estimation,
            "explained_all": self.explained_all,
            "explained_per_dof": list(self.explained_per_dof),
            "delta_bic": self.delta_bic,
            "parameters": self.parameters,
            "status": self.status,
            "reason": self.reason,
        }


@dataclass(frozen=True)
class StructureStage:
    """One model of the search and its errors on the test part.

    Attributes
    ----------
    label
        ``declared model`` or ``after step k: EFFECT on CONNECTION``.
    model
        The :class:`~nlid.model.structure.StructuralModel` fitted on the selection record.
    eps_percent
        Epsilon per DOF on the test part, ``100 RMS(R_e - R_hat) / RMS(R_e)`` (Eq. 26 per DOF).
    eps_selection_percent
        The same on the selection record (in-sample).
    freerun_rms
        RMS free-run error of each DOF's displacement on the test part (m); ``nan`` when it diverged.
    freerun_percent
        The same relative to the standard deviation of each DOF's measured displacement (%).
    freerun_note
        How the free run was made, or why it failed.
    predict_percent, predict_steps
        Each DOF's ``k``-step-ahead prediction error on the test part (% of the standard deviation of its
        displacement; runs of ``predict_steps`` samples, each from the measured state at its start): a figure
        that a lightly damped or chaotic structure's free run, whose error a small frequency error or the
        sensitivity to the start makes large, does not give (issue 31's probe).
    """

    label: str
    model: Any = field(repr=False)
    eps_percent: tuple[float, ...] = ()
    eps_selection_percent: tuple[float, ...] = ()
    freerun_rms: tuple[float, ...] = ()
    freerun_percent: tuple[float, ...] = ()
    freerun_note: str = ""
    predict_percent: tuple[float, ...] = ()
    predict_steps: int | None = None

    @property
    def elements(self) -> tuple[str, ...]:
        """The model's elements."""
        return tuple(self.model.elements.names)

    def to_dict(self) -> dict[str, Any]:
        """JSON-friendly dictionary (the model as :meth:`nlid.model.structure.StructuralModel.to_dict`)."""
        return {
            "label": self.label,
            "elements": list(self.elements),
            "coefficients": dict(self.model.coefficients),
            "model": self.model.to_dict(),
            "eps_percent": list(self.eps_percent),
            "eps_selection_percent": list(self.eps_selection_percent),
            "freerun_rms": list(self.freerun_rms),
            "freerun_percent": list(self.freerun_percent),
            "freerun_note": self.freerun_note,
            "predict_percent": list(self.predict_percent),
            "predict_steps": self.predict_steps,
        }


@dataclass(frozen=True)
class StructureStep:
    """An accepted element: where, what, the evidence, and the model before and after."""

    number: int
    evidence: ConnectionEvidence
    before: StructureStage
    after: StructureStage
    ranking: tuple[ConnectionEvidence, ...] = ()

    @property
    def connection(self) -> Connection:
        """Where the element acts."""
        return self.evidence.connection

    def to_dict(self) -> dict[str, Any]:
        """JSON-friendly dictionary (the ranking's best 10)."""
        return {
            "number": self.number,
            "effect": self.evidence.effect,
            "connection": list(self.connection),
            "where": self.evidence.where,
            "elements": list(self.evidence.elements),
            "evidence": self.evidence.to_dict(),
            "before": self.before.label,
            "after": self.after.label,
            "ranking": [e.to_dict() for e in self.ranking[:10]],
        }


@dataclass(frozen=True)
class ConnectionProbe:
    """A remaining-structure probe on one connection: the cross-fitted held-out fraction it predicts.

    Its fractions are counted beyond ``null``: what the same probe finds on the current model simulated at the
    record's noise (:func:`nlid.discovery.structure_probes.probe_null`; 0 when there is no null).
    """

    connection: Connection
    probe: str
    explained: float
    explained_holdout: float
    explained_estimation: float
    columns: int
    null: float = 0.0
    #: The acceleration probe's correction of its DOF's mass (kg; its sign is what to read:
    #: :func:`nlid.discovery.structure_probes.mass_corrections`) and the mass given; ``None`` for the other probes.
    mass_change: float | None = None
    given_mass: float | None = None

    def to_dict(self) -> dict[str, Any]:
        """JSON-friendly dictionary."""
        return {
            "connection": list(self.connection),
            "where": connection_name(self.connection),
            "probe": self.probe,
            "explained": self.explained,
            "explained_holdout": self.explained_holdout,
            "explained_estimation": self.explained_estimation,
            "columns": self.columns,
            "null": self.null,
            "mass_change": self.mass_change,
            "given_mass": self.given_mass,
        }


_WHAT = {"z": "the relative displacement", "v": "the relative velocity", "memory": "the history of the displacement"}
#: Probes of one DOF's residual for what no connection carries (:func:`nlid.discovery.structure._dof_columns`):
#: a wrong mass, the force's path. Each with what it finds and its likely cause.
DOF_PROBES = ("acceleration", "force", "time")
_DOF_WHAT = {
    "acceleration": "its acceleration: the mass matrix given is likely wrong there (check its values and their "
    "units, kg; and the units of the displacements and forces)",
    "force": "the force's neighbouring samples: an effect in the force's path (the force acting delayed, early or "
    "filtered), or a mass matrix wrong there",
    "time": "time itself: a drift (a displacement sensor's offset creeping, a temperature) or a parameter that "
    "changes during the record; check the sensors for drift and identify on parts short enough to be stationary",
}


@dataclass(frozen=True)
class StructureRemaining:
    """What the probes find in a model's residual, connection by connection."""

    probes: tuple[ConnectionProbe, ...]
    threshold: float = MIN_STRUCTURE
    #: Whether the probes were counted beyond a null (:func:`nlid.discovery.structure_probes.probe_null`); not when
    #: the model's free run diverged.
    null: bool = True

    @property
    def best(self) -> ConnectionProbe | None:
        """The probe that explains most."""
        return max(self.probes, key=lambda p: p.explained, default=None)

    @property
    def structured(self) -> bool:
        """True when some probe reaches the threshold."""
        best = self.best
        return best is not None and best.explained >= self.threshold

    @property
    def explained(self) -> float:
        """The largest fraction over connections and probes."""
        best = self.best
        return float("nan") if best is None else best.explained

    def describe(self) -> str:
        """One sentence: clean, or where structure remains and of what kind."""
        best = self.best
        if best is None:
            return "no probe was run"
        where = f"DOF {best.connection[0]}" if best.probe in DOF_PROBES else connection_name(best.connection)
        if not self.structured:
            return (
                f"clean: no flexible function of a connection, and neither a DOF's acceleration, its force's "
                f"neighbouring samples nor time, predicts {100 * self.threshold:g} % or more of the "
                f"held-out residual of its DOFs (largest: {best.probe} on {where}, "
                f"{100 * max(best.explained, 0.0):.2g} %)"
            )
        unchecked = "" if self.null else " (not counted beyond noise: the model's simulated null diverged)"
        if best.probe in _DOF_WHAT:
            said = unchecked
            if best.mass_change is not None and best.given_mass is not None and best.probe == "acceleration":
                way = "smaller" if best.mass_change < 0 else "larger"
                said = f" (the data ask for a {way} mass there than the {best.given_mass:.4g} kg given){unchecked}"
            return (
                f"{100 * best.explained:.2g} % of the held-out residual of DOF {best.connection[0]} remains "
                f"predictable from {_DOF_WHAT[best.probe]}{said}"
            )
        return (
            f"{100 * best.explained:.2g} % of the held-out residual of the DOFs of connection {where} remains "
            f"predictable from {_WHAT[best.probe]} of that connection; try candidates of that kind there "
            f"(connections=, extra_candidates=){unchecked}"
        )

    def to_dict(self) -> dict[str, Any]:
        """JSON-friendly dictionary."""
        return {
            "structured": self.structured,
            "explained": self.explained,
            "threshold": self.threshold,
            "null": self.null,
            "text": self.describe(),
            "probes": [p.to_dict() for p in self.probes],
        }


@dataclass(frozen=True)
class StructureDiscoveryResult:
    """The outcome of :func:`discover_structure` (plain data; :meth:`to_dict` for JSON).

    Attributes
    ----------
    declared
        The declared elements.
    n_dofs
        Number of DOFs.
    connections
        The connections tested.
    candidates
        The candidate effects tested on each.
    stages
        The declared model, then one per accepted element.
    steps
        The accepted elements.
    ranking
        The last round's candidates, best first (the round that accepted nothing, or the last one).
    remaining
        The probes on the declared and the final model.
    stop_reason
        Why the search stopped.
    rule
        The acceptance rule.
    info
        Samples of each part, band, weights, seconds...
    refined
        The final elements refitted by the refining identifier (``discover_structure(refine=True)``; ``None``
        otherwise), with its errors on the same test part.
    """

    declared: tuple[str, ...]
    n_dofs: int
    connections: tuple[Connection, ...]
    candidates: tuple[str, ...]
    stages: tuple[StructureStage, ...]
    steps: tuple[StructureStep, ...]
    ranking: tuple[ConnectionEvidence, ...]
    remaining_declared: StructureRemaining
    remaining: StructureRemaining
    stop_reason: str
    rule: AcceptanceRule
    info: Mapping[str, Any] = field(default_factory=dict)
    refined: StructureStage | None = None

    @property
    def final(self) -> StructureStage:
        """The final model's stage (the search's equation-error fit; :attr:`refined` holds a refit)."""
        return self.stages[-1]

    @property
    def model(self) -> Any:
        """The final structure model reported: the refit (:attr:`refined`) if there is one, else :attr:`final`'s."""
        return (self.refined or self.final).model

    @property
    def reported(self) -> tuple[StructureStage, ...]:
        """The stages the tables show: every stage of the search, then the refined one when there is one."""
        return self.stages if self.refined is None else (*self.stages, self.refined)

    @property
    def located(self) -> Connection | None:
        """The connection of the first accepted element (``None``: nothing was found)."""
        return self.steps[0].connection if self.steps else None

    @property
    def found(self) -> tuple[str, ...]:
        """The elements the search added, in order."""
        return tuple(name for s in self.steps for name in s.evidence.elements)

    @property
    def refused(self) -> tuple[ConnectionEvidence, ...]:
        """Fits refused for their sign (``rejected``: e.g. a negative damping that would feed energy in) that
        explained at least the rule's ``min_explained``, round by round: what would otherwise have competed."""
        rounds = [s.ranking for s in self.steps]
        if not self.steps or self.ranking is not self.steps[-1].ranking:
            rounds.append(self.ranking)
        floor = float(self.rule.min_explained)
        return tuple(
            e for ranking in rounds for e in ranking
            if e.status == "rejected" and e.explained is not None and e.explained >= floor
        )  # fmt: skip

    def to_dict(self) -> dict[str, Any]:
        """The object ``nlid discover --json`` prints for a structure record."""
        return {
            "schema": "nlid.discover-structure/1",
            "declared": list(self.declared),
            "n_dofs": self.n_dofs,
            "located": None if self.located is None else list(self.located),
            "found": list(self.found),
            "refused": [e.to_dict() for e in self.refused],
            "connections": [list(c) for c in self.connections],
            "candidates": list(self.candidates),
            "stages": [s.to_dict() for s in self.stages],
            "steps": [s.to_dict() for s in self.steps],
            "ranking": [e.to_dict() for e in self.ranking[:20]],
            "remaining_declared": self.remaining_declared.to_dict(),
            "remaining": self.remaining.to_dict(),
            "stop_reason": self.stop_reason,
            "rule": self.rule.to_dict(),
            "info": dict(self.info),
            "refined": None if self.refined is None else self.refined.to_dict(),
            "model": (self.refined or self.final).label,
        }

    def summary(self) -> str:
        """The table ``nlid discover`` prints: errors per DOF before and after, each step, what remains."""
        n = self.n_dofs
        lines = [
            f"structure discovery: {n} DOFs, declared: {', '.join(self.declared) or '(linear system only)'}",
            f"tested {len(self.candidates)} candidates on {len(self.connections)} connections; "
            f"choice on the selection record ({self.info.get('samples_estimation')} estimation + "
            f"{self.info.get('samples_holdout')} held-out samples, cross-fitted), errors on the test part "
            f"({self.info.get('samples_test')} samples)",
            *(f"data: {w}" for w in self.info.get("data_warnings") or ()),
        ]
        for step in self.steps:
            e = step.evidence
            coef = ", ".join(f"{k} = {v:.4g}" for k, v in e.coefficients.items())
            lines.append(
                f"step {step.number}: {e.effect} on connection {e.where}: {coef} "
                f"(explains {100 * (e.explained or 0):.3g} % of the held-out residual of its DOFs, "
                f"dBIC {e.delta_bic:.3g})"
            )
        if not self.steps:
            lines.append("no element added")
        for e in self.refused:
            coef = ", ".join(f"{k} = {v:.4g}" for k, v in e.coefficients.items())
            lines.append(f"refused: {e.effect} on connection {e.where} ({coef}): {e.reason}")
        lines.append(self.stop_reason)
        if self.refined is None and not self.info.get("derivatives_measured", True):
            noise = max(self.info.get("noise_percent") or [0.0])
            lines.append(
                "the coefficients above are equation-error fits of velocities and accelerations estimated from the "
                f"displacements (noise up to {noise:.2g} % of their std): the estimate's filter and that noise bias "
                "them, a Coulomb force most (benchmarks/accuracy_mdof_friction.py: 12-16 % low, with or without "
                "noise); refining (refine=True) refits the final elements by output error, which they do not bias"
            )
        if self.refined is not None:
            coef = ", ".join(f"{k} = {v:.6g}" for k, v in self.refined.model.coefficients.items())
            lines.append(f"{self.refined.label}, fitted on {self.info.get('refined_on')}: {coef}")
        if self.info.get("refine_failed"):
            lines.append(str(self.info["refine_failed"]))
        stages = self.reported
        header = "DOF".ljust(6) + "".join(f"{s.label[:24]:>28}" for s in stages)
        lines += ["", "epsilon on the test part (%)", header]
        for k in range(n):
            lines.append(f"z{k + 1}".ljust(6) + "".join(f"{s.eps_percent[k]:>28.4g}" for s in stages))
        lines += ["", "free-run error on the test part (% of std(z))", header]
        for k in range(n):
            lines.append(f"z{k + 1}".ljust(6) + "".join(f"{s.freerun_percent[k]:>28.4g}" for s in stages))
        chaotic = [s.label for s in stages if "chaotic" in s.freerun_note]
        if chaotic:
            lines.append(f"({', '.join(chaotic)}: the free run is chaotic, so its error says little about the model)")
        if all(s.predict_percent for s in stages):
            steps = ", ".join(dict.fromkeys(str(s.predict_steps) for s in stages))
            lines += ["", f"{steps}-step-ahead prediction error on the test part (% of std(z))", header]
            for k in range(n):
                lines.append(f"z{k + 1}".ljust(6) + "".join(f"{s.predict_percent[k]:>28.4g}" for s in stages))
        lines += ["", "What remains: " + self.remaining.describe()]
        return "\n".join(lines)

    def report(self) -> str:
        """A Markdown report (sections: Declared model, Steps, Errors, Ranking, What remains)."""
        n = self.n_dofs
        out = ["# nlid discover: structure", ""]
        out.append(f"- declared elements: {', '.join(f'`{d}`' for d in self.declared) or '(linear system only)'}")
        out.append(f"- connections tested: {', '.join(connection_name(c) for c in self.connections)}")
        out.append(f"- candidates: {', '.join(self.candidates)}")
        out.append(f"- rule: {self.rule.describe()}")
        out.append(f"- {self.stop_reason}")
        out += ["", "## Steps", ""]
        if not self.steps:
            out.append("No element was added.")
        for step in self.steps:
            e = step.evidence
            out.append(
                f"{step.number}. **{e.effect}** on connection **{e.where}**: "
                + ", ".join(f"`{k}` = {v:.6g}" for k, v in e.coefficients.items())
                + f" (explained {100 * (e.explained or 0):.3g} %, dBIC {e.delta_bic:.4g})"
            )
        if self.refused:
            out += ["", "Refused for their sign (a friction or damping law must dissipate energy):", ""]
            for e in self.refused:
                coef = ", ".join(f"`{k}` = {v:.6g}" for k, v in e.coefficients.items())
                out.append(f"- **{e.effect}** on connection **{e.where}**: {coef}: {e.reason}")
        if self.refined is not None:
            out += [
                "",
                f"## {self.refined.label.capitalize()}",
                "",
                f"Fitted on {self.info.get('refined_on')}: "
                + ", ".join(f"`{k}` = {v:.6g}" for k, v in self.refined.model.coefficients.items()),
            ]
        stages = self.reported
        out += ["", "## Errors on the test part", ""]
        out.append(
            "| DOF | "
            + " | ".join(f"eps % {s.label}" for s in stages)
            + " | "
            + " | ".join(f"free run % {s.label}" for s in stages)
            + " |"
        )
        out.append("|---" * (1 + 2 * len(stages)) + "|")
        for k in range(n):
            eps = " | ".join(f"{s.eps_percent[k]:.4g}" for s in stages)
            run = " | ".join(f"{s.freerun_percent[k]:.4g}" for s in stages)
            out.append(f"| z{k + 1} | {eps} | {run} |")
        out += ["", f"Free run: {self.final.freerun_note}", "", "## Ranking (last round, best 15)", ""]
        out.append("| effect | connection | elements | coefficients | explained % | all DOFs % | dBIC | status |")
        out.append("|---|---|---|---|---|---|---|---|")
        for e in [x for x in self.ranking if x.explained is not None][:15]:
            dbic = "" if e.delta_bic is None else f"{e.delta_bic:.4g}"
            coef = ", ".join(f"{v:.4g}" for v in e.coefficients.values())
            status = f"{e.status}: {e.reason}" if e.status == "rejected" else e.status
            out.append(
                f"| {e.effect} | {e.where} | {', '.join(e.elements)} | {coef} | {100 * e.explained:.3g} | "
                f"{100 * (e.explained_all or 0):.3g} | {dbic} | {status} |"
            )
        out += ["", "## What remains", "", f"Declared model: {self.remaining_declared.describe()}.", ""]
        out.append(f"Final model: {self.remaining.describe()}.")
        out.append("")
        return "\n".join(out)


def write_structure_report(result: StructureDiscoveryResult, out: str | Path) -> tuple[Path, Path]:
    """Write ``report.md`` and ``result.json`` into ``out`` (created); their paths."""
    import json

    from ..base.jsonable import to_jsonable

    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    md, js = folder / "report.md", folder / "result.json"
    md.write_text(result.report(), encoding="utf-8")
    js.write_text(json.dumps(to_jsonable(result.to_dict()), allow_nan=False, indent=1), encoding="utf-8")
    return md, js
