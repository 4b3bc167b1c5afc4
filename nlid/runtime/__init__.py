"""Where nlid's runs execute: isolated children, the fork server that starts them, what it preloads.

:mod:`nlid.runtime.isolation`
    :func:`~nlid.runtime.isolation.run_in_child`: a function in a child
    process that is killed at its time limit and never outlives nlid.
:mod:`nlid.runtime.forkserver`
    imported first by the fork server: it dies with its parent and pins the
    numerical libraries to one thread per run.
:mod:`nlid.runtime.preload`
    imported last by the fork server: the plugins and the compiled kernels,
    loaded once for every run.

This package imports nothing itself: the fork server imports
:mod:`nlid.runtime.forkserver` before numpy is loaded.
"""
