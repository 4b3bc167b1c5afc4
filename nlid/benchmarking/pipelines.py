"""What ``nlid bench`` runs on a benchmark: identifiers by name, ``linear``, ``discover``, the peers, the true model.

Every pipeline is given the *estimation part only* (:func:`fit_pipelines` has no other record):
the test sets take no part in any decision. ``discover`` selects the structure with its
hold-out taken from the end of the estimation part (the benchmark file's ``holdout``; no
``validation=`` record is given) and the cross-fitted prediction on blocks of the estimation
part, then the final model is **refitted on the whole estimation part** with the same
identifier; ``discover --refine`` runs its own search, whose candidates are judged by the
refining identifier's (``oe``) fits, and refines the structure it chose on the whole estimation
part, started from the same identifier (``discover-refine``). The peers
choose their hyper-parameters on the end of the estimation part and refit on all of it.

Pipeline names (:data:`PEERS` are other tools, each run as a competent user of it would):

* any installed identifier (``rfs``, ``sindy``, ``oe``...): the benchmark's model (``terms``);
* ``linear``: the default identifier on the linear terms of the declared model (``1, z, v``);
* ``discover``, ``discover-refine`` (``discover`` then its refinement; spelled ``discover --refine`` too);
* ``pysindy`` (:mod:`nlid.benchmarking.peer`), ``sysidentpy`` (polynomial NARX, FROLS) and
  ``linear-ss`` (a linear state space by output error) (:mod:`nlid.benchmarking.blackbox`);
* ``truth``: the benchmark's own model where its file declares it (``[truth]``), fitted to nothing.

Every :class:`Fitted` carries its :class:`~nlid.benchmarking.prior.Prior`, derived here from what the
pipeline was given.
"""

from __future__ import annotations

import re
import time
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

from ..base.validate import did_you_mean
from ..data.record import Record
from ..errors import DataError, InputError
from .declarations import PipelineSettings, Protocol
from .fitted import Fitted
from .prior import Prior, given_shapes

__all__ = [
    "PipelineSpec",
    "parse_pipelines",
    "fit_pipelines",
    "PEER",
    "PEERS",
    "DISCOVER",
    "REFINE",
    "LINEAR",
    "TRUTH",
    "linear_terms",
]

DISCOVER = "discover"
REFINE = "discover-refine"
PEER = "pysindy"
LINEAR = "linear"
TRUTH = "truth"
#: The peers (other tools) by pipeline name.
PEERS = (PEER, "sysidentpy", "linear-ss")
_ALIASES = {"peer": PEER}
_OPTION = re.compile(r"\s+-{1,2}")  # "discover --refine" -> "discover-refine"


@dataclass(frozen=True)
class PipelineSpec:
    """One pipeline: its name and kind (``"identify"``, ``"linear"``, ``"discover"``, ``"peer"``, ``"truth"``)."""

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
        from ..contract.registry import load_registry

        identifiers = load_registry().names()
    out: list[PipelineSpec] = []
    for raw in items:
        name = _ALIASES.get(_OPTION.sub("-", raw), _OPTION.sub("-", raw))
        if name == DISCOVER:
            spec = PipelineSpec(DISCOVER, "discover")
        elif name == REFINE:
            spec = PipelineSpec(REFINE, "discover", refine=True)
        elif name in PEERS:
            spec = PipelineSpec(name, "peer")
        elif name == LINEAR:
            spec = PipelineSpec(LINEAR, "linear")
        elif name == TRUTH:
            spec = PipelineSpec(TRUTH, "truth")
        elif name in identifiers:
            spec = PipelineSpec(name, "identify", method=name)
        else:
            known = [*identifiers, LINEAR, DISCOVER, REFINE, *PEERS, TRUTH]
            raise InputError(f"unknown pipeline {raw!r}{did_you_mean(raw, known)}; choose from {', '.join(known)}")
        if spec not in out:
            out.append(spec)
    return out


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


def _mass_prior(settings: PipelineSettings) -> str:
    return "estimated" if settings.mass is None else "given"


