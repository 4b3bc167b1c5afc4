"""``nlid.bench()``: pipelines on benchmarks under their protocols, persisted as they finish, and the leaderboard."""

from __future__ import annotations

import json
import os
import sys
import time
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TextIO

from ..base.jsonable import to_jsonable
from ..errors import InputError
from .data import SOURCES, check_user_files
from .declarations import Protocol
from .jobs import BenchJob, BenchRun
from .leaderboard import leaderboard_rows, write_leaderboard
from .pipelines import PipelineSpec, parse_pipelines
from .protocol import load_protocol

__all__ = [
    "bench",
    "BenchOutcome",
    "BENCH_OUTPUTS",
    "DEFAULT_BENCHMARKS",
    "DEFAULT_PIPELINES",
    "default_pipelines",
    "plan_bench",
]

#: Entries ``nlid bench`` writes at the top of its output folder (:func:`nlid.runtime.outputs.output_folder`).
BENCH_OUTPUTS = ("runs", "arrays", "figures", "bench.json", "leaderboard.csv", "leaderboard.md", "leaderboard.html")
#: The benchmarks run when none is named (those whose data ``nlid data`` lists, with their local test sets).
DEFAULT_BENCHMARKS = ("emps-internal", "silverbox", "bouc-wen")
#: The pipelines run when none is named, after the default identifier (:func:`default_pipelines`): nlid's
#: linear model and discovery, the peers (``sysidentpy`` only where installed) and the true model where known.
DEFAULT_PIPELINES = ("linear", "discover", "discover-refine", "pysindy", "sysidentpy", "linear-ss", "truth")


def default_pipelines() -> tuple[str, ...]:
    """The pipelines run when none is named: the default identifier (:func:`nlid.contract.methods.choose_method`;
    ``rfs`` with the built-in plugins) and :data:`DEFAULT_PIPELINES`."""
    from ..contract.methods import choose_method

    name, _ = choose_method(None)
    return (name, *DEFAULT_PIPELINES)


#: Expected relative cost of a job (longest first: the executors start jobs in order).
_COST = {"discover": 3, "peer": 1, "identify": 1, "linear": 1, "truth": 0}


@dataclass
class BenchOutcome:
    """What :func:`bench` did and where the outputs are.

    Attributes
    ----------
    folder
        The output folder.
    rows
        The leaderboard rows (:data:`nlid.benchmarking.leaderboard.COLUMNS`).
    runs
        The jobs of this bench.
    executed, skipped
        Jobs run now, and found done from an earlier session.
    seconds
        Wall time of this call.
    paths
        ``leaderboard.csv``, ``.md``, ``.html`` and ``bench.json``.
    """

    folder: Path
    rows: list[dict[str, Any]]
    runs: list[BenchRun]
    executed: int
    skipped: int
    seconds: float
    paths: list[Path]

    def frame(self) -> Any:
        """The leaderboard as a pandas DataFrame."""
        import pandas as pd

        return pd.DataFrame(self.rows)


def _load_average() -> float:
    try:
        return float(os.getloadavg()[0])
    except (AttributeError, OSError):  # pragma: no cover - not Unix
        return float("nan")


def _cores() -> int:
    from ..study.execute import default_jobs

    return default_jobs()


def _names(value: str | Iterable[str]) -> list[str]:
    items = value.split(",") if isinstance(value, str) else list(value)
    return [i.strip() for i in items if i.strip()]


def plan_bench(
    protocols: Mapping[str, Protocol],
    pipelines: list[PipelineSpec],
    *,
    source: str = "auto",
    files: Mapping[str, str] | None = None,
    timeout: float = 1800.0,
) -> list[BenchRun]:
    """The jobs: one per benchmark and pipeline (``discover`` and ``discover --refine`` run their own searches).

    Longest first (discoveries, then the rest), so a pool of workers finishes early.
    """
    runs: list[tuple[int, BenchRun]] = []
    for p in protocols.values():
        for group in ((s,) for s in pipelines):
            job = BenchJob.make(p, group, source=source, files=files, timeout=timeout)
            runs.append(
                (-sum(_COST[s.kind] for s in group) - (2 if any(s.refine for s in group) else 0), BenchRun.of(job))
            )
    runs.sort(key=lambda item: item[0])  # stable: benchmark order within a cost
    return [r for _, r in runs]


