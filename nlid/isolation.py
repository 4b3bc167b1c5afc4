"""Moved to :mod:`nlid.runtime.isolation`; this name keeps working."""

from .runtime.isolation import (
    FORKSERVER_ENV,
    PARENT_ENV,
    PRELOAD,
    START_METHOD_ENV,
    ChildResult,
    IsolationError,
    PluginWarning,
    describe_exit,
    die_with_parent,
    kill_children,
    run_in_child,
    start_fork_server,
    start_method,
    track,
    untrack,
)

__all__ = [
    "ChildResult",
    "IsolationError",
    "PluginWarning",
    "run_in_child",
    "kill_children",
    "die_with_parent",
    "describe_exit",
    "start_fork_server",
    "start_method",
    "track",
    "untrack",
    "START_METHOD_ENV",
    "PARENT_ENV",
    "FORKSERVER_ENV",
    "PRELOAD",
]
