"""Study configuration: a TOML file read, validated and resolved before anything runs.

A study is datasets x models x identifiers x repetitions. The file::

    [study]
    name = "paper-numerical"       # default: the file's stem
    description = "..."
    seed = 2024                    # study seed; every run's seed derives from it and the run id
    repetitions = 5                # records per simulated dataset (measured datasets: 1)
    timeout = 600                  # seconds per run; a run over it is stopped and recorded
    identifiers = "all"            # every installed identifier, or a list of names

    [options.rfs]                  # options of one identifier (checked against its declaration)
    cutoff = 80

    [[datasets]]
    name = "numerical"
    preset = "paper-numerical"     # or: dataset = "emps" (nlid.datasets), or: file = "x.csv"
    overrides = { duration = 30 }  # preset fields / coefficients
    noise = { z = 0.02 }           # fraction of each channel's standard deviation (or one number)
    channels = ["z"]               # response channels recorded (z always)
    terms = "z^3, z^2, v*|v|"      # besides 1, z, v (default: the preset's terms)
    without = ""                   # default terms to remove
    mass = "known"                 # "known" (truth / reference), "estimate", or kg
    holdout = "independent"        # held-out data: "independent" (presets: another record),
                                   # a fraction at the end (0.25), a part name ("arrow"), or "none"
    freerun = true                 # free-run NRMSE on the held-out data (sensitivity-tested)
    freerun_rule = "window:50"     # its transient rule: first-sample, window:N, periodic, periodic:P
                                   # (default: the held-out record's own, nlid.scoring.default_rule)
    slices = [-0.02, 0.0, 0.02]    # positions (m) of damping-force slices (paper Fig. 21 b-d)

    [datasets.models]              # alternative term sets identified on the same data
    stiffness-only = { terms = "z^3, z^2", without = "v" }

    [datasets.methods.rfs]         # per-identifier overrides: terms, without, options
    options = { cutoff = 50 }

    [datasets.reference]           # reference values for measured data
    mass = 95.1
    coefficients = { v = 203.5, "sign(v)" = 20.4 }
    equilibria = [-0.030, 0.024]   # stable equilibria (m)
    modal = [{ fn_hz = 11.75, zeta = 0.109 }, { fn_hz = 8.77, zeta = 0.146 }]

    [posterior]                    # optional: nlid.bayes.study_metrics(..., **options)
    draws = 2000

Everything is checked before any run starts: :func:`parse_study` validates
the text (unknown keys in every table, the ``[posterior]`` table's keys and
values, numbers that are not finite, negative or absurd, terms, presets and
their overrides, identifiers and their options, and the number of runs, at
most :data:`MAX_RUNS`) into typed values (:mod:`nlid.study.values`);
:func:`resolve_study` is the one step that touches the disk (files exist and
read, benchmark parts load, a "known" mass is known). :func:`load_study`
does both. Each problem is one :class:`ConfigError` naming the file, the key
and, where one exists, a suggestion.
"""

from __future__ import annotations

import inspect
import math
import os
import re
import sys
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from .._frozen import FrozenDict
from ..errors import InputError, NlidError, brief
from ..interface import resolve_options
from ..io import parse_columns
from ..pipeline import as_model
from ..presets import RESPONSE_CHANNELS
from ..registry import Registry, default_registry
from ..scoring import rule_from_spec
from ..validate import CUTOFF, NOISE_FRACTION, SEED, check_noise, did_you_mean
from .values import (
    MAX_MASS,
    MAX_TIMEOUT,
    BenchmarkSource,
    ConfigError,
    DataSource,
    FileSource,
    Holdout,
    KnownMass,
    Mass,
    NoHoldout,
    PresetSource,
    Where,
    parse_holdout,
    parse_mass,
)

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - exercised on 3.10 only
    import tomli as tomllib

