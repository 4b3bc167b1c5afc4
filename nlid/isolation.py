"""Moved to :mod:`nlid.runtime.isolation`; this name keeps working."""

from .runtime.isolation import (
    FORKSERVER_ENV,
    PARENT_ENV,
    PRELOAD,
    ChildResult,
    describe_exit,
    die_with_parent,
    kill_children,
    run_in_child,
    start_fork_server,
    track,
    untrack,
)

__all__ = [
    "ChildResult",
    "run_in_child",
    "kill_children",
    "die_with_parent",
    "describe_exit",
    "start_fork_server",
    "track",
    "untrack",
    "PARENT_ENV",
    "FORKSERVER_ENV",
    "PRELOAD",
]
