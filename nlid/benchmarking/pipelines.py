"""What ``nlid bench`` runs on a benchmark: identifiers by name, ``discover``, ``discover --refine``, the pysindy peer.

Every pipeline is given the *estimation part only* (:func:`fit_pipelines` has no other record):
the test sets take no part in any decision. ``discover`` selects the structure with its
hold-out taken from the end of the estimation part (the benchmark file's ``holdout``; no
``validation=`` record is given), then the final model is **refitted on the whole estimation
part** with the same identifier; ``discover --refine`` refines that structure with the refining
identifier (``oe``) on the whole estimation part, started from the same identifier (``discover-refine``). The pysindy
peer chooses its hyper-parameters on the end of the estimation part and refits on all of it.

Pipeline names: any installed identifier (``rfs``, ``sindy``, ``oe``...), ``discover``,
``discover-refine`` (``discover`` then its refinement; spelled ``discover --refine`` too), and
``pysindy`` (the peer).
"""

from __future__ import annotations

import re
import time
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any

from ..errors import InputError
from ..record import Record
from ..validate import did_you_mean
from .protocol import PipelineSettings

__all__ = ["PipelineSpec", "Fitted", "parse_pipelines", "fit_pipelines", "PEER", "DISCOVER", "REFINE"]

DISCOVER = "discover"
REFINE = "discover-refine"
PEER = "pysindy"
_ALIASES = {"peer": PEER}
_OPTION = re.compile(r"\s+-{1,2}")  # "discover --refine" -> "discover-refine"


