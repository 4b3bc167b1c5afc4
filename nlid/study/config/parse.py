"""Parsing a study: TOML text to a typed :class:`~nlid.study.config.StudyConfig`, nothing read from the disk.

Every table's keys, every value and every name is checked here (see
:mod:`nlid.study.config` for the file); each problem is one
:class:`~nlid.study.values.ConfigError` naming the file, the key and, where
one exists, a suggestion. The sources parse their own keys
(:meth:`~nlid.study.values.PresetSource.from_toml` ...).
"""

from __future__ import annotations

import inspect
import os
import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ...base.frozen import FrozenDict
from ...base.validate import CUTOFF, SEED
from ...contract.identifier import resolve_options
from ...contract.registry import Registry, default_registry
from ...errors import InputError, NlidError, brief
from ...identification.pipeline import as_model
from ...model.terms import Model
from ...scoring import rule_from_spec
from ..values import (
    MAX_MASS,
    MAX_TIMEOUT,
    SOURCES,
    ConfigError,
    DataSource,
    FileSource,
    KnownMass,
    Where,
    parse_holdout,
    parse_mass,
)
from .schema import (
    DEFAULT_TIMEOUT,
    MAIN_MODEL,
    MAX_FREQUENCY,
    MAX_POSITION,
    MAX_RUNS,
    DatasetConfig,
    ModelConfig,
    StudyConfig,
)
from .tomlio import tomllib

__all__ = ["parse_study"]

_STUDY_KEYS = ("name", "description", "seed", "repetitions", "timeout", "identifiers")
_TOP_KEYS = ("study", "options", "datasets", "posterior", "response")
#: Keys of the ``[response]`` table (:func:`nlid.study.metrics.response_metrics`).
_RESPONSE_KEYS = ("force", "band", "harmonics")
_DATASET_KEYS = (
    "name",
    "description",
    "preset",
    "dataset",
    "file",
    "part",
    "columns",
    "fs",
    "overrides",
    "noise",
    "channels",
    "terms",
    "without",
    "px_roots",
    "mass",
    "holdout",
    "freerun",
    "freerun_rule",
    "slices",
    "repetitions",
    "timeout",
    "models",
    "methods",
    "reference",
)
_MODEL_KEYS = ("terms", "without", "px_roots")
_METHOD_KEYS = ("terms", "without", "px_roots", "options")
_REFERENCE_KEYS = ("mass", "coefficients", "equilibria", "modal")
_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.+-]*$")


def _name(where: Where, value: Any) -> str:
    value = where.string(value)
    if not _NAME.match(value):
        raise where.error(f"{value!r} is not a usable name (letters, digits, _ . + -; no spaces or /)")
    return value


def _roots(where: Where, value: Any) -> tuple[float, float] | None:
    """Two positions ``[z-, z+]`` (a list from the file, or the tuple of a term set a method override inherits)."""
    if value is None:
        return None
    if not isinstance(value, (list, tuple)) or len(value) != 2:
        raise where.error(f"expected two numbers [z-, z+], got {brief(value)}")
    low, high = (
        float((where / f"[{i}]").number(x, minimum=-MAX_POSITION, maximum=MAX_POSITION)) for i, x in enumerate(value)
    )
    return low, high


def _check_model(where: Where, model: ModelConfig, source: Any = None) -> None:
    try:
        if getattr(source, "kind", "") == "preset" and hasattr(source.preset(), "elements"):  # several DOFs
            from ..structures import check_structure_terms

            check_structure_terms(model.terms, source.preset(), model.without)
            return
        as_model(model.terms, without=model.without, px_roots=model.px_roots)
    except NlidError as exc:
        raise where.error(str(exc)) from None


