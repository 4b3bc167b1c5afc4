"""The model of ``R`` encoded as the integer and float arrays the compiled kernels read.

One compiled kernel serves every model of the term language because the model
reaches it as arrays (:func:`encode_model`, :func:`encode_memory`), decoded
once per integration by :func:`nlid.simulation.kernels._plan`.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..model.terms import Model, px_coefficients

__all__ = ["encode_model", "encode_memory"]

#: Codes of the special factors in :func:`encode_model`.
_KIND_CODE = {"exp1": 1, "exp2": 2, "tanh": 3, "gap": 4, "stop": 5}
#: Codes of the memory laws in :func:`encode_memory`.
_MEMORY_CODE = {"bouc_wen": 1, "dahl": 2}
_VAR_CODE = {"z": 0, "v": 1}


def encode_memory(model: Model) -> np.ndarray:
    """The memory terms of a model for the compiled kernel: ``(law, p1, p2)`` per term (law 0: not memory).

    ``bouc_wen(a, b)`` is law 1 with ``(a, b)``; ``dahl(rho)`` law 2 with ``(rho, 0)``
    (:mod:`nlid.model.terms.memory`).
    """
    out = np.zeros((len(model.terms), 3))
    for i, term in enumerate(model.terms):
        if term.memory is not None:
            law, params = term.memory
            out[i, 0] = _MEMORY_CODE[law]
            out[i, 1 : 1 + len(params)] = params
    return out


def encode_model(model: Model) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Encode a model for the compiled kernel.

    Returns
    -------
    parts : numpy.ndarray of int64, shape (p, 6)
        ``(pz, sz, pv, sv, ppx, spx)`` of each term.
    special : numpy.ndarray of float, shape (p, k, 4)
        ``(kind, variable, scale, multiplicity)`` of each special factor
        (kind 0 pads).
    pxc : numpy.ndarray, shape (4,)
        ``alpha, beta, gamma, delta`` of ``px(z)`` (zeros if unused).
    """
    p = len(model.terms)
    k = max([len(t.special) for t in model.terms] + [1])
    parts = np.zeros((p, 6), dtype=np.int64)
    special = np.zeros((p, k, 4))
    for i, term in enumerate(model.terms):
        parts[i] = (*term.z, *term.v, *term.px)
        for j, (kind, var, scale, mult) in enumerate(term.special):
            special[i, j] = (_KIND_CODE[kind], _VAR_CODE[var], scale, mult)
    pxc = np.zeros(4)
    if model.uses_px:
        if model.px_roots is None:
            raise InputError("the model uses px(z) but its roots are not set")
        pxc[:] = px_coefficients(*model.px_roots)
    return parts, special, pxc
