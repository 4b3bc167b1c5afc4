"""``scipy.signal.lfilter`` without importing ``scipy.signal``.

nsi-ip filters its regressors (the B step's all-pole part, the impulse
responses of the noise correction, the clean-force surrogate) with
``scipy.signal.lfilter``, whose arithmetic is the compiled
``scipy.signal._sigtools._linear_filter``. Importing ``scipy.signal`` costs
~0.5 s and ~40 MB (it imports ``scipy.stats``) in a process that does not
have it yet, which is every ``nlid identify`` child (docs/performance.md,
round four). So :func:`lfilter` loads that one compiled module by its file,
without the package ``scipy.signal`` (0.2 ms), and calls it exactly as
``scipy.signal.lfilter`` does for a filter with ``len(a) > 1``: the same
arrays to the bit (tests/plugins/test_nsi_filters.py). ``_sigtools`` is a
private module of scipy: if it cannot be found or loaded (another scipy
layout), :func:`lfilter` is ``scipy.signal.lfilter`` itself.
"""

from __future__ import annotations

import importlib.machinery
import importlib.util
import os
from collections.abc import Callable
from typing import Any

import numpy as np

__all__ = ["lfilter", "lfiltic_output"]

_LINEAR_FILTER: list[Callable[..., Any] | None] = []


def _linear_filter() -> Callable[..., Any] | None:
    """``scipy.signal._sigtools._linear_filter`` loaded from its file, or ``None`` (cached)."""
    if not _LINEAR_FILTER:
        func = None
        try:
            import scipy

            folder = os.path.join(os.path.dirname(scipy.__file__), "signal")
            suffixes = tuple(importlib.machinery.EXTENSION_SUFFIXES)
            files = [f for f in os.listdir(folder) if f.startswith("_sigtools.") and f.endswith(suffixes)]
            if files:
                name = f"{__package__ or 'nlid_nsi'}._sigtools"  # the module's init is found by the last part
                path = os.path.join(folder, files[0])
                loader = importlib.machinery.ExtensionFileLoader(name, path)
                spec = importlib.util.spec_from_file_location(name, path, loader=loader)
                if spec is not None:
                    module = importlib.util.module_from_spec(spec)
                    loader.exec_module(module)
                    func = getattr(module, "_linear_filter", None)
        except (ImportError, OSError, AttributeError):
            func = None
        _LINEAR_FILTER.append(func)
    return _LINEAR_FILTER[0]


def lfilter(b: Any, a: np.ndarray, x: np.ndarray, axis: int = -1, zi: np.ndarray | None = None) -> Any:
    """``scipy.signal.lfilter(b, a, x, axis, zi)`` for float64 data and ``len(a) > 1``.

    Parameters
    ----------
    b, a
        Numerator and denominator (1-D, ``a`` of at least two coefficients).
    x
        Data (float64).
    axis
        Axis along which to filter.
    zi
        Initial state (shape of ``x`` with ``max(len(a), len(b)) - 1`` along
        ``axis``), or ``None`` for a zero state.

    Returns
    -------
    y, or (y, zf) when ``zi`` is given
        As ``scipy.signal.lfilter``.
    """
    b = np.atleast_1d(np.asarray(b, dtype=float))
    a = np.atleast_1d(np.asarray(a, dtype=float))
    func = _linear_filter() if len(a) > 1 else None
    if func is None:
        from scipy import signal

        return signal.lfilter(b, a, x, axis=axis) if zi is None else signal.lfilter(b, a, x, axis=axis, zi=zi)
    x = np.asarray(x, dtype=float)
    if zi is None:
        return func(b, a, x, axis)
    return func(b, a, x, axis, np.asarray(zi, dtype=float))


def lfiltic_output(a: np.ndarray, y_prev: float) -> np.ndarray:
    """``scipy.signal.lfiltic([1.0], a, [y_prev])``: the state of ``1 / a`` after the output ``y_prev`` at ``t = -1``.

    With a numerator of one tap the state is ``-a[1:] * y_prev / a[0]`` (the
    same products and the same division as ``lfiltic``).
    """
    a = np.asarray(a, dtype=float)
    zi = -(a[1:] * float(y_prev))
    if a[0] != 1.0:
        zi = zi / a[0]
    return zi
