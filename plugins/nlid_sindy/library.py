"""A pysindy feature library that speaks nlid's term language.

:class:`TermLibrary` turns an :class:`nlid.model.terms.Model` into a pysindy
feature library, so that SINDy is given exactly the terms the user wrote for
every other method. Its inputs are the columns pysindy passes to a library:
the state ``[z, v]`` followed by the control inputs (the force). Its outputs
are the model's columns ``g_i(z, v)`` in model order, then every control
column unchanged.

Filtered (weak) form
    Given ``fs`` and ``cutoff``, each model column is low-passed with nlid's
    shared zero-phase filter (:func:`nlid.signal.derivatives.lowpass`) after being
    evaluated. Together with a force and an acceleration passed through the
    same filter (:func:`nlid.model.physics.regression_data`), this states the
    equation of motion in the filter band, where the estimated derivatives
    are accurate, instead of sample by sample - the same idea as pysindy's
    weak-form libraries, with nlid's filter as the test function. The filter
    needs the whole record, so give the library every sample: it returns NaN
    rows (every feature, the controls included) within
    ``nlid.model.physics.EDGE_PERIODS`` cut-off periods of either end of each
    trajectory, where the filter has not settled, and pysindy's optimizers
    drop those rows - the samples :func:`nlid.model.physics.regression_data` trims.

:func:`auto_candidates` lists the terms of the automatic candidate library.
"""

from __future__ import annotations

import numpy as np
from pysindy.feature_library.base import BaseFeatureLibrary, x_sequence_or_item
from pysindy.utils import AxesArray, comprehend_axes
from sklearn.utils.validation import check_is_fitted

from nlid.plugin import EDGE_PERIODS, Model, derivatives

__all__ = ["TermLibrary", "auto_candidates", "AUTO_DAMPING"]

#: Velocity-dependent candidates of the automatic library: viscous, quadratic
#: and cubic damping, Coulomb friction and two position-dependent (van der
#: Pol-type) dampings.
AUTO_DAMPING: tuple[str, ...] = ("v", "v*|v|", "v^3", "sign(v)", "z*v", "z^2*v")


def auto_candidates(degree: int) -> list[str]:
    """Terms of the automatic candidate library.

    Parameters
    ----------
    degree
        Highest power of the polynomial stiffness ``1, z, ..., z^degree``.

    Returns
    -------
    list of str
        The stiffness polynomial followed by :data:`AUTO_DAMPING`.
    """
    if degree < 1:
        raise ValueError(f"the automatic library needs a stiffness degree >= 1, got {degree}")
    return ["1", "z", *(f"z^{k}" for k in range(2, degree + 1)), *AUTO_DAMPING]


class TermLibrary(BaseFeatureLibrary):
    """pysindy feature library evaluating the columns of an nlid model.

    Parameters
    ----------
    model
        The terms (``px(z)`` roots set if a term uses them).
    fs
        Sampling frequency in Hz (needed with ``cutoff``).
    cutoff
        Low-pass the model columns at this frequency (Hz) with nlid's shared
        zero-phase filter, and leave the unsettled rows at each end NaN;
        ``None`` evaluates them sample by sample.

    Notes
    -----
    Inputs are ``[z, v, u_0, u_1, ...]``: the first two columns are the
    state, the rest control inputs passed through as features.
    """

    def __init__(self, model: Model, fs: float | None = None, cutoff: float | None = None):
        self.model = model
        self.fs = fs
        self.cutoff = cutoff

    @x_sequence_or_item
    def fit(self, x_full, y=None):
        """Record the number of inputs and outputs."""
        n_in = int(x_full[0].shape[x_full[0].ax_coord])
        if n_in < 2:
            raise ValueError(f"TermLibrary needs the state [z, v] as its first two inputs, got {n_in} input(s)")
        if self.cutoff is not None and self.fs is None:
            raise ValueError("TermLibrary: a cutoff needs the sampling frequency fs")
        self.n_features_in_ = n_in
        self.n_output_features_ = len(self.model) + n_in - 2
        return self

    @x_sequence_or_item
    def transform(self, x_full):
        """Evaluate the model columns (and pass the controls through)."""
        check_is_fitted(self)
        out = []
        for x in x_full:
            arr = np.asarray(x)
            if arr.ndim != 2 or arr.shape[1] != self.n_features_in_:
                raise ValueError(f"TermLibrary expects samples x {self.n_features_in_} inputs, got shape {arr.shape}")
            G = self.model.evaluate(arr[:, 0], arr[:, 1] if self.model.uses_velocity else None)
            xp = np.concatenate([G, arr[:, 2:]], axis=1)
            if self.cutoff is not None:
                xp[:, : G.shape[1]] = derivatives.lowpass(G, self.fs, self.cutoff)
                edge = self.edge
                xp[:edge] = np.nan
                xp[xp.shape[0] - edge :] = np.nan
            out.append(AxesArray(xp, comprehend_axes(xp)))
        return out

    @property
    def edge(self) -> int:
        """Rows at each end left unset (NaN) by the filter: ``ceil(EDGE_PERIODS fs / cutoff)``."""
        return 0 if self.cutoff is None else int(np.ceil(EDGE_PERIODS * self.fs / self.cutoff))

    def get_feature_names(self, input_features=None) -> list[str]:
        """The model's canonical term names, then the control inputs' names."""
        check_is_fitted(self)
        if input_features is None:
            input_features = ["z", "v", *(f"u{i}" for i in range(self.n_features_in_ - 2))]
        return [*self.model.names, *input_features[2 : self.n_features_in_]]
