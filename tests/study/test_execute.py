"""Executing studies: failures and hangs are recorded, runs are isolated, executors agree."""

from __future__ import annotations

import pandas as pd
import pytest

from nlid.study import DaskExecutor, LocalExecutor, ResultStore, parse_study, plan_study, run_study
from nlid.study.worker import execute_run, run_isolated

#: Columns that measure the machine, not the result.
MACHINE = ["seconds", "method_seconds", "peak_memory_mb"]


def test_failing_hanging_and_dying_identifiers_are_recorded_and_the_study_goes_on(small_study, registry, tmp_path):
    # the limit must leave rfs time to finish on a loaded 2-core CI machine; "hang" never finishes
    text = small_study('["rfs", "crash", "hang", "die"]', repetitions=1, timeout=12)
    config = parse_study(text, registry=registry)
    outcome = run_study(config, tmp_path / "out", executor=LocalExecutor(jobs=2), progress=False)
    frame = pd.read_csv(tmp_path / "out" / "results.csv").set_index("method")
    assert frame.loc["rfs", "status"] == "ok" and abs(frame.loc["rfs", "coef_error_pct:z^3"]) < 1
    assert frame.loc["crash", "status"] == "failed"
    assert "identifier 'crash' raised RuntimeError: deliberate failure" in frame.loc["crash", "error"]
    assert frame.loc["hang", "status"] == "timeout"
    assert "time limit of 12 s" in frame.loc["hang", "error"]
    assert frame.loc["die", "status"] == "failed" and "exit code 3" in frame.loc["die", "error"]
    summary = outcome.summary
    assert "| hang | 0/1 (1 timed out) |" in summary and "| crash | 0/1 (1 failed) |" in summary
    assert "hang r0: timeout: stopped after the time limit of 12 s" in summary


def test_a_hung_run_is_killed_at_its_time_limit(small_study, registry):
    run = plan_study(parse_study(small_study('["hang"]', repetitions=1), registry=registry))[0]
    payload = run_isolated(run.spec, timeout=1.5)
    assert payload["row"]["status"] == "timeout"


def test_subprocess_child_gives_the_same_result_as_the_forked_one(small_study, registry):
    """The spawn start method (Windows, NLID_START_METHOD=spawn) gives what the fork server gives."""
    from threadpoolctl import threadpool_limits

    run = plan_study(parse_study(small_study('["rfs"]', repetitions=1), registry=registry))[0]
    forked = run_isolated(run.spec)
    child = run_isolated(run.spec, use_subprocess=True)
    with threadpool_limits(1):  # as in the run children: one BLAS thread (more change the last digit of sums)
        inline = execute_run(run.spec)
    for payload in (forked, child):
        assert payload["row"]["status"] == "ok", payload["row"]["error"]
        assert payload["result"]["coefficients"] == inline["result"]["coefficients"]
        assert {k: v for k, v in payload["row"].items() if k not in MACHINE} == {
            k: v for k, v in inline["row"].items() if k not in MACHINE
        }
    hung = run_isolated(
        plan_study(parse_study(small_study('["hang"]', repetitions=1), registry=registry))[0].spec,
        timeout=1.5,
        use_subprocess=True,
    )
    assert hung["row"]["status"] == "timeout"


@pytest.mark.slow
def test_local_and_dask_local_cluster_give_identical_results(small_study, registry, tmp_path):
    pytest.importorskip("distributed")
    config = parse_study(small_study('["rfs", "echo"]', repetitions=2), registry=registry)
    run_study(config, tmp_path / "local", executor=LocalExecutor(jobs=2), progress=False, report=False)
    run_study(config, tmp_path / "dask", executor=DaskExecutor(jobs=2), progress=False, report=False)
    frames = []
    for name in ("local", "dask"):
        frame = ResultStore(tmp_path / name).results(plan_study(config)).drop(columns=MACHINE)
        frames.append(frame.sort_values("run_id").reset_index(drop=True))
    assert len(frames[0]) == 4 and (frames[0]["status"] == "ok").all()
    pd.testing.assert_frame_equal(frames[0], frames[1], check_exact=True)