def bench(
    benchmarks: str | Iterable[str] = DEFAULT_BENCHMARKS,
    pipelines: str | Iterable[str] | None = None,
    *,
    out: str | Path = "bench",
    jobs: int | None = None,
    executor: str = "local",
    scheduler: str | None = None,
    source: str = "auto",
    files: Mapping[str, str] | None = None,
    timeout: float = 1800.0,
    rerun: bool = False,
    progress: bool | None = None,
    log: TextIO | None = None,
    force: bool = False,
) -> BenchOutcome:
    """Run pipelines on benchmarks under their declared protocols and write the leaderboard.

    Each pipeline sees only the benchmark's estimation part (structure, thresholds and stopping
    are decided on it, ``discover``'s hold-out is its end); after structure selection the final
    model is refitted on the whole estimation part; then every test set is scored under its
    declared transient rule. Jobs (a benchmark and its pipelines) run in their own processes
    through the study executors (local or Dask), are persisted as they finish, and a second
    call with the same arguments resumes: finished jobs are not run again.

    Parameters
    ----------
    benchmarks
        Built-in names (``emps``, ``emps-internal``, ``silverbox``, ``bouc-wen``) or paths of
        benchmark files (:mod:`nlid.benchmarking.protocol`).
    pipelines
        Installed identifiers by name, ``"discover"``, ``"discover-refine"``, ``"pysindy"``
        (default :func:`default_pipelines`).
    out
        Output folder (:data:`BENCH_OUTPUTS`; created; nlid writes only into folders it owns).
    jobs
        Concurrent jobs (default: every core).
    executor, scheduler
        ``"local"`` or ``"dask"`` (and a Dask scheduler address), as for studies.
    source
        Where the data come from: ``"auto"``, ``"local"`` or ``"package"`` (:mod:`nlid.benchmarking.data`).
    files
        User-supplied sets, ``{"BENCHMARK:TEST": path}``, e.g. ``{"bouc-wen:multisine": "uval_multisine.mat"}``.
    timeout
        Seconds before a job is stopped.
    rerun
        Run every job again.
    progress
        Show a progress line (default: on a terminal).
    log
        Where status lines go (default ``sys.stderr``).
    force
        Write into a folder holding files nlid did not write (never replacing them).

    Returns
    -------
    BenchOutcome

    Raises
    ------
    InputError
        An unknown benchmark, pipeline, source or executor; a user file for an unknown set.
    """
    from ..runtime.outputs import output_folder
    from ..study.execute import make_executor
    from ..study.runner import Progress
    from ..study.store import ResultStore

    start = time.perf_counter()
    load_start = _load_average()
    log = log if log is not None else sys.stderr
    if source not in SOURCES:
        raise InputError(f"source= must be one of {', '.join(SOURCES)}, got {source!r}")
    protocols: dict[str, Protocol] = {}
    for name in _names(benchmarks):
        p = load_protocol(name)
        if p.name in protocols:
            raise InputError(f"benchmark {p.name!r} is named twice")
        protocols[p.name] = p
    if not protocols:
        raise InputError("benchmarks= names no benchmark")
    specs = parse_pipelines(default_pipelines() if pipelines is None else pipelines)
    checked = check_user_files(protocols, dict(files or {}))
    runs = plan_bench(protocols, specs, source=source, files=checked, timeout=timeout)
    runner = make_executor(executor, jobs=jobs, scheduler=scheduler)
    with output_folder(out, BENCH_OUTPUTS, force=force) as folder:
        store = ResultStore(folder)
        todo = runs if rerun else [r for r in runs if not store.is_done(r)]
        skipped = len(runs) - len(todo)
        log.write(
            f"nlid bench: {len(runs)} job(s) ({len(protocols)} benchmark(s): {', '.join(protocols)}; pipelines: "
            f"{', '.join(s.name for s in specs)}), {skipped} already done, {len(todo)} to run with the "
            f"{runner.name} executor; results in {folder}\n"
        )
        bar = Progress(len(todo), label="nlid bench: ", stream=log, enabled=progress)

        def on_done(run: Any, payload: dict[str, Any]) -> None:
            store.save(run, payload)
            status = payload["row"]["status"]
            bar.update(failed=status != "ok")
            if status != "ok" and not bar.enabled:
                log.write(f"nlid bench: {run.run_id}: {status}: {payload['row'].get('error', '')}\n")

        try:
            runner.run(todo, on_done)
        finally:
            bar.close()
        records = store.records(runs)
        rows = leaderboard_rows(protocols, records)
        paths = write_leaderboard(folder, protocols, rows)
        details = {
            "benchmarks": list(protocols),
            "pipelines": [s.name for s in specs],
            "source": source,
            "arguments": {
                "jobs": jobs,
                "executor": executor,
                "source": source,
                "files": {key: Path(path).name for key, path in checked.items()},
            },
            "run": {
                "seconds": time.perf_counter() - start,
                "executed": len(todo),
                "skipped": skipped,
                "jobs": jobs,
                "cores": _cores(),
                "load_average": [load_start, _load_average()],
            },
            "jobs": [
                {
                    "run_id": r["run_id"],
                    **{k: v for k, v in (r.get("result") or {}).items() if k != "rows"},
                    "status": r["row"].get("status"),
                    "error": r["row"].get("error", ""),
                }
                for r in records
            ],
        }
        path = folder / "bench.json"
        path.write_text(json.dumps(to_jsonable(details), indent=1, allow_nan=False) + "\n")
        paths.append(path)
    return BenchOutcome(folder, rows, runs, len(todo), skipped, time.perf_counter() - start, paths)
