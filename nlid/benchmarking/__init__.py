"""``nlid bench`` (``nlid.bench()``): nlid's pipelines on the measured benchmarks, under the benchmarks' own protocols.

A benchmark is declared as data (:mod:`nlid.benchmarking.protocol`; the built-in files are
``nlid/benchmarking/protocols/*.toml``): its estimation part, its test sets with their transient rules
(an initialisation window, periodic steady state, from the first sample), the metric and unit,
and the published figures with their source, rule and how they were verified. :func:`bench`
runs pipelines (identifiers by name, nlid's ``linear`` model, ``discover``, ``discover --refine``,
the peers ``pysindy``, ``sysidentpy`` and ``linear-ss``, the ``truth`` where known) on each
benchmark through the study executors, persisting each job as it finishes, and writes a
leaderboard (CSV, Markdown, a sortable HTML page, a figure per test set) with nlid's rows beside
the peers', the published ones and the true model's, each row saying what it knew
(:mod:`nlid.benchmarking.prior`).

The test sets never take part in a decision: a pipeline is given the estimation part only
(:func:`nlid.benchmarking.pipelines.fit_pipelines`), the test sets are read after it has finished.

Example::

    import nlid

    outcome = nlid.bench(["silverbox", "bouc-wen"], ["rfs", "discover", "pysindy"], out="bench-out", jobs=2)
    print(outcome.frame()[["benchmark", "test", "pipeline", "rmse", "unit", "rule"]])
"""

from .data import SOURCES, load_estimation, load_test
from .declarations import Protocol, Published, TestSet
from .jobs import BenchJob, BenchRun
from .leaderboard import COLUMNS, leaderboard_rows, write_leaderboard
from .pipelines import PEERS, PipelineSpec, fit_pipelines, parse_pipelines
from .prior import Prior
from .protocol import builtin_benchmarks, load_protocol, parse_protocol
from .run import BENCH_OUTPUTS, DEFAULT_BENCHMARKS, DEFAULT_PIPELINES, BenchOutcome, bench, default_pipelines

__all__ = [
    "bench",
    "BenchOutcome",
    "BENCH_OUTPUTS",
    "DEFAULT_BENCHMARKS",
    "DEFAULT_PIPELINES",
    "default_pipelines",
    "Protocol",
    "TestSet",
    "Published",
    "load_protocol",
    "parse_protocol",
    "builtin_benchmarks",
    "load_estimation",
    "load_test",
    "SOURCES",
    "PipelineSpec",
    "PEERS",
    "Prior",
    "parse_pipelines",
    "fit_pipelines",
    "BenchJob",
    "BenchRun",
    "COLUMNS",
    "leaderboard_rows",
    "write_leaderboard",
]
