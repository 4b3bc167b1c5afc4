"""nlid: identify the nonlinear stiffness and friction of vibrating structures.

The Python API is a handful of verbs (:mod:`nlid.api`)::

    import nlid

    record = nlid.simulate("paper-numerical", seed=0, noise=0.02, channels="z,a")
    fit = nlid.identify(record, "z^3, z^2, v*|v|", mass=0.2)   # method: the preferred installed one
    print(fit.summary())                                       # a nlid.Summary (text, Markdown, HTML)
    table = nlid.compare(record, "z^3, z^2, v*|v|", ["rfs", "nsi-ip"], mass=0.2)
    post = nlid.posterior(record, fit, seed=0)
    found = nlid.discover(nlid.load("dataset:emps"), "v, 1")
    outcome = nlid.run_study("paper-numerical")

The core (this package) knows nothing about any one identification method: it
holds the data model (:class:`Record`), the term language
(:mod:`nlid.model.terms`), derivative estimation, the physics of an oscillator
model (:mod:`nlid.model.physics`), the force balance identifiers build on
(:mod:`nlid.estimation.balance`), the one scoring path (:mod:`nlid.scoring`), the
identified model (:class:`IdentifiedModel`), the simulator and its presets,
and the plugin interface (:mod:`nlid.plugin`). Identifiers are plugins
discovered through the entry-point group ``nlid.identifiers``.

Names are loaded on first use, so ``import nlid`` (and ``nlid --help``) stay
fast: numpy, scipy, pandas and numba are imported only by what needs them.
"""

from __future__ import annotations

import importlib
from typing import Any

from .errors import DataError, IdentificationError, InputError, NlidError, OptionError, PluginError, TermError

__version__ = "0.1.0"

#: Public name -> module that defines it (imported on first access).
_LAZY: dict[str, str] = {
    "load": "nlid.api",
    "simulate": "nlid.api",
    "compare": "nlid.api",
    "posterior": "nlid.api",
    "discover": "nlid.api",
    "run_study": "nlid.api",
    "bench": "nlid.benchmarking",
    "identify": "nlid.identification.pipeline",
    "IdentifiedModel": "nlid.identified.model",
    "InputPath": "nlid.estimation.inputpath",
    "Summary": "nlid.report.summary",
    "Record": "nlid.data.record",
    "Model": "nlid.model.terms",
    "parse_term": "nlid.model.terms",
    "Identifier": "nlid.contract.identifier",
    "Estimate": "nlid.contract.estimate",
    "Option": "nlid.contract.identifier",
    "hookimpl": "nlid.contract.hookspecs",
}

__all__ = [
    "load",
    "simulate",
    "identify",
    "compare",
    "posterior",
    "discover",
    "run_study",
    "bench",
    "IdentifiedModel",
    "InputPath",
    "Summary",
    "Record",
    "Model",
    "parse_term",
    "Identifier",
    "Estimate",
    "Option",
    "hookimpl",
    "NlidError",
    "InputError",
    "DataError",
    "TermError",
    "OptionError",
    "PluginError",
    "IdentificationError",
    "__version__",
]


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'nlid' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value  # later lookups skip this function
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
