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
    preset = "paper-numerical"     # or: dataset = "emps" (nlid.data.datasets), or: file = "x.csv"
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

    [posterior]                    # optional: nlid.bayes.posterior_metrics(..., **options)
    draws = 2000

    [response]                     # optional: each fit's frequency response against the reference's
    force = [0.5, 1.0]             # amplitudes (N) of the harmonic force
    band = [5.0, 30.0]             # Hz
    harmonics = 7

Everything is checked before any run starts: :func:`parse_study` validates
the text (unknown keys in every table, the ``[posterior]`` table's keys and
values, numbers that are not finite, negative or absurd, terms, presets and
their overrides, identifiers and their options, and the number of runs, at
most :data:`MAX_RUNS`) into typed values (:mod:`nlid.study.values`);
:func:`resolve_study` is the one step that touches the disk (files exist and
read, benchmark parts load, a "known" mass is known). :func:`load_study`
does both. Each problem is one :class:`ConfigError` naming the file, the key
and, where one exists, a suggestion.

A parsed study writes itself back out (:meth:`StudyConfig.to_toml`): every
value explicit, the identifiers as the list they resolved to. Reading that
text again gives the same datasets, and so the same runs with the same seeds.

The package holds one job per module:

=================================  =============================================================
:mod:`~nlid.study.config.schema`   the typed study (:class:`StudyConfig`, :class:`DatasetConfig`,
                                   :class:`ModelConfig`) and its limits, written back as TOML
:mod:`~nlid.study.config.parse`    :func:`parse_study`: TOML text to a typed study, nothing read
:mod:`~nlid.study.config.load`     :func:`resolve_study` (the disk) and :func:`load_study`
:mod:`~nlid.study.config.builtin`  the built-in studies (:func:`builtin_studies`)
:mod:`~nlid.study.config.tomlio`   ``tomllib`` and :func:`~nlid.study.config.tomlio.dumps`
=================================  =============================================================
"""

from __future__ import annotations

from .builtin import BUILTIN_PACKAGE_DIR, builtin_dirs, builtin_studies, resolve_study_path
from .load import TRIAL_SECONDS, load_study, resolve_study
from .parse import parse_study
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

__all__ = [
    "DatasetConfig",
    "ModelConfig",
    "StudyConfig",
    "load_study",
    "parse_study",
    "resolve_study",
    "builtin_studies",
    "builtin_dirs",
    "resolve_study_path",
    "MAX_RUNS",
    "MAX_POSITION",
    "MAX_FREQUENCY",
    "DEFAULT_TIMEOUT",
    "MAIN_MODEL",
    "BUILTIN_PACKAGE_DIR",
    "TRIAL_SECONDS",
    "tomllib",
]
