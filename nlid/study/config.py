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

Everything is checked by :func:`load_study`: unknown keys, presets, datasets,
files, terms, identifiers and options are reported as one
:class:`ConfigError` naming the file, the key and, where one exists, a
suggestion.
"""

from __future__ import annotations

import importlib
import os
import re
import sys
from collections.abc import Mapping
from dataclasses import dataclass, field
from difflib import get_close_matches
from pathlib import Path
from typing import Any

from ..errors import InputError, NlidError
from ..interface import resolve_options
from ..pipeline import as_model
from ..registry import Registry, default_registry

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
    "builtin_studies",
    "resolve_study_path",
]

DEFAULT_TIMEOUT = 600.0
MAIN_MODEL = "main"

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


class ConfigError(InputError):
    """A study configuration is invalid.

    Parameters
    ----------
    source
        The file (or ``"<string>"``).
    key
        Dotted key, e.g. ``datasets[2].terms``.
    message
        What is wrong (with a suggestion where one exists).
    """

    def __init__(self, source: str, key: str, message: str):
        self.source, self.key, self.reason = source, key, message
        where = f"{source}: {key}: " if key else f"{source}: "
        super().__init__(where + message)


@dataclass(frozen=True)
class ModelConfig:
    """One term set of a dataset (``terms`` besides the defaults, ``without``, ``px_roots``)."""

    name: str
    terms: str
    without: str = ""
    px_roots: tuple[float, float] | None = None


@dataclass(frozen=True)
class DatasetConfig:
    """A validated dataset entry (plain values only: it travels to worker processes).

    Attributes
    ----------
    kind
        ``"preset"``, ``"dataset"`` or ``"file"``.
    source
        Preset name, ``nlid.datasets`` name, or the resolved file path.
    """

    name: str
    kind: str
    source: str
    description: str = ""
    part: str = "all"
    columns: str | None = None
    fs: float | None = None
    overrides: dict[str, Any] = field(default_factory=dict)
    noise: dict[str, float] | float = 0.0
    channels: tuple[str, ...] = ("z",)
    models: tuple[ModelConfig, ...] = ()
    mass: str | float = "known"
    holdout: str | float = "none"
    freerun: bool = True
    slices: tuple[float, ...] = ()
    repetitions: int = 1
    timeout: float = DEFAULT_TIMEOUT
    methods: dict[str, dict[str, Any]] = field(default_factory=dict)
    reference: dict[str, Any] | None = None

    @property
    def simulated(self) -> bool:
        """True for preset datasets (one record per repetition)."""
        return self.kind == "preset"

    def to_dict(self) -> dict[str, Any]:
        """Plain dictionary (for worker processes and the study record)."""
        out = dict(self.__dict__)
        out["channels"] = list(self.channels)
        out["models"] = [
            {"name": m.name, "terms": m.terms, "without": m.without, "px_roots": m.px_roots} for m in self.models
        ]
        return out


@dataclass(frozen=True)
class StudyConfig:
    """A validated study."""

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


# --------------------------------------------------------------------------- helpers
def _unknown(source: str, key: str, name: str, known: tuple[str, ...] | list[str], what: str = "key") -> ConfigError:
    hint = get_close_matches(name, list(known), n=1)
    return ConfigError(
        source,
        key,
        f"unknown {what} {name!r}" + (f" (did you mean {hint[0]!r}?)" if hint else "") + f"; known: {', '.join(known)}",
    )


def _check_keys(source: str, prefix: str, table: Mapping[str, Any], known: tuple[str, ...]) -> None:
    for key in table:
        if key not in known:
            raise _unknown(source, f"{prefix}{key}" if prefix else key, key, known)


def _table(source: str, key: str, value: Any) -> dict[str, Any]:
    if not isinstance(value, Mapping):
        raise ConfigError(source, key, f"expected a table, got {type(value).__name__} {value!r}")
    return dict(value)


def _number(source: str, key: str, value: Any, *, minimum: float | None = None, integer: bool = False) -> Any:
    ok = isinstance(value, int) if integer else isinstance(value, (int, float))
    if isinstance(value, bool) or not ok:
        raise ConfigError(source, key, f"expected {'an integer' if integer else 'a number'}, got {value!r}")
    if minimum is not None and value < minimum:
        raise ConfigError(source, key, f"must be >= {minimum:g}, got {value!r}")
    return value


def _string(source: str, key: str, value: Any) -> str:
    if not isinstance(value, str):
        raise ConfigError(source, key, f"expected a string, got {value!r}")
    return value


def _name(source: str, key: str, value: Any) -> str:
    value = _string(source, key, value)
    if not _NAME.match(value):
        raise ConfigError(source, key, f"{value!r} is not a usable name (letters, digits, _ . + -; no spaces or /)")
    return value


def _roots(source: str, key: str, value: Any) -> tuple[float, float] | None:
    if value is None:
        return None
    if not isinstance(value, list) or len(value) != 2:
        raise ConfigError(source, key, f"expected two numbers [z-, z+], got {value!r}")
    return (float(_number(source, key, value[0])), float(_number(source, key, value[1])))


def _check_model(source: str, key: str, model: ModelConfig) -> None:
    try:
        as_model(model.terms, without=model.without, px_roots=model.px_roots)
    except NlidError as exc:
        raise ConfigError(source, key, str(exc)) from None


def builtin_dirs() -> list[Path]:
    """Folders searched for built-in studies: the source tree's ``studies/``, then the installed copy."""
    here = Path(__file__).resolve()
    return [here.parents[2] / "studies", Path(sys.prefix) / "share" / "nlid" / "studies"]


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
    if path.suffix == ".toml" or os.sep in text or path.is_file():
        if not path.is_file():
            raise InputError(f"study file {text} not found")
        return path
    studies = builtin_studies()
    if text in studies:
        return studies[text]
    hint = get_close_matches(text, list(studies), n=1)
    raise InputError(
        f"unknown study {text!r}"
        + (f" (did you mean {hint[0]!r}?)" if hint else "")
        + f"; built-in studies: {', '.join(studies) or 'none found'} (or give a path to a .toml file)"
    )