def parse_study(
    text: str,
    *,
    source: str = "<string>",
    base_dir: str | os.PathLike[str] = ".",
    default_name: str = "study",
    registry: Registry | None = None,
) -> StudyConfig:
    """Validate a study given as TOML text into typed values (no file or benchmark is read).

    See the module docstring for the keys; :func:`resolve_study` checks the
    files and benchmarks the study names.
    """
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(source, "", f"not valid TOML: {exc}") from None
    except RecursionError:
        raise ConfigError(source, "", "not usable TOML: arrays or tables nested too deeply") from None
    top = Where(source, "")
    top.keys(raw, _TOP_KEYS)
    at = Where(source, "study")
    study = at.table(raw.get("study", {}))
    at.keys(study, _STUDY_KEYS)
    name = _name(at / "name", study.get("name", default_name))
    seed = (at / "seed").check(SEED, study.get("seed", 0))
    reps = int((at / "repetitions").number(study.get("repetitions", 1), minimum=1, maximum=MAX_RUNS, integer=True))
    timeout = float((at / "timeout").number(study.get("timeout", DEFAULT_TIMEOUT), positive=True, maximum=MAX_TIMEOUT))
    registry = registry or default_registry()

    wanted = study.get("identifiers", "all")
    skipped: dict[str, str] = {}
    if wanted == "all":
        identifiers = tuple(registry.names())
        skipped = dict(registry.failures)
        if not identifiers:
            raise (at / "identifiers").error("no identifier is installed (see nlid methods)")
    elif isinstance(wanted, list) and wanted and all(isinstance(x, str) for x in wanted):
        for i, ident in enumerate(wanted):
            try:
                registry.get(ident)
            except NlidError as exc:
                raise (at / f"identifiers[{i}]").error(str(exc)) from None
        if len(set(wanted)) != len(wanted):
            raise (at / "identifiers").error("an identifier is listed twice")
        identifiers = tuple(wanted)
    else:
        raise (at / "identifiers").error(f'expected "all" or a list of names, got {brief(wanted)}')

    at_options = Where(source, "options")
    options_raw = at_options.table(raw.get("options", {}))
    options: dict[str, dict[str, Any]] = {}
    for ident, opts in options_raw.items():
        if ident not in identifiers:
            raise (at_options / ident).unknown(ident, identifiers, "identifier")
        opts = (at_options / ident).table(opts)
        _validate_options(at_options / ident, registry, ident, opts)
        options[ident] = opts

    if "datasets" not in raw:
        raise ConfigError(source, "datasets", "a study needs at least one [[datasets]] entry")
    if not isinstance(raw["datasets"], list) or not raw["datasets"]:
        raise ConfigError(source, "datasets", "expected one or more [[datasets]] tables")
    datasets = []
    for i, entry in enumerate(raw["datasets"]):
        where = Where(source, f"datasets[{i}]")
        datasets.append(_dataset(where, where.table(entry), Path(base_dir), reps, timeout))
        for ident, over in datasets[-1].methods.items():
            if ident not in identifiers:
                raise (where / f"methods.{ident}").unknown(ident, identifiers, "identifier")
            merged = {**options.get(ident, {}), **over.get("options", {})}
            _validate_options(where / f"methods.{ident}.options", registry, ident, merged)
    names = [d.name for d in datasets]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise ConfigError(source, "datasets", f"dataset name {dup[0]!r} is used twice; give each a unique name")

    posterior = _posterior(Where(source, "posterior"), raw["posterior"], datasets) if "posterior" in raw else None
    response = _response(Where(source, "response"), raw["response"]) if "response" in raw else None

    config = StudyConfig(
        name=name,
        description=(at / "description").string(study.get("description", "")),
        seed=seed,
        identifiers=identifiers,
        options=options,
        datasets=tuple(datasets),
        posterior=posterior,
        response=response,
        source=source,
        text=text,
        skipped_identifiers=skipped,
    )
    if config.run_count > MAX_RUNS:
        raise (at / "repetitions").error(
            f"the study plans {config.run_count} runs (datasets x term sets x identifiers x repetitions); "
            f"at most {MAX_RUNS} are allowed: split it into several studies"
        )
    return config


