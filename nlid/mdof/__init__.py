"""Structures with several degrees of freedom and localised nonlinearities.

One degree of freedom stays the special case of nlid (:class:`nlid.Record`,
:class:`nlid.Model`, :class:`nlid.IdentifiedModel`, unchanged). This package
adds the multi-DOF counterparts, one job per module:

:mod:`~nlid.mdof.record`, :mod:`~nlid.mdof.tables`
    :class:`StructureRecord`: channels ``z1..zn``, ``f1..``, ``v``, ``a`` of
    each DOF; every reader returns one when the channels are indexed;
:mod:`~nlid.mdof.elements`
    :class:`Element` and :class:`ElementSet`: the term language on the
    connections between DOFs (``(z1-z2)^3``, ``sign(v2-v1)``, ``z3^3``);
:mod:`~nlid.mdof.model`, :mod:`~nlid.mdof.statics`, :mod:`~nlid.mdof.modes`
    :class:`StructuralModel` (``M``, ``C``, ``K`` plus elements), its
    equilibria, linearised modes and FRF matrix;
:mod:`~nlid.mdof.kernels`, :mod:`~nlid.mdof.simulation`, :mod:`~nlid.mdof.sensitivity`
    the compiled integrator, its free runs, and their forward sensitivities (``oe``'s Jacobian);
:mod:`~nlid.mdof.regression`, :mod:`~nlid.mdof.jointfit`, :mod:`~nlid.mdof.balance`
    the force balance of every DOF on one footing, the one joint least squares of a structure
    (``rfs``, ``discover``) and the residual per DOF;
:mod:`~nlid.mdof.presets`
    ``3dof-cubic``, ``2dof-double-well``, ``beam-5mode`` (``nlid.simulate``);
:mod:`~nlid.mdof.estimate`, :mod:`~nlid.mdof.identified`, :mod:`~nlid.mdof.fit`
    what an identifier of several DOFs returns (:class:`StructureEstimate`),
    the identified structure (:class:`IdentifiedStructure`) and how
    :func:`nlid.identify` builds it.

Names are loaded on first use (the presets are listed by ``nlid simulate --help``).
"""

from __future__ import annotations

import importlib
from typing import Any

_LAZY = {
    "StructureRecord": "nlid.mdof.record",
    "Element": "nlid.mdof.elements",
    "ElementSet": "nlid.mdof.elements",
    "parse_element": "nlid.mdof.elements",
    "StructuralModel": "nlid.mdof.model",
    "StructureEquilibria": "nlid.mdof.statics",
    "StructureModes": "nlid.mdof.modes",
    "simulate": "nlid.mdof.simulation",
    "free_run": "nlid.mdof.simulation",
    "free_run_segments": "nlid.mdof.simulation",
    "StructurePreset": "nlid.mdof.presets",
    "StructureEstimate": "nlid.mdof.estimate",
    "IdentifiedStructure": "nlid.mdof.identified",
}

__all__ = list(_LAZY)


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'nlid.mdof' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
