"""The typed study: :class:`StudyConfig`, its :class:`DatasetConfig` entries and their :class:`ModelConfig` term sets.

These are frozen values (a dataset entry travels to worker processes). Each
writes itself back: :meth:`DatasetConfig.to_dict` is the layout run specs
carry in JSON (and their digests are computed from), :meth:`DatasetConfig.to_toml`
the entry of a study file, and :meth:`StudyConfig.to_toml` the whole file,
which :func:`nlid.study.config.parse_study` reads back to the same datasets.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from ...base.frozen import FrozenDict
from ..values import (
    SPEC_DEFAULTS,
    DataSource,
    Holdout,
    KnownMass,
    Mass,
    NoHoldout,
    PresetSource,
    Where,
    parse_holdout,
    parse_mass,
    plain,
    source_from_spec,
)
from .tomlio import dumps

__all__ = [
    "ModelConfig",
    "DatasetConfig",
    "StudyConfig",
    "DEFAULT_TIMEOUT",
    "MAIN_MODEL",
    "MAX_RUNS",
    "MAX_POSITION",
    "MAX_FREQUENCY",
]

#: Time limit of a run (s) when the study gives none.
DEFAULT_TIMEOUT = 600.0
#: The name of a dataset's own term set.
MAIN_MODEL = "main"
#: Most runs a study may plan (datasets x term sets x identifiers x repetitions).
MAX_RUNS = 20_000
#: Largest position (m) a study may name (slices, equilibria, px roots): a kilometre.
MAX_POSITION = 1e3
#: Highest natural frequency (Hz) a reference may give.
MAX_FREQUENCY = 1e7


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

    def to_toml(self) -> dict[str, Any]:
        """The term set's keys in a study file (``px_roots`` when given)."""
        out: dict[str, Any] = {"terms": self.terms, "without": self.without}
        if self.px_roots is not None:
            out["px_roots"] = list(self.px_roots)
        return out


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
        spec = {**plain(SPEC_DEFAULTS), **self.source.to_spec()}
        return {
            "name": self.name,
            "kind": spec["kind"],
            "source": spec["source"],
            "description": self.description,
            "part": spec["part"],
            "columns": spec["columns"],
            "fs": spec["fs"],
            "overrides": spec["overrides"],
            "noise": spec["noise"],
            "channels": spec["channels"],
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
        models = tuple(
            ModelConfig(
                m["name"], m["terms"], m.get("without", ""), None if m.get("px_roots") is None else tuple(m["px_roots"])
            )
            for m in data.get("models") or ()
        )
        return cls(
            name=data["name"],
            source=source_from_spec(data, where),
            description=data.get("description", ""),
            models=models,
            mass=parse_mass(data.get("mass", "known"), where / "mass"),
            holdout=parse_holdout(data.get("holdout", "none"), data["kind"], where / "holdout"),
            freerun=bool(data.get("freerun", True)),
            slices=tuple(float(x) for x in data.get("slices") or ()),
            repetitions=int(data.get("repetitions", 1)),
            timeout=float(data.get("timeout", DEFAULT_TIMEOUT)),
            methods=FrozenDict({k: FrozenDict(v) for k, v in (data.get("methods") or {}).items()}),
            reference=data.get("reference"),
            freerun_rule=str(data.get("freerun_rule") or ""),
        )

    def to_toml(self) -> dict[str, Any]:
        """The ``[[datasets]]`` entry of a study file, every value explicit (reads back to this entry)."""
        main, *others = self.models
        out: dict[str, Any] = {"name": self.name, "description": self.description, **self.source.to_toml()}
        out.update(main.to_toml())
        out.update(
            mass=self.mass.to_toml(),
            holdout=self.holdout.to_toml(),
            freerun=self.freerun,
            slices=list(self.slices),
            repetitions=self.repetitions,
            timeout=self.timeout,
            models={m.name: m.to_toml() for m in others},
            methods=plain(self.methods),
        )
        if self.freerun_rule:
            out["freerun_rule"] = self.freerun_rule
        if self.reference is not None:
            out["reference"] = plain(self.reference)
        return out


@dataclass(frozen=True)
class StudyConfig:
    """A validated study.

    Attributes
    ----------
    resolved
        True once :func:`~nlid.study.config.resolve_study` has checked it against the disk.
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
    response: dict[str, Any] | None = None

    @property
    def run_count(self) -> int:
        """How many runs the study plans."""
        return sum(len(d.models) * len(self.identifiers) * d.repetitions for d in self.datasets)

    def to_dict(self) -> dict[str, Any]:
        """The study as the tables of its TOML file, every value explicit.

        The identifiers are the list the study resolved to (``"all"`` becomes the names installed when it
        was read); the repetitions and time limits are each dataset's own; a file dataset's path is
        absolute. Nothing is left to a default, so the file means the same wherever it is read.
        """
        out: dict[str, Any] = {
            "study": {
                "name": self.name,
                "description": self.description,
                "seed": self.seed,
                "identifiers": list(self.identifiers),
            },
            "options": plain(self.options),
            "datasets": [d.to_toml() for d in self.datasets],
        }
        if self.posterior is not None:
            out["posterior"] = plain(self.posterior)
        if self.response is not None:
            out["response"] = plain(self.response)
        return out

    def to_toml(self) -> str:
        """The study written out as a TOML file (:meth:`to_dict`) that :func:`~nlid.study.load_study` reads back.

        Examples
        --------
        >>> from nlid.study import load_study, parse_study
        >>> study = load_study("paper-numerical")
        >>> parse_study(study.to_toml()).datasets == study.datasets
        True
        """
        return dumps(self.to_dict())
