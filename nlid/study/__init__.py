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

The names below are loaded on first use (as :mod:`nlid`'s are): importing
one submodule, e.g. the worker a child process runs, does not import the
runner, the executors and the report with it, and no submodule depends on
this package's namespace.
"""

from __future__ import annotations

from ..base.lazy import lazy_face

#: Public name -> module that defines it (imported on first access).
_LAZY: dict[str, str] = {
    "ConfigError": "nlid.study.values",
    "StudyConfig": "nlid.study.config",
    "builtin_studies": "nlid.study.config",
    "load_study": "nlid.study.config",
    "parse_study": "nlid.study.config",
    "plan_study": "nlid.study.plan",
    "derive_seed": "nlid.study.plan",
    "Run": "nlid.study.plan",
    "run_study": "nlid.study.runner",
    "StudyOutcome": "nlid.study.runner",
    "ResultStore": "nlid.study.store",
    "LocalExecutor": "nlid.study.execute",
    "DaskExecutor": "nlid.study.execute",
    "make_executor": "nlid.study.execute",
}

__all__ = list(_LAZY)


__getattr__, __dir__ = lazy_face(__name__, _LAZY, __all__)