def _posterior(where: Where, value: Any, datasets: list[DatasetConfig]) -> dict[str, Any]:
    """The ``[posterior]`` table: the settings of :class:`nlid.bayes.PosteriorSampler` plus ``level``."""
    table = where.table(value)
    try:
        from ...bayes import PosteriorSampler
    except ImportError as exc:  # pragma: no cover - nlid.bayes is part of nlid
        raise where.error(f"needs the module nlid.bayes, which is not available ({exc})") from None
    known = tuple(n for n in inspect.signature(PosteriorSampler).parameters if n != "self") + ("level",)
    where.keys(table, known)
    where.finite(table)
    settings = dict(table)
    level = settings.pop("level", 0.9)
    (where / "level").number(level)
    if not 0 < level < 1:
        raise (where / "level").error(f"the credible level must lie between 0 and 1, got {level}")
    for key in ("walkers", "max_steps", "bias_pairs", "bias_iterations"):
        if key in settings:
            (where / key).number(settings[key], integer=True, minimum=1)
    if "seed" in settings:
        (where / "seed").check(SEED, settings["seed"])
    if "cutoff" in settings and settings["cutoff"] is not None:
        (where / "cutoff").check(CUTOFF, settings["cutoff"])
    try:
        PosteriorSampler(**settings)
    except (NlidError, TypeError, ValueError) as exc:
        text = str(exc)
        # name the key when the message is about one setting ("max_steps= must be ...")
        key = next((k for k in sorted(settings, key=len, reverse=True) if re.match(rf"{re.escape(k)}\b", text)), None)
        raise (where / key if key else where).error(text) from None
    _check_posterior_terms(where, settings, datasets)
    return table


def _response(where: Where, value: Any) -> dict[str, Any]:
    """The ``[response]`` table: force amplitudes (N), the band (Hz) and the harmonics of each run's response.

    Checked by the same rules as :func:`nlid.response.frequency_response`'s arguments.
    """
    from ...response.api import MAX_HARMONICS, check_band, check_forces

    table = where.table(value)
    where.keys(table, _RESPONSE_KEYS)
    for key in ("force", "band"):
        if key not in table:
            raise (where / key).error(f"the response needs {key} (e.g. force = [0.5, 1.0], band = [5.0, 30.0])")
    out: dict[str, Any] = {}
    try:
        out["force"] = list(check_forces(table["force"]))
    except InputError as exc:
        raise (where / "force").error(str(exc)) from None
    try:
        out["band"] = list(check_band(table["band"]))
    except InputError as exc:
        raise (where / "band").error(str(exc)) from None
    out["harmonics"] = int(
        (where / "harmonics").number(table.get("harmonics", 7), integer=True, minimum=1, maximum=MAX_HARMONICS)
    )
    return out


def _structure_unknowns(ds: DatasetConfig, main: Any) -> Any:
    from ...bayes.structure import StructureParameters
    from ...estimation.structure_regression import unknown_names
    from ...identification.structure_fit import as_elements

    elements = as_elements(main.terms, ds.source.preset().model().n_dofs, without=main.without)
    return StructureParameters(unknown_names(elements), elements)


def _structure_params(settings: Mapping[str, Any], unknowns: Any) -> list[str]:
    """The unknowns a structure dataset's posterior samples (its elements on connections, K, C, s)."""
    from ...bayes.structure import select_structure_params

    if settings.get("noise"):
        raise InputError(
            "noise sets the one-DOF correction's levels; a structure's are each displacement's noise floor "
            "(nlid.bayes.structure): leave it out for this dataset"
        )
    return [unknowns.names[i] for i in select_structure_params(unknowns, settings.get("params", "damping"))]


