"""Jobs for tests/study/test_overlap.py, importable by a run child (this folder is on ``sys.path``).

A :class:`Gate` marks its start, notifies ``"identified"`` as a study run does after its identification,
then waits (at most :data:`WAIT` seconds) for the next job to have started. No time is asserted: the files
say what happened in which order.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

from nlid.runtime.child import notify

#: Longest wait of a gate job for the next one (seconds): reached only when the runs do not overlap.
WAIT = 60.0


class Gate:
    """A job that marks its start, notifies "identified", then waits for the next job to start."""

    def __init__(self, index, folder, last, fail=""):
        self.index, self.folder, self.last, self.fail = index, Path(folder), last, fail

    run_id = property(lambda self: f"gate-{self.index}")
    label = property(lambda self: self.run_id)
    timeout = property(lambda self: 120.0)

    def execute(self, threads=1):
        # the previous job has identified when this one starts: one identification at a time
        previous = self.index == 0 or (self.folder / f"{self.index - 1}.identified").exists()
        (self.folder / f"{self.index}.started").touch()
        (self.folder / f"{self.index}.identified").touch()
        notify("identified")
        overlapped = self.index == self.last
        deadline = time.monotonic() + WAIT
        while not overlapped and time.monotonic() < deadline:
            overlapped = (self.folder / f"{self.index + 1}.started").exists()
            time.sleep(0.005)
        if self.fail == "raise":
            raise ValueError("deliberate failure in the scores")
        if self.fail == "die":
            os._exit(5)
        return {
            "run_id": self.run_id,
            "row": {
                "status": "ok",
                "warnings": "",
                "error": "",
                "previous_identified": previous,
                "overlapped": overlapped,
            },
        }

    def failure(self, status, error):
        return {"run_id": self.run_id, "row": {"status": status, "error": error, "warnings": ""}}


class Scheduled:
    def __init__(self, spec):
        self.spec, self.run_id, self.digest = spec, spec.run_id, spec.run_id


def notified(tag):
    notify(tag)
    return 7