# --------------------------------------------------------------------------- loading
def load_study(name_or_path: str | os.PathLike[str], *, registry: Registry | None = None) -> StudyConfig:
    """Read and validate a study (built-in name or TOML path).

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
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise InputError(f"cannot read study file {path}: {exc.strerror}") from None
    return parse_study(text, source=str(path), base_dir=path.parent, default_name=path.stem, registry=registry)


def parse_study(
    text: str,
    *,
    source: str = "<string>",
    base_dir: str | os.PathLike[str] = ".",
    default_name: str = "study",
    registry: Registry | None = None,
) -> StudyConfig:
    """Validate a study given as TOML text (see the module docstring for the keys)."""
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(source, "", f"not valid TOML: {exc}") from None
    _check_keys(source, "", raw, _TOP_KEYS)
    study = _table(source, "study", raw.get("study", {}))
    _check_keys(source, "study.", study, _STUDY_KEYS)
    name = _name(source, "study.name", study.get("name", default_name))
    seed = int(_number(source, "study.seed", study.get("seed", 0), minimum=0, integer=True))
    reps = int(_number(source, "study.repetitions", study.get("repetitions", 1), minimum=1, integer=True))
    timeout = float(_number(source, "study.timeout", study.get("timeout", DEFAULT_TIMEOUT), minimum=1e-3))
    registry = registry or default_registry()

    wanted = study.get("identifiers", "all")
    skipped: dict[str, str] = {}
    if wanted == "all":
        identifiers = tuple(registry.names())
        skipped = dict(registry.failures)
        if not identifiers:
            raise ConfigError(source, "study.identifiers", "no identifier is installed (see nlid methods)")
    elif isinstance(wanted, list) and wanted and all(isinstance(x, str) for x in wanted):
        for i, ident in enumerate(wanted):
            try:
                registry.get(ident)
            except NlidError as exc:
                raise ConfigError(source, f"study.identifiers[{i}]", str(exc)) from None
        if len(set(wanted)) != len(wanted):
            raise ConfigError(source, "study.identifiers", "an identifier is listed twice")
        identifiers = tuple(wanted)
    else:
        raise ConfigError(source, "study.identifiers", f'expected "all" or a list of names, got {wanted!r}')

    options_raw = _table(source, "options", raw.get("options", {}))
    options: dict[str, dict[str, Any]] = {}
    for ident, opts in options_raw.items():
        if ident not in identifiers:
            raise _unknown(source, f"options.{ident}", ident, list(identifiers), "identifier")
        opts = _table(source, f"options.{ident}", opts)
        _validate_options(source, f"options.{ident}", registry, ident, opts)
        options[ident] = opts

    if "datasets" not in raw:
        raise ConfigError(source, "datasets", "a study needs at least one [[datasets]] entry")
    if not isinstance(raw["datasets"], list) or not raw["datasets"]:
        raise ConfigError(source, "datasets", "expected one or more [[datasets]] tables")
    datasets = []
    for i, entry in enumerate(raw["datasets"]):
        datasets.append(
            _dataset(source, f"datasets[{i}]", _table(source, f"datasets[{i}]", entry), Path(base_dir), reps, timeout)
        )
        for ident, over in datasets[-1].methods.items():
            if ident not in identifiers:
                raise _unknown(source, f"datasets[{i}].methods.{ident}", ident, list(identifiers), "identifier")
            merged = {**options.get(ident, {}), **over.get("options", {})}
            _validate_options(source, f"datasets[{i}].methods.{ident}.options", registry, ident, merged)
    names = [d.name for d in datasets]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise ConfigError(source, "datasets", f"dataset name {dup[0]!r} is used twice; give each a unique name")

    posterior = None
    if "posterior" in raw:
        posterior = _table(source, "posterior", raw["posterior"])
        try:
            module = importlib.import_module("nlid.bayes")
        except ImportError as exc:
            raise ConfigError(
                source, "posterior", f"needs the module nlid.bayes, which is not available ({exc})"
            ) from None
        if not callable(getattr(module, "study_metrics", None)):
            raise ConfigError(source, "posterior", "nlid.bayes has no study_metrics() function")

    return StudyConfig(
        name=name,
        description=_string(source, "study.description", study.get("description", "")),
        seed=seed,
        identifiers=identifiers,
        options=options,
        datasets=tuple(datasets),
        posterior=posterior,
        source=source,
        text=text,
        skipped_identifiers=skipped,
    )


def _validate_options(source: str, key: str, registry: Registry, ident: str, opts: Mapping[str, Any]) -> None:
    cls = registry.get(ident)
    try:
        resolve_options(tuple(getattr(cls, "options", ())), opts)
        cls(**dict(opts))
    except NlidError as exc:
        raise ConfigError(source, key, str(exc)) from None


def _dataset(source: str, key: str, entry: dict[str, Any], base: Path, reps: int, timeout: float) -> DatasetConfig:
    _check_keys(source, f"{key}.", entry, _DATASET_KEYS)
    kinds = [k for k in ("preset", "dataset", "file") if k in entry]
    if len(kinds) != 1:
        raise ConfigError(source, key, "give exactly one of preset, dataset or file")
    kind = kinds[0]
    value = _string(source, f"{key}.{kind}", entry[kind])
    default_terms = ""
    overrides: dict[str, Any] = {}
    part = "all"
    truth_known = False
    if kind == "preset":
        from ..presets import get_preset

        try:
            preset = get_preset(value)
            overrides = _table(source, f"{key}.overrides", entry.get("overrides", {}))
            if "band" in overrides and isinstance(overrides["band"], list):
                overrides["band"] = tuple(overrides["band"])
            preset = preset.with_overrides(**overrides) if overrides else preset
            preset.model()
        except NlidError as exc:
            raise ConfigError(source, f"{key}.{'overrides' if overrides else 'preset'}", str(exc)) from None
        except (TypeError, ValueError) as exc:
            raise ConfigError(source, f"{key}.overrides", f"invalid preset override: {exc}") from None
        default_terms = preset.terms
        truth_known = True
        source_value = value
    elif kind == "dataset":
        from .. import datasets as nlid_datasets

        if value not in nlid_datasets.DATASETS:
            raise _unknown(source, f"{key}.dataset", value, list(nlid_datasets.DATASETS), "dataset")
        part = _string(source, f"{key}.part", entry.get("part", "all"))
        holdout_part = entry.get("holdout")
        for k, p in (("part", part), ("holdout", holdout_part)):
            if isinstance(p, str) and p not in ("none", "independent"):
                try:
                    loaded = nlid_datasets.load(value, part=p)
                except NlidError as exc:
                    raise ConfigError(source, f"{key}.{k}", str(exc)) from None
                if k == "part":
                    truth_known = bool(loaded.mass or (loaded.meta.get("reference") or {}).get("mass"))
        source_value = value
    else:
        expanded = os.path.expandvars(os.path.expanduser(value))
        if "$" in expanded:
            raise ConfigError(source, f"{key}.file", f"{value!r}: an environment variable in it is not set")
        path = Path(expanded)
        path = path if path.is_absolute() else (base / path)
        if not path.is_file():
            raise ConfigError(source, f"{key}.file", f"file {path} not found")
        source_value = str(path.resolve())
        try:
            from ..io import read_record

            read_record(source_value, entry.get("columns"), fs=entry.get("fs"))
        except NlidError as exc:
            raise ConfigError(source, f"{key}.file", str(exc)) from None
    for k in ("overrides", "noise", "channels") if kind != "preset" else ():
        if k in entry:
            raise ConfigError(source, f"{key}.{k}", f"only applies to preset datasets, not {kind}")
    for k in ("columns", "fs") if kind != "file" else ():
        if k in entry:
            raise ConfigError(source, f"{key}.{k}", "only applies to file datasets")
    if "part" in entry and kind != "dataset":
        raise ConfigError(source, f"{key}.part", "only applies to nlid.datasets entries (dataset = ...)")

    name = _name(source, f"{key}.name", entry.get("name", value if kind != "file" else Path(value).stem))

    noise: dict[str, float] | float = 0.0
    if "noise" in entry:
        raw_noise = entry["noise"]
        if isinstance(raw_noise, Mapping):
            noise = {}
            for ch, x in raw_noise.items():
                if ch not in ("z", "v", "a"):
                    raise _unknown(source, f"{key}.noise.{ch}", ch, ["z", "v", "a"], "channel")
                noise[ch] = float(_number(source, f"{key}.noise.{ch}", x, minimum=0.0))
        else:
            noise = float(_number(source, f"{key}.noise", raw_noise, minimum=0.0))
        levels = noise.values() if isinstance(noise, dict) else [noise]
        if any(x >= 10 for x in levels):
            raise ConfigError(source, f"{key}.noise", "noise is a fraction of the signal's std (0.02 = 2 %)")
    channels_raw = entry.get("channels", list(noise) if isinstance(noise, dict) else ["z"])
    if not isinstance(channels_raw, list) or not all(c in ("z", "v", "a") for c in channels_raw):
        raise ConfigError(source, f"{key}.channels", f"expected a list of z, v, a; got {channels_raw!r}")
    channels = tuple(dict.fromkeys(["z", *channels_raw]))
    if isinstance(noise, dict):
        missing = [c for c in noise if c not in channels]
        if missing:
            raise ConfigError(source, f"{key}.noise", f"noise on channel {missing[0]!r}, which is not recorded")

    terms = _string(source, f"{key}.terms", entry.get("terms", default_terms))
    main = ModelConfig(
        MAIN_MODEL,
        terms,
        _string(source, f"{key}.without", entry.get("without", "")),
        _roots(source, f"{key}.px_roots", entry.get("px_roots")),
    )
    _check_model(source, f"{key}.terms", main)
    models = [main]
    for mname, spec in _table(source, f"{key}.models", entry.get("models", {})).items():
        mkey = f"{key}.models.{mname}"
        _name(source, mkey, mname)
        if mname == MAIN_MODEL:
            raise ConfigError(source, mkey, f"{MAIN_MODEL!r} is the dataset's own terms; choose another name")
        if isinstance(spec, str):
            spec = {"terms": spec}
        spec = _table(source, mkey, spec)
        _check_keys(source, f"{mkey}.", spec, _MODEL_KEYS)
        model = ModelConfig(
            mname,
            _string(source, f"{mkey}.terms", spec.get("terms", "")),
            _string(source, f"{mkey}.without", spec.get("without", "")),
            _roots(source, f"{mkey}.px_roots", spec.get("px_roots")),
        )
        _check_model(source, f"{mkey}.terms", model)
        models.append(model)

    methods: dict[str, dict[str, Any]] = {}
    for ident, spec in _table(source, f"{key}.methods", entry.get("methods", {})).items():
        mkey = f"{key}.methods.{ident}"
        spec = _table(source, mkey, spec)
        _check_keys(source, f"{mkey}.", spec, _METHOD_KEYS)
        if "options" in spec:
            spec["options"] = _table(source, f"{mkey}.options", spec["options"])
        for m in models:
            _check_model(
                source,
                f"{mkey}.terms",
                ModelConfig(
                    m.name,
                    _string(source, f"{mkey}.terms", spec.get("terms", m.terms)),
                    _string(source, f"{mkey}.without", spec.get("without", m.without)),
                    _roots(source, f"{mkey}.px_roots", spec.get("px_roots", m.px_roots)),
                ),
            )
        methods[ident] = spec

    mass = entry.get("mass", "known" if kind == "preset" else "estimate")
    if isinstance(mass, str):
        if mass not in ("known", "estimate"):
            raise ConfigError(source, f"{key}.mass", f'expected "known", "estimate" or a number in kg, got {mass!r}')
    else:
        mass = float(_number(source, f"{key}.mass", mass, minimum=0.0))
        if mass <= 0:
            raise ConfigError(source, f"{key}.mass", "the mass must be positive (kg)")

    reference = None
    if "reference" in entry:
        reference = _table(source, f"{key}.reference", entry["reference"])
        _check_keys(source, f"{key}.reference.", reference, _REFERENCE_KEYS)
        if "coefficients" in reference:
            coeffs = _table(source, f"{key}.reference.coefficients", reference["coefficients"])
            for term, x in coeffs.items():
                _number(source, f"{key}.reference.coefficients.{term}", x)
                try:
                    as_model(term, without="1,z,v")
                except NlidError as exc:
                    raise ConfigError(source, f"{key}.reference.coefficients", str(exc)) from None
            reference["coefficients"] = {as_model(t, without="1,z,v").names[0]: float(x) for t, x in coeffs.items()}
        if "mass" in reference:
            reference["mass"] = float(_number(source, f"{key}.reference.mass", reference["mass"], minimum=0.0))
        if "equilibria" in reference:
            eq = reference["equilibria"]
            if not isinstance(eq, list) or not all(isinstance(x, (int, float)) for x in eq):
                raise ConfigError(source, f"{key}.reference.equilibria", "expected a list of positions (m)")
            reference["equilibria"] = sorted(float(x) for x in eq)
        if "modal" in reference:
            modal = reference["modal"]
            if not isinstance(modal, list) or not all(isinstance(m, Mapping) for m in modal):
                raise ConfigError(source, f"{key}.reference.modal", "expected a list of {fn_hz, zeta} tables")
            for j, m in enumerate(modal):
                _check_keys(source, f"{key}.reference.modal[{j}].", m, ("fn_hz", "zeta"))
    if mass == "known" and not truth_known and not (reference and "mass" in reference):
        raise ConfigError(source, f"{key}.mass", 'the mass is not known for this data: give it in kg or "estimate"')

    holdout = entry.get("holdout", "independent" if kind == "preset" else "none")
    if isinstance(holdout, str):
        if holdout == "independent" and kind != "preset":
            raise ConfigError(source, f"{key}.holdout", '"independent" needs a preset (a second simulated record)')
        if holdout not in ("independent", "none") and kind != "dataset":
            raise ConfigError(
                source, f"{key}.holdout", f'expected "independent", "none" or a fraction such as 0.25; got {holdout!r}'
            )
    else:
        holdout = float(_number(source, f"{key}.holdout", holdout))
        if not 0 < holdout < 1:
            raise ConfigError(source, f"{key}.holdout", f"a held-out fraction must be between 0 and 1, got {holdout}")

    freerun = entry.get("freerun", True)
    if not isinstance(freerun, bool):
        raise ConfigError(source, f"{key}.freerun", f"expected true or false, got {freerun!r}")
    slices = entry.get("slices", [])
    if not isinstance(slices, list):
        raise ConfigError(source, f"{key}.slices", f"expected a list of positions in m, got {slices!r}")
    slices = tuple(float(_number(source, f"{key}.slices", z)) for z in slices)
    d_reps = int(_number(source, f"{key}.repetitions", entry.get("repetitions", reps), minimum=1, integer=True))
    if kind != "preset":
        d_reps = 1  # measured data: the same record every time
    return DatasetConfig(
        name=name,
        kind=kind,
        source=source_value,
        description=_string(source, f"{key}.description", entry.get("description", "")),
        part=part,
        columns=None if "columns" not in entry else _string(source, f"{key}.columns", entry["columns"]),
        fs=None if "fs" not in entry else float(_number(source, f"{key}.fs", entry["fs"], minimum=0.0)),
        overrides=overrides,
        noise=noise,
        channels=channels,
        models=tuple(models),
        mass=mass,
        holdout=holdout,
        freerun=freerun,
        slices=slices,
        repetitions=d_reps,
        timeout=float(_number(source, f"{key}.timeout", entry.get("timeout", timeout), minimum=1e-3)),
        methods=methods,
        reference=reference,
    )