__all__ = [
    "ConfigError",
    "DatasetConfig",
    "ModelConfig",
    "StudyConfig",
    "load_study",
    "parse_study",
    "resolve_study",
    "builtin_studies",
    "resolve_study_path",
    "MAX_RUNS",
    "MAX_POSITION",
]

DEFAULT_TIMEOUT = 600.0
MAIN_MODEL = "main"
#: Most runs a study may plan (datasets x term sets x identifiers x repetitions).
MAX_RUNS = 20_000
#: Largest position (m) a study may name (slices, equilibria, px roots): a kilometre.
MAX_POSITION = 1e3
#: Highest natural frequency (Hz) a reference may give.
MAX_FREQUENCY = 1e7

_STUDY_KEYS = ("name", "description", "seed", "repetitions", "timeout", "identifiers")
_TOP_KEYS = ("study", "options", "datasets", "posterior")
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


@dataclass(frozen=True)
class ModelConfig:
    """One term set of a dataset (``terms`` besides the defaults, ``without``, ``px_roots``)."""

    name: str
    terms: str
    without: str = ""
    px_roots: tuple[float, float] | None = None

    def to_dict(self) -> dict[str, Any]:
        """Plain dictionary."""
        return {"name": self.name, "terms": self.terms, "without": self.without, "px_roots": self.px_roots}


@dataclass(frozen=True)
class DatasetConfig:
    """A validated dataset entry, with typed values (frozen: it travels to worker processes).

    Attributes
    ----------
    name, description
        As in the file.
    source
        Where the data come from: :class:`~nlid.study.values.PresetSource`,
        :class:`~nlid.study.values.BenchmarkSource` or
        :class:`~nlid.study.values.FileSource`.
    models
        The term sets (the dataset's own, ``"main"``, first).
    mass
        :class:`~nlid.study.values.KnownMass`, ``EstimatedMass`` or ``GivenMass``.
    holdout
        ``NoHoldout``, ``IndependentHoldout``, ``FractionHoldout`` or ``PartHoldout``.
    freerun, slices, repetitions, timeout, methods, reference
        As in the file (``methods``: per-identifier overrides).
    freerun_rule
        The held-out free run's transient rule as spelled in the file (``"window:50"``; empty: the held-out
        record's own, :func:`nlid.scoring.default_rule`).
    """

    name: str
    source: DataSource
    description: str = ""
    models: tuple[ModelConfig, ...] = ()
    mass: Mass = field(default_factory=KnownMass)
    holdout: Holdout = field(default_factory=NoHoldout)
    freerun: bool = True
    slices: tuple[float, ...] = ()
    repetitions: int = 1
    timeout: float = DEFAULT_TIMEOUT
    methods: Mapping[str, Mapping[str, Any]] = field(default_factory=FrozenDict)
    reference: Mapping[str, Any] | None = None
    freerun_rule: str = ""

    @property
    def kind(self) -> str:
        """``"preset"``, ``"dataset"`` or ``"file"``."""
        return self.source.kind

    @property
    def simulated(self) -> bool:
        """True for preset datasets (one record per repetition)."""
        return isinstance(self.source, PresetSource)

    def to_dict(self) -> dict[str, Any]:
        """The plain layout run specs carry in JSON (and their digests are computed from)."""
        src = self.source
        return {
            "name": self.name,
            "kind": src.kind,
            "source": src.path if isinstance(src, FileSource) else src.name,
            "description": self.description,
            "part": src.part if isinstance(src, BenchmarkSource) else "all",
            "columns": src.columns if isinstance(src, FileSource) else None,
            "fs": src.fs if isinstance(src, FileSource) else None,
            "overrides": dict(src.overrides) if isinstance(src, PresetSource) else {},
            "noise": (dict(src.noise) if isinstance(src.noise, Mapping) else src.noise)
            if isinstance(src, PresetSource)
            else 0.0,
            "channels": list(src.channels) if isinstance(src, PresetSource) else ["z"],
            "models": [m.to_dict() for m in self.models],
            "mass": self.mass.to_toml(),
            "holdout": self.holdout.to_toml(),
            "freerun": self.freerun,
            "slices": list(self.slices),
            "repetitions": self.repetitions,
            "timeout": self.timeout,
            "methods": {k: dict(v) for k, v in self.methods.items()},
            "reference": None if self.reference is None else dict(self.reference),
            **({"freerun_rule": self.freerun_rule} if self.freerun_rule else {}),  # absent: digests as before
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], where: Where | None = None) -> DatasetConfig:
        """Inverse of :meth:`to_dict` (a run spec read back from JSON)."""
        where = where or Where("<run spec>", "dataset")
        kind = data["kind"]
        if kind == "preset":
            src: DataSource = PresetSource(
                data["source"],
                data.get("overrides") or {},
                data.get("noise", 0.0),
                tuple(data.get("channels") or ("z",)),
            )
        elif kind == "dataset":
            src = BenchmarkSource(data["source"], data.get("part", "all"))
        elif kind == "file":
            src = FileSource(data["source"], data.get("columns"), data.get("fs"))
        else:
            raise where.error(f"unknown dataset kind {kind!r}")
        models = tuple(
            ModelConfig(
                m["name"], m["terms"], m.get("without", ""), None if m.get("px_roots") is None else tuple(m["px_roots"])
            )
            for m in data.get("models") or ()
        )
        return cls(
            name=data["name"],
            source=src,
            description=data.get("description", ""),
            models=models,
            mass=parse_mass(data.get("mass", "known"), where / "mass"),
            holdout=parse_holdout(data.get("holdout", "none"), kind, where / "holdout"),
            freerun=bool(data.get("freerun", True)),
            slices=tuple(float(x) for x in data.get("slices") or ()),
            repetitions=int(data.get("repetitions", 1)),
            timeout=float(data.get("timeout", DEFAULT_TIMEOUT)),
            methods=FrozenDict({k: FrozenDict(v) for k, v in (data.get("methods") or {}).items()}),
            reference=data.get("reference"),
            freerun_rule=str(data.get("freerun_rule") or ""),
        )


