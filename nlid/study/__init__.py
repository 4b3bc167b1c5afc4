"""Benchmark studies: score every installed identifier on the same data.

A study (a TOML file, :mod:`nlid.study.config`) is datasets x models x
identifiers x repetitions. :func:`plan_study` expands it into runs with stable
ids and seeds derived from the study seed and the run id; an executor
(:mod:`nlid.study.execute`: local processes or Dask) runs each in its own
child process with a time limit (:mod:`nlid.study.worker`); each finished run
is persisted at once (:mod:`nlid.study.store`) and scored
(:mod:`nlid.study.metrics`); the outputs (results.csv, summary.md, figures,
report.html) are written by :mod:`nlid.study.report`.

Example::

    from nlid.study import load_study, run_study
    outcome = run_study(load_study("paper-numerical"), "out/paper-numerical")
    print(outcome.summary)
"""

from .config import ConfigError, StudyConfig, builtin_studies, load_study, parse_study
from .execute import DaskExecutor, LocalExecutor, make_executor
from .plan import Run, derive_seed, plan_study
from .runner import StudyOutcome, run_study
from .store import ResultStore

__all__ = [
    "ConfigError",
    "StudyConfig",
    "builtin_studies",
    "load_study",
    "parse_study",
    "plan_study",
    "derive_seed",
    "Run",
    "run_study",
    "StudyOutcome",
    "ResultStore",
    "LocalExecutor",
    "DaskExecutor",
    "make_executor",
]