def _check_posterior_terms(where: Where, settings: Mapping[str, Any], datasets: list[DatasetConfig]) -> None:
    """The sampled terms and the terms given priors exist in each dataset's own term set.

    (Alternative term sets may lack them: their runs then report the posterior as a warning.)
    """
    from ...bayes import select_params
    from ...bayes.priors import parse_prior_assignments

    params = settings.get("params", "damping")
    parse_prior_assignments(settings.get("priors"), canonical=lambda name: name)  # the specs, before the names
    for ds in datasets:
        main = ds.models[0]
        if getattr(ds.source, "kind", "") == "preset" and hasattr(ds.source.preset(), "elements"):
            try:
                unknowns = _structure_unknowns(ds, main)
                names = _structure_params(settings, unknowns)
                priors = parse_prior_assignments(settings.get("priors"), canonical=unknowns.canonical)
            except NlidError as exc:
                raise where.error(f"dataset {ds.name!r}: {exc}") from None
        else:
            model = as_model(main.terms, without=main.without, px_roots=main.px_roots)
            try:
                names = [model.names[i] for i in select_params(model, params)]
            except NlidError as exc:
                raise (where / "params").error(f"dataset {ds.name!r}: {exc}") from None
            priors = parse_prior_assignments(settings.get("priors"))
        stray = [n for n in priors if n not in names]
        if stray:
            raise (where / "priors").error(
                f"a prior is given for {', '.join(stray)}, which dataset {ds.name!r} does not sample "
                f"(it samples {', '.join(names)})"
            )


def _validate_options(where: Where, registry: Registry, ident: str, opts: Mapping[str, Any]) -> None:
    cls = registry.get(ident)
    try:
        resolve_options(tuple(getattr(cls, "options", ())), opts)
        registry.create(ident, opts)
    except NlidError as exc:
        raise where.error(str(exc)) from None


def _dataset(where: Where, entry: dict[str, Any], base: Path, reps: int, timeout: float) -> DatasetConfig:
    where.keys(entry, _DATASET_KEYS)
    kinds = [k for k in ("preset", "dataset", "file") if k in entry]
    if len(kinds) != 1:
        raise where.error("give exactly one of preset, dataset or file")
    kind = kinds[0]
    value = (where / kind).string(entry[kind])
    for k in ("overrides", "noise", "channels") if kind != "preset" else ():
        if k in entry:
            raise (where / k).error(f"only applies to preset datasets, not {kind}")
    for k in ("columns", "fs") if kind != "file" else ():
        if k in entry:
            raise (where / k).error("only applies to file datasets")
    if "part" in entry and kind != "dataset":
        raise (where / "part").error("only applies to nlid.data.datasets entries (dataset = ...)")
    source: DataSource = SOURCES[kind].from_toml(entry, where, base)

    name = _name(where / "name", entry.get("name", value if kind != "file" else Path(value).stem))

    terms = (where / "terms").string(entry.get("terms", source.default_terms))
    main = ModelConfig(
        MAIN_MODEL,
        terms,
        (where / "without").string(entry.get("without", "")),
        _roots(where / "px_roots", entry.get("px_roots")),
    )
    _check_model(where / "terms", main, source)
    models = [main]
    at_models = where / "models"
    for mname, spec in at_models.table(entry.get("models", {})).items():
        mw = at_models / mname
        _name(mw, mname)
        if mname == MAIN_MODEL:
            raise mw.error(f"{MAIN_MODEL!r} is the dataset's own terms; choose another name")
        if isinstance(spec, str):
            spec = {"terms": spec}
        spec = mw.table(spec)
        mw.keys(spec, _MODEL_KEYS)
        model = ModelConfig(
            mname,
            (mw / "terms").string(spec.get("terms", "")),
            (mw / "without").string(spec.get("without", "")),
            _roots(mw / "px_roots", spec.get("px_roots")),
        )
        _check_model(mw / "terms", model, source)
        models.append(model)

    methods: dict[str, FrozenDict] = {}
    at_methods = where / "methods"
    for ident, spec in at_methods.table(entry.get("methods", {})).items():
        mw = at_methods / ident
        spec = mw.table(spec)
        mw.keys(spec, _METHOD_KEYS)
        if "options" in spec:
            spec["options"] = FrozenDict((mw / "options").table(spec["options"]))
        for m in models:
            _check_model(
                mw / "terms",
                ModelConfig(
                    m.name,
                    (mw / "terms").string(spec.get("terms", m.terms)),
                    (mw / "without").string(spec.get("without", m.without)),
                    _roots(mw / "px_roots", spec.get("px_roots", m.px_roots)),
                ),
                source,
            )
        methods[ident] = FrozenDict(spec)

    mass = parse_mass(entry.get("mass", "known" if kind == "preset" else "estimate"), where / "mass")
    reference = _reference(where / "reference", entry["reference"]) if "reference" in entry else None
    if isinstance(mass, KnownMass) and isinstance(source, FileSource) and not (reference and "mass" in reference):
        raise (where / "mass").error('the mass is not known for this data: give it in kg or "estimate"')
    holdout = parse_holdout(
        entry.get("holdout", "independent" if kind == "preset" else "none"), kind, where / "holdout"
    )

    freerun = entry.get("freerun", True)
    if not isinstance(freerun, bool):
        raise (where / "freerun").error(f"expected true or false, got {brief(freerun)}")
    freerun_rule = (where / "freerun_rule").string(entry.get("freerun_rule", "")).strip()
    if freerun_rule:
        try:
            rule_from_spec(freerun_rule)
        except InputError as exc:
            raise (where / "freerun_rule").error(str(exc)) from None
    slices = entry.get("slices", [])
    if not isinstance(slices, list):
        raise (where / "slices").error(f"expected a list of positions in m, got {brief(slices)}")
    slices = tuple(
        float((where / f"slices[{i}]").number(z, minimum=-MAX_POSITION, maximum=MAX_POSITION))
        for i, z in enumerate(slices)
    )
    d_reps = int(
        (where / "repetitions").number(entry.get("repetitions", reps), minimum=1, maximum=MAX_RUNS, integer=True)
    )
    if kind != "preset":
        d_reps = 1  # measured data: the same record every time
    return DatasetConfig(
        name=name,
        source=source,
        description=(where / "description").string(entry.get("description", "")),
        models=tuple(models),
        mass=mass,
        holdout=holdout,
        freerun=freerun,
        slices=slices,
        repetitions=d_reps,
        timeout=float((where / "timeout").number(entry.get("timeout", timeout), positive=True, maximum=MAX_TIMEOUT)),
        methods=FrozenDict(methods),
        reference=reference,
        freerun_rule=freerun_rule,
    )