def _identify(record: Record, settings: PipelineSettings, method: str) -> Fitted:
    from ..identification.pipeline import identify

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
    shapes = given_shapes(fit.terms)
    prior = Prior(
        _mass_prior(settings),
        "declared",
        "given" if shapes and not _fitted_shapes(fit) else ("fitted" if _fitted_shapes(fit) else "none"),
        f"shape given: {', '.join(shapes)}" if shapes else "",
    )
    return Fitted(method, "nlid", method, fit, _parameters(fit), seconds, _identified_choices(fit), prior=prior)


def linear_terms(settings: PipelineSettings) -> list[str]:
    """The linear terms (``1``, ``z``, ``v``) of the declared model: what the ``linear`` pipeline fits."""
    from ..model.terms import Model

    terms = [t.name for t in Model.from_spec(settings.declared, defaults=False).terms if t.name in ("1", "z", "v")]
    if not terms:
        raise InputError(f"the declared model {settings.declared!r} has no linear term (1, z, v) to fit")
    return terms


def _linear(record: Record, settings: PipelineSettings) -> Fitted:
    from ..contract.methods import choose_method
    from ..identification.pipeline import identify
    from ..model.terms import Model

    method, _ = choose_method(None)
    terms = linear_terms(settings)
    start = time.perf_counter()
    fit = identify(
        record,
        Model.from_spec(terms, defaults=False),
        method,
        mass=settings.mass,
        options=dict(settings.options.get(method, {})),
    )
    seconds = time.perf_counter() - start
    prior = Prior(_mass_prior(settings), "declared", "none", "")
    return Fitted(
        LINEAR,
        "nlid",
        f"{method} on {', '.join(terms)}",
        fit,
        _parameters(fit),
        seconds,
        _identified_choices(fit),
        prior=prior,
    )


def _stage(stage: Any, label: str, terms: Sequence[str]) -> dict[str, Any]:
    s = stage.scores
    return {
        "model": label,
        "terms": list(terms),
        "eps_holdout": s.eps_holdout,
        "force_residual_holdout": s.force_residual_holdout,
        "sim_rms_holdout": stage.sim_rms_holdout,
    }


def _discover(record: Record, settings: PipelineSettings, spec: PipelineSpec) -> Fitted:
    """One discovery, judged by the fits the pipeline delivers (``discover --refine``: the refiner's).

    ``discover`` and ``discover --refine`` run their own searches: a candidate is accepted when it improves
    the cross-fitted prediction of the model the row will report (an equation-error refit, or ``oe``).
    """
    from ..contract.methods import choose_refiner
    from ..discovery import discover
    from ..identification.pipeline import identify

    start = time.perf_counter()
    result = discover(
        record,
        settings.declared,
        mass=settings.mass,
        holdout=settings.holdout,
        views=False,
        refine=spec.refine,
        freerun_rule=settings.rule,
    )
    method = result.method
    final = result.final
    declared = set(result.declared)
    chosen_shapes = sum(len(t.shapes) for t in final.model.terms if t.name not in declared)
    chosen_shapes += final.path.parameters
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
        "input_path": final.path.describe(),
        "prediction_rule": result.info.get("prediction_rule"),
    }
    choices = {
        "method": method,
        "steps": [{"effect": step.effect, "terms": list(step.terms)} for step in result.steps],
        "selected": _identified_choices(final.identified),
    }
    shapes = given_shapes(settings.declared)
    prior = Prior(
        _mass_prior(settings),
        "discovered",
        "fitted" if chosen_shapes else ("given" if shapes else "none"),
        f"started from {', '.join(result.declared)}; added: {', '.join(s.effect for s in result.steps) or 'nothing'}",
    )
    if not spec.refine:
        # the whole estimation part, with the input path the search found
        refit = identify(record, final.model, method, mass=final.given_mass, input_path=final.path)
        seconds = time.perf_counter() - start
        how = f"discover ({method}), refit on the estimation part"
        return Fitted(DISCOVER, "nlid", how, refit, _parameters(refit, chosen_shapes), seconds,
                      {**choices, "refit": _identified_choices(refit)}, details, prior)  # fmt: skip
    refiner = choose_refiner()
    given = dict(settings.options.get(refiner, {}))
    if result.refined is not None and not given:
        # the search refined its final model on this same record, with the same refiner, start and input path
        # (``refine_stage``: the whole record it was given): that fit is the row's, not a second identical one
        refined = result.refined.identified
    else:
        options = {**given, "init": method}
        refined = identify(record, final.model, refiner, mass=final.given_mass, options=options, input_path=final.path)
    seconds = time.perf_counter() - start
    how = f"discover ({method}, judged by {refiner}'s fits) + {refiner} on the estimation part"
    choices = {**choices, "refined": _identified_choices(refined), "refiner": refiner}
    return Fitted(REFINE, "nlid", how, refined, _parameters(refined, chosen_shapes), seconds, choices, details, prior)