@dataclass(frozen=True)
class PipelineSpec:
    """One pipeline: its name and kind (``"identify"``, ``"discover"``, ``"peer"``)."""

    name: str
    kind: str
    method: str | None = None
    refine: bool = False

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-able values."""
        return {"name": self.name, "kind": self.kind, "method": self.method, "refine": self.refine}

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> PipelineSpec:
        """Inverse of :meth:`to_dict`."""
        return cls(data["name"], data["kind"], data.get("method"), bool(data.get("refine", False)))


def parse_pipelines(names: str | Iterable[str], identifiers: Sequence[str] | None = None) -> list[PipelineSpec]:
    """Pipeline specs from names (``"rfs, discover, discover-refine, pysindy"``).

    Parameters
    ----------
    names
        Comma-separated text or a list of names.
    identifiers
        Installed identifiers (default: the registry's); an identifier name must be one.

    Raises
    ------
    InputError
        An unknown name (with the closest known one), or no pipeline.
    """
    items = [n.strip() for n in (names.split(",") if isinstance(names, str) else names)]
    items = [n for n in items if n]
    if not items:
        raise InputError("pipelines= names no pipeline; e.g. 'rfs, discover, discover-refine, pysindy'")
    if identifiers is None:
        from ..registry import load_registry

        identifiers = load_registry().names()
    out: list[PipelineSpec] = []
    for raw in items:
        name = _ALIASES.get(_OPTION.sub("-", raw), _OPTION.sub("-", raw))
        if name == DISCOVER:
            spec = PipelineSpec(DISCOVER, "discover")
        elif name == REFINE:
            spec = PipelineSpec(REFINE, "discover", refine=True)
        elif name == PEER:
            spec = PipelineSpec(PEER, "peer")
        elif name in identifiers:
            spec = PipelineSpec(name, "identify", method=name)
        else:
            known = [*identifiers, DISCOVER, REFINE, PEER]
            raise InputError(f"unknown pipeline {raw!r}{did_you_mean(raw, known)}; choose from {', '.join(known)}")
        if spec not in out:
            out.append(spec)
    return out


@dataclass
class Fitted:
    """One fitted model of a pipeline, and the choices it made (all on the estimation part).

    Attributes
    ----------
    pipeline
        The pipeline's name.
    kind
        ``"nlid"`` or ``"peer"``.
    method
        What fitted it, in words (``"rfs"``, ``"discover (rfs), refit on the estimation part"``...).
    model
        The :class:`~nlid.identified.IdentifiedModel` or the :class:`~nlid.benchmarking.peer.PeerModel`.
    parameters
        Fitted parameters: coefficients, the mass when estimated, shape parameters chosen from data.
    seconds
        Wall time of the pipeline (its share, when two pipelines share a discovery).
    choices
        Every decision (terms, steps, coefficients, hyper-parameters): what must not depend on the test sets.
    details
        For the report (discovery steps and their hold-out scores, equations).
    """

    pipeline: str
    kind: str
    method: str
    model: Any
    parameters: int
    seconds: float
    choices: dict[str, Any] = field(default_factory=dict)
    details: dict[str, Any] = field(default_factory=dict)


def _identified_choices(fit: Any) -> dict[str, Any]:
    return {
        "terms": list(fit.terms),
        "coefficients": {k: float(v) for k, v in fit.coefficients.items()},
        "mass": None if fit.mass is None else float(fit.mass),
        "mass_estimated": bool(fit.mass_estimated),
    }


def _fitted_shapes(fit: Any) -> int:
    shapes = (fit.diagnostics or {}).get("shapes") or {}
    return sum(len((entry or {}).get("values", {})) for entry in shapes.values())


def _parameters(fit: Any, chosen_shapes: int = 0) -> int:
    """Coefficients, the mass when estimated, and shape parameters chosen from the data."""
    return len(fit.terms) + int(bool(fit.mass_estimated)) + max(_fitted_shapes(fit), chosen_shapes)


def _identify(record: Record, settings: PipelineSettings, method: str) -> Fitted:
    from ..pipeline import identify

    start = time.perf_counter()
    fit = identify(
        record,
        settings.terms,
        method,
        mass=settings.mass,
        without=settings.without,
        options=dict(settings.options.get(method, {})),
    )
    seconds = time.perf_counter() - start
    return Fitted(method, "nlid", method, fit, _parameters(fit), seconds, _identified_choices(fit))


def _stage(stage: Any, label: str, terms: Sequence[str]) -> dict[str, Any]:
    s = stage.scores
    return {
        "model": label,
        "terms": list(terms),
        "eps_holdout": s.eps_holdout,
        "force_residual_holdout": s.force_residual_holdout,
        "sim_rms_holdout": stage.sim_rms_holdout,
    }


def _discover(record: Record, settings: PipelineSettings, specs: Sequence[PipelineSpec]) -> list[Fitted]:
    from ..discovery import discover
    from ..methods import choose_refiner
    from ..pipeline import identify

    start = time.perf_counter()
    result = discover(record, settings.declared, mass=settings.mass, holdout=settings.holdout, views=False)
    method = result.method
    final = result.final
    declared = set(result.declared)
    chosen_shapes = sum(len(t.shapes) for t in final.model.terms if t.name not in declared)
    refit = identify(record, final.model, method, mass=final.given_mass)  # the whole estimation part
    discover_seconds = time.perf_counter() - start
    stages = [_stage(result.states[0], "declared", result.states[0].identified.terms)]
    stages += [_stage(step.after, f"+ {step.effect}", step.terms) for step in result.steps]
    details = {
        "declared": list(result.declared),
        "method": method,
        "steps": stages,
        "stop_reason": result.stop_reason,
        "holdout": result.info.get("holdout", ""),
        "freerun_rule_holdout": result.info.get("freerun_rule", ""),
        "estimation_samples": record.n,
        "selection_samples": int(round(record.n * (1 - settings.holdout))),
        "final_terms": list(final.identified.terms),
    }
    choices = {
        "method": method,
        "steps": [{"effect": step.effect, "terms": list(step.terms)} for step in result.steps],
        "selected": _identified_choices(final.identified),
        "refit": _identified_choices(refit),
    }
    out = []
    for spec in specs:
        if not spec.refine:
            out.append(
                Fitted(
                    DISCOVER,
                    "nlid",
                    f"discover ({method}), refit on the estimation part",
                    refit,
                    _parameters(refit, chosen_shapes),
                    discover_seconds,
                    choices,
                    details,
                )
            )
            continue
        refiner = choose_refiner()
        t0 = time.perf_counter()
        options = {**dict(settings.options.get(refiner, {})), "init": method}
        refined = identify(record, final.model, refiner, mass=final.given_mass, options=options)
        seconds = discover_seconds + time.perf_counter() - t0
        out.append(
            Fitted(
                REFINE,
                "nlid",
                f"discover ({method}) + {refiner} on the estimation part",
                refined,
                _parameters(refined, chosen_shapes),
                seconds,
                {**choices, "refined": _identified_choices(refined), "refiner": refiner},
                details,
            )
        )
    return out


def _peer(record: Record, settings: PipelineSettings) -> Fitted:
    from .peer import fit_peer

    peer = fit_peer(record, settings.peer, holdout=settings.holdout)
    choices = {
        "differentiation": peer.differentiation,
        "threshold": peer.threshold,
        "coefficients": peer.coefficients.tolist(),
        "features": peer.names,
    }
    details = {"equations": peer.equations, "selection": peer.selection}
    method = f"pysindy {_pysindy_version()} SINDy ({peer.differentiation}, STLSQ threshold {peer.threshold:g})"
    return Fitted(PEER, "peer", method, peer, peer.parameters, peer.seconds, choices, details)


def _pysindy_version() -> str:
    try:
        from importlib.metadata import version

        return version("pysindy")
    except Exception:  # noqa: BLE001 - a version string is cosmetic
        return ""


def fit_pipelines(record: Record, settings: PipelineSettings, specs: Sequence[PipelineSpec]) -> list[Fitted]:
    """Fit every pipeline on the estimation record (``discover`` and ``discover --refine`` share one discovery).

    Returns
    -------
    list of Fitted
        In the order of ``specs``.
    """
    discovered: dict[str, Fitted] = {}
    wanted = [s for s in specs if s.kind == "discover"]
    if wanted:
        for fitted in _discover(record, settings, wanted):
            discovered[fitted.pipeline] = fitted
    out = []
    for spec in specs:
        if spec.kind == "identify":
            out.append(_identify(record, settings, spec.method or spec.name))
        elif spec.kind == "discover":
            out.append(discovered[spec.name])
        elif spec.kind == "peer":
            out.append(_peer(record, settings))
        else:  # pragma: no cover - parse_pipelines makes only these
            raise InputError(f"unknown pipeline kind {spec.kind!r}")
    return out