def _term_name(where: Where, text: str) -> str:
    """The canonical name of the one term ``text`` (``"|v|*v"`` -> ``"v*|v|"``; ``v``, ``z`` and ``1`` too)."""
    try:
        names = Model.from_spec(text, defaults=False).names
    except NlidError as exc:
        raise where.error(str(exc)) from None
    if len(names) != 1:
        raise where.error(f"{text!r}: give one term per key")
    return names[0]


def _reference(where: Where, value: Any) -> dict[str, Any]:
    reference = where.table(value)
    where.keys(reference, _REFERENCE_KEYS)
    if "coefficients" in reference:
        coeffs = (where / "coefficients").table(reference["coefficients"])
        for term, x in coeffs.items():
            (where / f"coefficients.{term}").number(x)
        reference["coefficients"] = {_term_name(where / "coefficients", t): float(x) for t, x in coeffs.items()}
    if "mass" in reference:
        reference["mass"] = float((where / "mass").number(reference["mass"], positive=True, maximum=MAX_MASS))
    if "equilibria" in reference:
        eq = reference["equilibria"]
        if not isinstance(eq, list):
            raise (where / "equilibria").error("expected a list of positions (m)")
        reference["equilibria"] = sorted(
            float((where / f"equilibria[{i}]").number(x, minimum=-MAX_POSITION, maximum=MAX_POSITION))
            for i, x in enumerate(eq)
        )
    if "modal" in reference:
        modal = reference["modal"]
        if not isinstance(modal, list) or not all(isinstance(m, Mapping) for m in modal):
            raise (where / "modal").error("expected a list of {fn_hz, zeta} tables")
        for j, m in enumerate(modal):
            mw = where / f"modal[{j}]"
            mw.keys(m, ("fn_hz", "zeta"))
            missing = [k for k in ("fn_hz", "zeta") if k not in m]
            if missing:
                raise mw.error(f"needs {' and '.join(missing)} (a table {{ fn_hz = ..., zeta = ... }})")
            (mw / "fn_hz").number(m["fn_hz"], positive=True, maximum=MAX_FREQUENCY)
            (mw / "zeta").number(m["zeta"], positive=True)
    return reference