@dataclass(frozen=True)
class StudyConfig:
    """A validated study.

    Attributes
    ----------
    resolved
        True once :func:`resolve_study` has checked it against the disk.
    """

    name: str
    description: str
    seed: int
    identifiers: tuple[str, ...]
    options: dict[str, dict[str, Any]]
    datasets: tuple[DatasetConfig, ...]
    posterior: dict[str, Any] | None
    source: str
    text: str
    skipped_identifiers: dict[str, str] = field(default_factory=dict)
    resolved: bool = False

    @property
    def run_count(self) -> int:
        """How many runs the study plans."""
        return sum(len(d.models) * len(self.identifiers) * d.repetitions for d in self.datasets)


# --------------------------------------------------------------------------- helpers
def _unknown(source: str, key: str, name: str, known: tuple[str, ...] | list[str], what: str = "key") -> ConfigError:
    return ConfigError(source, key, f"unknown {what} {name!r}{did_you_mean(name, known)}; known: {', '.join(known)}")


def _check_keys(where: Where, table: Mapping[str, Any], known: tuple[str, ...]) -> None:
    for key in table:
        if key not in known:
            raise _unknown(where.source, (where / key).key, key, known)


def _table(where: Where, value: Any) -> dict[str, Any]:
    if not isinstance(value, Mapping):
        raise where.error(f"expected a table, got {type(value).__name__} {brief(value)}")
    return dict(value)


def _name(where: Where, value: Any) -> str:
    value = where.string(value)
    if not _NAME.match(value):
        raise where.error(f"{value!r} is not a usable name (letters, digits, _ . + -; no spaces or /)")
    return value


def _roots(where: Where, value: Any) -> tuple[float, float] | None:
    if value is None:
        return None
    if not isinstance(value, list) or len(value) != 2:
        raise where.error(f"expected two numbers [z-, z+], got {brief(value)}")
    low, high = (
        float((where / f"[{i}]").number(x, minimum=-MAX_POSITION, maximum=MAX_POSITION)) for i, x in enumerate(value)
    )
    return low, high


