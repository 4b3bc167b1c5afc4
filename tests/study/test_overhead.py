"""The study's fixed costs beside the identification: cut without changing a number (issue 36)."""

from __future__ import annotations

import threading

import numpy as np
import pytest

from nlid.runtime import parallel
from nlid.study import parse_study, plan_study
from nlid.study.worker import run_isolated

#: Columns that measure the machine, not the result.
MACHINE = ["seconds", "method_seconds", "peak_memory_mb"]
#: An independent held-out record, so that the run has a free run and its chaos check.
HELD_OUT = 'mass = "known"\nholdout = "independent"'


def test_both_gives_the_results_in_order_and_raises_the_first_error_first():
    threads = []

    def record(value):
        def call():
            threads.append(threading.current_thread().name)
            return value

        return call

    def fail(message):
        def call():
            raise ValueError(message)

        return call

    for budget in (1, 2):
        with parallel.thread_budget(budget):
            assert parallel.both(record("a"), record("b")) == ("a", "b")
            with pytest.raises(ValueError, match="first"):
                parallel.both(fail("first"), fail("second"))
            with pytest.raises(ValueError, match="second"):
                parallel.both(record(1), fail("second"))
    assert len(set(threads)) == 2  # with a budget of two the second call ran on a thread of its own
    assert not [t for t in threading.enumerate() if t.name == "nlid-both"]  # every thread joined


def test_a_run_given_two_threads_stores_the_same_row_and_result(small_study, registry):
    """The free run and its chaos check at once (LocalExecutor with fewer runs than cores): the same numbers."""
    run = plan_study(parse_study(small_study('["rfs"]', repetitions=1, extra=HELD_OUT), registry=registry))[0]
    one = run_isolated(run.spec, threads=1)
    two = run_isolated(run.spec, threads=2)
    for payload in (one, two):
        assert payload["row"]["status"] == "ok", payload["row"]["error"]
    assert np.isfinite(one["row"]["freerun_nrmse_pct"])
    assert one["result"]["coefficients"] == two["result"]["coefficients"]
    assert {k: v for k, v in one["row"].items() if k not in MACHINE} == {
        k: v for k, v in two["row"].items() if k not in MACHINE
    }
