"""nlid: identify the nonlinear stiffness and friction of vibrating structures.

The core (this package) knows nothing about any one identification method: it
holds the data model (:class:`Record`), the term language
(:mod:`nlid.terms`), derivative estimation, the physics of an oscillator
model (:mod:`nlid.physics`), the force balance identifiers build on
(:mod:`nlid.balance`), the one scoring path (:mod:`nlid.scoring`), the
simulator and its presets, and the plugin interface (:mod:`nlid.plugin`).
Identifiers are plugins discovered through the entry-point group
``nlid.identifiers``.
"""

from .errors import DataError, IdentificationError, InputError, NlidError, OptionError, PluginError, TermError
from .hookspecs import hookimpl
from .identified import IdentifiedModel
from .interface import Estimate, Identifier, Option
from .pipeline import identify
from .record import Record
from .terms import Model, parse_term

__version__ = "0.1.0"

__all__ = [
    "Record",
    "Model",
    "parse_term",
    "identify",
    "IdentifiedModel",
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