def _check_model(where: Where, model: ModelConfig) -> None:
    try:
        as_model(model.terms, without=model.without, px_roots=model.px_roots)
    except NlidError as exc:
        raise where.error(str(exc)) from None


def _check_finite(where: Where, value: Any) -> None:
    """Every number inside ``value`` (tables and arrays too) is finite."""
    if isinstance(value, Mapping):
        for k, v in value.items():
            _check_finite(where / str(k), v)
    elif isinstance(value, list):
        for i, v in enumerate(value):
            _check_finite(where / f"[{i}]", v)
    elif isinstance(value, float) and not math.isfinite(value):
        raise where.error(f"expected a finite number, got {brief(value)}")


#: Package folder of the built-in studies (package data; copies of the repository's ``studies/``).
BUILTIN_PACKAGE_DIR = "studies"


def builtin_dirs() -> list[Path]:
    """Folders searched for built-in studies: the package data folder ``nlid/studies``.

    The studies ship inside the package (read with :mod:`importlib.resources`),
    so every kind of install finds them: a virtual environment, ``pip install
    --user``, ``pip install --target DIR`` or the source tree.
    """
    from importlib.resources import files

    return [Path(str(files("nlid") / BUILTIN_PACKAGE_DIR))]


def builtin_studies() -> dict[str, Path]:
    """``{name: path}`` of the built-in studies (the first folder that has a name wins)."""
    out: dict[str, Path] = {}
    for folder in builtin_dirs():
        if folder.is_dir():
            for path in sorted(folder.glob("*.toml")):
                out.setdefault(path.stem, path)
    return out


def resolve_study_path(name_or_path: str | os.PathLike[str]) -> Path:
    """A study file from a built-in name or a path.

    Raises
    ------
    InputError
        Naming the built-in studies (with a suggestion) when neither matches.
    """
    text = str(name_or_path)
    path = Path(text).expanduser()
    if path.is_dir():
        raise InputError(f"study file {text} is a folder, not a .toml file")
    if path.suffix == ".toml" or os.sep in text or path.is_file():
        if path.is_dir():
            raise InputError(f"study file {text} is a folder, not a .toml file")
        if not path.is_file():
            raise InputError(f"study file {text} not found")
        return path
    studies = builtin_studies()
    if text in studies:
        return studies[text]
    raise InputError(
        f"unknown study {text!r}{did_you_mean(text, studies)}"
        f"; built-in studies: {', '.join(studies) or 'none found'} (or give a path to a .toml file)"
    )


