"""Where plugin code runs: isolated children, the fork server that starts them, what it preloads.

:mod:`nlid.runtime.isolation`
    :func:`~nlid.runtime.isolation.run_in_child`: a function in a child
    process that is killed at its time limit, cannot take nlid down, and
    never outlives it; the start methods (``NLID_START_METHOD``: fork server
    or spawn).
:mod:`nlid.runtime.outcome`
    what became of a call in a child: :class:`~nlid.runtime.outcome.ChildResult`,
    the warnings it issued, :class:`~nlid.runtime.outcome.IsolationError`.
:mod:`nlid.runtime.forkserver`
    nlid's fork server (``python -m nlid.runtime.forkserver``): forks warm
    children on request over an anonymous socket pair.
:mod:`nlid.runtime.child`
    the child's side: runs the request, sends the reply, ends its process
    group (also ``python -m nlid.runtime.child``, the spawn start method).
:mod:`nlid.runtime.preload`
    what the fork server loads once for every run.
:mod:`nlid.runtime.memory`
    :class:`~nlid.runtime.memory.PeakMemory`: the peak memory a block adds,
    from the process's resident high-water mark where the system keeps one.

This package imports nothing itself: the fork server pins the numerical
libraries' threads before numpy is loaded.
"""