def _peer(record: Record, protocol: Protocol, name: str) -> Fitted:
    """A peer fitted on the estimation record; its hyper-parameters chosen on the record's end."""
    from .peer import selection_rule

    settings = protocol.pipelines
    rule = selection_rule([t.rule for t in protocol.tests])
    if name == PEER:
        from .peer import fit_peer

        peer = fit_peer(record, settings.peer, holdout=settings.holdout, rule=rule)
        choices = {
            "differentiation": peer.differentiation,
            "threshold": peer.threshold,
            "coefficients": peer.coefficients.tolist(),
            "features": peer.names,
        }
        library = f"polynomial degree {settings.peer.degree} in z, v; u" + (
            ", sign(v)" if settings.peer.friction else ""
        )
        method = (
            f"pysindy {_version('pysindy')} SINDy ({peer.differentiation}, normalised columns, STLSQ threshold "
            f"{peer.selection.get('threshold', 0):g} of the largest coefficient)"
        )
        prior = Prior("none", "library", "none", f"library: {library}")
    elif name == "linear-ss":
        from .blackbox import fit_linear

        peer = fit_linear(record, holdout=settings.holdout, rule=rule)
        choices = {"order": peer.order, "b": peer.b.tolist(), "f": peer.f.tolist(), "u_mean": peer.u_mean}
        method = f"linear state space, order {peer.order} (output error)"
        prior = Prior("none", "black box", "none", "order chosen on the estimation part")
    else:
        from .blackbox import fit_narx

        peer = fit_narx(record, holdout=settings.holdout, rule=rule)
        choices = {k: v for k, v in peer.selection.items() if k in ("degree", "lags", "terms")}
        choices["regressors"] = [str(r) for r in getattr(peer.model, "final_model", [])]
        choices["theta"] = [float(x) for x in getattr(peer.model, "theta", []).ravel()]
        method = f"sysidentpy {_version('sysidentpy')} FROLS, polynomial NARX degree {peer.degree}, lags {peer.lag}"
        prior = Prior("none", "library", "none", "degree, lags and terms chosen on the estimation part")
    details = {"equations": peer.equations, "selection": peer.selection}
    return Fitted(name, "peer", method, peer, peer.parameters, peer.seconds, choices, details, prior)


def _version(package: str) -> str:
    try:
        from importlib.metadata import version

        return version(package)
    except Exception:  # noqa: BLE001 - a version string is cosmetic
        return ""


def fit_pipelines(record: Record, protocol: Protocol, specs: Sequence[PipelineSpec]) -> list[Fitted | str]:
    """Fit every pipeline on the estimation record (``discover`` and ``discover --refine`` each run their own search).

    Returns
    -------
    list
        In the order of ``specs``: a :class:`Fitted`, or the reason in words when the pipeline
        cannot run here (an optional peer not installed, no truth declared).
    """
    settings = protocol.pipelines
    out: list[Fitted | str] = []
    for spec in specs:
        if spec.kind == "identify":
            out.append(_identify(record, settings, spec.method or spec.name))
        elif spec.kind == "linear":
            out.append(_linear(record, settings))
        elif spec.kind == "discover":
            out.append(_discover(record, settings, spec))
        elif spec.kind == "peer":
            try:
                out.append(_peer(record, protocol, spec.name))
            except DataError as exc:  # an optional peer that is not installed
                out.append(str(exc))
        elif spec.kind == "truth":
            from .truth import true_fitted

            truth = true_fitted(protocol)
            out.append(truth[0] if truth else f"benchmark {protocol.name} declares no true model")
        else:  # pragma: no cover - parse_pipelines makes only these
            raise InputError(f"unknown pipeline kind {spec.kind!r}")
    return out