# --------------------------------------------------------------------------- loading
def load_study(name_or_path: str | os.PathLike[str], *, registry: Registry | None = None) -> StudyConfig:
    """Read, validate and resolve a study (built-in name or TOML path).

    Parameters
    ----------
    name_or_path
        A built-in study name (``nlid study list``) or a ``.toml`` file.
    registry
        Where identifiers are looked up; default: the installed plugins.

    Raises
    ------
    ConfigError
        For anything invalid, naming the file and key.
    """
    path = resolve_study_path(name_or_path)
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise InputError(f"cannot read study file {path}: {exc.strerror}") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ConfigError(str(path), "", f"not UTF-8 text (byte {exc.start}): a TOML file must be UTF-8") from None
    config = parse_study(text, source=str(path), base_dir=path.parent, default_name=path.stem, registry=registry)
    return resolve_study(config)


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
    _check_keys(top, raw, _TOP_KEYS)
    at = Where(source, "study")
    study = _table(at, raw.get("study", {}))
    _check_keys(at, study, _STUDY_KEYS)
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
    options_raw = _table(at_options, raw.get("options", {}))
    options: dict[str, dict[str, Any]] = {}
    for ident, opts in options_raw.items():
        if ident not in identifiers:
            raise _unknown(source, f"options.{ident}", ident, list(identifiers), "identifier")
        opts = _table(at_options / ident, opts)
        _validate_options(at_options / ident, registry, ident, opts)
        options[ident] = opts

    if "datasets" not in raw:
        raise ConfigError(source, "datasets", "a study needs at least one [[datasets]] entry")
    if not isinstance(raw["datasets"], list) or not raw["datasets"]:
        raise ConfigError(source, "datasets", "expected one or more [[datasets]] tables")
    datasets = []
    for i, entry in enumerate(raw["datasets"]):
        where = Where(source, f"datasets[{i}]")
        datasets.append(_dataset(where, _table(where, entry), Path(base_dir), reps, timeout))
        for ident, over in datasets[-1].methods.items():
            if ident not in identifiers:
                raise _unknown(source, f"datasets[{i}].methods.{ident}", ident, list(identifiers), "identifier")
            merged = {**options.get(ident, {}), **over.get("options", {})}
            _validate_options(where / f"methods.{ident}.options", registry, ident, merged)
    names = [d.name for d in datasets]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise ConfigError(source, "datasets", f"dataset name {dup[0]!r} is used twice; give each a unique name")

    posterior = _posterior(Where(source, "posterior"), raw["posterior"], datasets) if "posterior" in raw else None

    config = StudyConfig(
        name=name,
        description=(at / "description").string(study.get("description", "")),
        seed=seed,
        identifiers=identifiers,
        options=options,
        datasets=tuple(datasets),
        posterior=posterior,
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
    table = _table(where, value)
    try:
        from ..bayes import PosteriorSampler
    except ImportError as exc:  # pragma: no cover - nlid.bayes is part of nlid
        raise where.error(f"needs the module nlid.bayes, which is not available ({exc})") from None
    known = tuple(n for n in inspect.signature(PosteriorSampler).parameters if n != "self") + ("level",)
    _check_keys(where, table, known)
    _check_finite(where, table)
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


def _check_posterior_terms(where: Where, settings: Mapping[str, Any], datasets: list[DatasetConfig]) -> None:
    """The sampled terms and the terms given priors exist in each dataset's own term set.

    (Alternative term sets may lack them: their runs then report the posterior as a warning.)
    """
    from ..bayes import select_params
    from ..bayes.priors import parse_prior_assignments

    params = settings.get("params", "damping")
    priors = parse_prior_assignments(settings.get("priors"))
    for ds in datasets:
        main = ds.models[0]
        model = as_model(main.terms, without=main.without, px_roots=main.px_roots)
        try:
            names = [model.names[i] for i in select_params(model, params)]
        except NlidError as exc:
            raise (where / "params").error(f"dataset {ds.name!r}: {exc}") from None
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


def _preset_source(where: Where, value: str, entry: dict[str, Any]) -> tuple[PresetSource, str]:
    from ..presets import get_preset

    overrides = _table(where / "overrides", entry.get("overrides", {}))
    _check_finite(where / "overrides", overrides)
    try:
        preset = get_preset(value)
        over = dict(overrides)
        if isinstance(over.get("band"), list):
            over["band"] = tuple(over["band"])
        preset = preset.with_overrides(**over) if over else preset
        preset.model()
    except NlidError as exc:
        raise (where / ("overrides" if overrides else "preset")).error(str(exc)) from None
    except (TypeError, ValueError) as exc:
        raise (where / "overrides").error(f"invalid preset override: {exc}") from None
    noise: dict[str, float] | float = 0.0
    if "noise" in entry:
        raw_noise = entry["noise"]
        if isinstance(raw_noise, Mapping):
            noise = {}
            for ch, x in raw_noise.items():
                if ch not in RESPONSE_CHANNELS:
                    raise _unknown(where.source, (where / f"noise.{ch}").key, ch, RESPONSE_CHANNELS, "channel")
                noise[ch] = (where / f"noise.{ch}").check(NOISE_FRACTION, x)
        else:
            noise = (where / "noise").check(NOISE_FRACTION, raw_noise)
    channels_raw = entry.get("channels", list(noise) if isinstance(noise, dict) else ["z"])
    if not isinstance(channels_raw, list) or not all(c in RESPONSE_CHANNELS for c in channels_raw):
        raise (where / "channels").error(f"expected a list of z, v, a; got {brief(channels_raw)}")
    channels = tuple(dict.fromkeys(["z", *channels_raw]))
    try:
        check_noise(noise, channels)  # each channel given a level is recorded
    except InputError as exc:
        raise (where / "noise").error(str(exc)) from None
    return PresetSource(value, overrides, noise, channels), preset.terms


def _dataset(where: Where, entry: dict[str, Any], base: Path, reps: int, timeout: float) -> DatasetConfig:
    _check_keys(where, entry, _DATASET_KEYS)
    kinds = [k for k in ("preset", "dataset", "file") if k in entry]
    if len(kinds) != 1:
        raise where.error("give exactly one of preset, dataset or file")
    kind = kinds[0]
    value = (where / kind).string(entry[kind])
    default_terms = ""
    for k in ("overrides", "noise", "channels") if kind != "preset" else ():
        if k in entry:
            raise (where / k).error(f"only applies to preset datasets, not {kind}")
    for k in ("columns", "fs") if kind != "file" else ():
        if k in entry:
            raise (where / k).error("only applies to file datasets")
    if "part" in entry and kind != "dataset":
        raise (where / "part").error("only applies to nlid.datasets entries (dataset = ...)")
    source: DataSource
    if kind == "preset":
        source, default_terms = _preset_source(where, value, entry)
    elif kind == "dataset":
        from .. import datasets as nlid_datasets

        if value not in nlid_datasets.DATASETS:
            raise _unknown(where.source, (where / "dataset").key, value, list(nlid_datasets.DATASETS), "dataset")
        source = BenchmarkSource(value, (where / "part").string(entry.get("part", "all")))
    else:
        expanded = os.path.expandvars(os.path.expanduser(value))
        if "$" in expanded:
            raise (where / "file").error(f"{value!r}: an environment variable in it is not set")
        path = Path(expanded)
        path = path if path.is_absolute() else (base / path)
        fs = None
        if "fs" in entry:
            fs = float((where / "fs").number(entry["fs"], positive=True, maximum=1e9))
        columns = None if "columns" not in entry else (where / "columns").string(entry["columns"])
        try:
            parse_columns(columns)
        except NlidError as exc:
            raise (where / "columns").error(str(exc)) from None
        source = FileSource(os.path.normpath(os.path.abspath(path)), columns, fs)

    name = _name(where / "name", entry.get("name", value if kind != "file" else Path(value).stem))

    terms = (where / "terms").string(entry.get("terms", default_terms))
    main = ModelConfig(
        MAIN_MODEL,
        terms,
        (where / "without").string(entry.get("without", "")),
        _roots(where / "px_roots", entry.get("px_roots")),
    )
    _check_model(where / "terms", main)
    models = [main]
    at_models = where / "models"
    for mname, spec in _table(at_models, entry.get("models", {})).items():
        mw = at_models / mname
        _name(mw, mname)
        if mname == MAIN_MODEL:
            raise mw.error(f"{MAIN_MODEL!r} is the dataset's own terms; choose another name")
        if isinstance(spec, str):
            spec = {"terms": spec}
        spec = _table(mw, spec)
        _check_keys(mw, spec, _MODEL_KEYS)
        model = ModelConfig(
            mname,
            (mw / "terms").string(spec.get("terms", "")),
            (mw / "without").string(spec.get("without", "")),
            _roots(mw / "px_roots", spec.get("px_roots")),
        )
        _check_model(mw / "terms", model)
        models.append(model)

    methods: dict[str, FrozenDict] = {}
    at_methods = where / "methods"
    for ident, spec in _table(at_methods, entry.get("methods", {})).items():
        mw = at_methods / ident
        spec = _table(mw, spec)
        _check_keys(mw, spec, _METHOD_KEYS)
        if "options" in spec:
            spec["options"] = FrozenDict(_table(mw / "options", spec["options"]))
        for m in models:
            _check_model(
                mw / "terms",
                ModelConfig(
                    m.name,
                    (mw / "terms").string(spec.get("terms", m.terms)),
                    (mw / "without").string(spec.get("without", m.without)),
                    _roots(mw / "px_roots", spec.get("px_roots", m.px_roots)),
                ),
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


def _reference(where: Where, value: Any) -> dict[str, Any]:
    reference = _table(where, value)
    _check_keys(where, reference, _REFERENCE_KEYS)
    if "coefficients" in reference:
        coeffs = _table(where / "coefficients", reference["coefficients"])
        for term, x in coeffs.items():
            (where / f"coefficients.{term}").number(x)
            try:
                as_model(term, without="1,z,v")
            except NlidError as exc:
                raise (where / "coefficients").error(str(exc)) from None
        reference["coefficients"] = {as_model(t, without="1,z,v").names[0]: float(x) for t, x in coeffs.items()}
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
            _check_keys(mw, m, ("fn_hz", "zeta"))
            missing = [k for k in ("fn_hz", "zeta") if k not in m]
            if missing:
                raise mw.error(f"needs {' and '.join(missing)} (a table {{ fn_hz = ..., zeta = ... }})")
            (mw / "fn_hz").number(m["fn_hz"], positive=True, maximum=MAX_FREQUENCY)
            (mw / "zeta").number(m["zeta"], positive=True)
    return reference


# --------------------------------------------------------------------------- the disk
def resolve_study(config: StudyConfig) -> StudyConfig:
    """Check what a parsed study names: files read, benchmark parts load, "known" masses are known, presets simulate.

    This is the only step of loading a study that touches the disk; it
    returns the config marked ``resolved``.

    Raises
    ------
    ConfigError
        Naming the file and key of the first dataset that cannot be read.
    """
    for i, ds in enumerate(config.datasets):
        where = Where(config.source, f"datasets[{i}]")
        src = ds.source
        if isinstance(src, BenchmarkSource):
            loaded = None
            for key, part in (("part", src.part), ("holdout", getattr(ds.holdout, "part", None))):
                if part is None:
                    continue
                try:
                    record = src.load(part)
                except NlidError as exc:
                    raise (where / key).error(str(exc)) from None
                if key == "part":
                    loaded = record
            known = bool(loaded is not None and (loaded.mass or (loaded.meta.get("reference") or {}).get("mass")))
            if isinstance(ds.mass, KnownMass) and not known and not (ds.reference and "mass" in ds.reference):
                raise (where / "mass").error('the mass is not known for this data: give it in kg or "estimate"')
        elif isinstance(src, PresetSource):
            _trial_simulation(where, src)
        elif isinstance(src, FileSource):
            if not Path(src.path).is_file():
                raise (where / "file").error(f"file {src.path} not found")
            try:
                src.load()
            except NlidError as exc:
                raise (where / "file").error(str(exc)) from None
    return replace(config, resolved=True)


#: Seconds of a preset simulated by :func:`resolve_study` to check that the overrides give a stable model.
TRIAL_SECONDS = 1.0


def _trial_simulation(where: Where, source: PresetSource) -> None:
    """Simulate the first :data:`TRIAL_SECONDS` of a preset dataset: absurd overrides diverge at once."""
    preset = source.preset()
    duration = min(preset.duration, max(TRIAL_SECONDS, 64.0 / preset.fs))
    try:
        preset.with_overrides(duration=duration).simulate(0, channels=source.channels)
    except NlidError as exc:
        key = "overrides" if source.overrides else "preset"
        raise (where / key).error(f"the first {duration:g} s of the simulation fail: {exc}") from None
