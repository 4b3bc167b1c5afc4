"""The job protocol: the worker runs any :class:`nlid.study.job.Job` (a study's run, a bench job) by its methods."""

from __future__ import annotations

import ast
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from nlid.benchmarking.jobs import BenchJob, BenchRun
from nlid.study import parse_study, plan_study
from nlid.study.job import Job, Scheduled
from nlid.study.worker import execute_run, failure_payload, run_isolated

ROOT = Path(__file__).resolve().parents[2]


@dataclass(frozen=True)
class EchoJob:
    """A third kind of job, which the worker has never heard of."""

    run_id: str = "echo/1"
    timeout: float = 30.0
    label: str = "job 'echo/1'"

    def execute(self, threads: int = 1) -> dict[str, Any]:
        return {"run_id": self.run_id, "row": {"status": "ok", "error": "", "threads": threads}, "result": None}

    def failure(self, status: str, error: str) -> dict[str, Any]:
        return {"run_id": self.run_id, "row": {"status": status, "error": error}, "result": None}


def test_a_study_run_and_a_bench_job_are_jobs(small_study, registry):
    spec = plan_study(parse_study(small_study('["rfs"]', repetitions=1), registry=registry))[0].spec
    bench = BenchJob("silverbox/rfs", "silverbox", "", ())
    assert isinstance(spec, Job) and isinstance(bench, Job) and isinstance(EchoJob(), Job)
    assert spec.label == "identifier 'rfs'" and bench.label == "job 'silverbox/rfs'"
    failed = failure_payload(spec, "timeout", "stopped")
    assert failed["row"]["status"] == "timeout" and failed["row"]["method"] == "rfs"  # the study's own row
    assert failure_payload(bench, "failed", "x")["row"]["benchmark"] == "silverbox"


def test_the_executors_and_the_store_see_both_kinds_as_scheduled(small_study, registry):
    run = plan_study(parse_study(small_study('["rfs"]', repetitions=1), registry=registry))[0]
    bench = BenchRun.of(BenchJob("silverbox/rfs", "silverbox", "", ()))
    for scheduled in (run, bench):
        assert isinstance(scheduled, Scheduled) and isinstance(scheduled.spec, Job)
        assert scheduled.run_id == scheduled.spec.run_id and scheduled.digest


def test_the_worker_runs_any_job_by_the_protocol():
    assert execute_run(EchoJob(), threads=2)["row"]["threads"] == 2
    payload = run_isolated(EchoJob())  # in a child, as a study's run
    assert payload["row"] == {"status": "ok", "error": "", "threads": 1}


def test_the_worker_knows_no_kind_of_job():
    """No ``isinstance`` on a job in the worker, and no import of the plan or of the bench."""
    tree = ast.parse((ROOT / "nlid/study/worker.py").read_text())
    checked = [
        n.args[1] for n in ast.walk(tree) if isinstance(n, ast.Call) and getattr(n.func, "id", "") == "isinstance"
    ]
    assert not any("Spec" in ast.unparse(c) or "Job" in ast.unparse(c) for c in checked)
    imported = {n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and n.module}
    assert not imported & {"plan", "run", "benchmarking", "benchmarking.jobs"}
