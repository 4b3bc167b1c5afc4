"""The contract between nlid and its identifiers.

An identifier is a class with

* ``name`` (the entry-point name users type, e.g. ``"rfs"``) and ``summary``;
* ``options``: a tuple of :class:`Option` (typed, with defaults) that the CLI
  and study configs validate before anything runs;
* ``needs_mass``: ``True`` if it cannot estimate the mass itself;
* ``dofs``: ``"single"`` (the default) or ``"multi"`` when it also identifies
  structures of several degrees of freedom (:mod:`nlid.model.structure`): its
  ``identify_structure`` then receives an indexed :class:`~nlid.data.record.Record`, an
  :class:`~nlid.model.elements.ElementSet` and a mass matrix (or ``None``) and returns a
  :class:`~nlid.contract.structure_estimate.StructureEstimate` (by default :meth:`Identifier.identify_structure`
  passes them on to ``identify``); the core refuses a structure record for a single-DOF identifier, naming it;
* optionally what the core tells users about it, so that the core never names
  a plugin: ``preference`` (rank as the default method), ``advice`` and
  ``advice_order`` (the "Which method?" list of ``nlid methods``), ``docs``
  (the page reports link to) and ``refines`` (it refines another method's fit,
  started from the identifier its ``init`` option names);
* a constructor that only stores validated settings (``self.settings``), and
* ``identify(record, model, *, mass=None) -> Estimate``.

Subclassing :class:`Identifier` gives the constructor and the option handling;
the core only relies on the attributes above (the named checks of
:mod:`nlid.testing`).

The identifier returns an :class:`Estimate`: the coefficients it estimated
(every coefficient is the coefficient of its term in ``R(z, v) = f - m z''``),
the mass if it estimated it, standard errors and its diagnostics. The core
(:func:`nlid.identify`) then builds the immutable
:class:`~nlid.identified.model.IdentifiedModel` with what it computes the same way
for every method: equilibria, modal parameters (unless the method measured
them itself), the residuals (always recomputed from the data, never trusted
from the plugin) and the wall time.

:class:`Estimate` and its check (:func:`check_estimate`) are defined in
:mod:`nlid.contract.estimate`; this module re-exports them.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from ..base.jsonable import to_jsonable
from ..base.validate import did_you_mean
from ..data.record import Record
from ..errors import OptionError, brief
from ..model.elements import ElementSet
from ..model.terms import Model
from .estimate import Estimate
from .structure_estimate import StructureEstimate

__all__ = [
    "Option",
    "Identifier",
    "FigureArray",
    "FIGURE_KINDS",
    "standard_figure_arrays",
    "resolve_options",
]

_TYPES = ("int", "float", "bool", "str", "floats")
_TRUE = {"1", "true", "yes", "on"}
_FALSE = {"0", "false", "no", "off"}


@dataclass(frozen=True)
class Option:
    """A declared identifier option.

    Parameters
    ----------
    name
        Option name as typed by users (``--set name=value``, TOML key).
    type
        ``"int"``, ``"float"``, ``"bool"``, ``"str"`` or ``"floats"`` (a
        comma-separated list of floats).
    default
        Default value; ``None`` means "automatic" and requires ``nullable``.
    help
        One line for ``nlid methods``.
    choices
        Allowed values (for ``str`` options).
    minimum, maximum
        Inclusive bounds for numbers.
    nullable
        Accept ``"auto"`` / ``"none"`` / ``None`` meaning "let the method choose".
    """

    name: str
    type: str
    default: Any
    help: str
    choices: tuple[Any, ...] | None = None
    minimum: float | None = None
    maximum: float | None = None
    nullable: bool = False

    def __post_init__(self) -> None:
        if self.type not in _TYPES:
            raise ValueError(f"option {self.name!r}: type must be one of {_TYPES}, got {self.type!r}")

    def parse(self, value: Any, where: str = "") -> Any:
        """Convert and check a value (from the CLI, a config file or Python).

        Raises
        ------
        OptionError
            Naming the option, the value and what was expected.
        """
        prefix = f"{where}option {self.name!r}"
        if value is None or (isinstance(value, str) and value.strip().lower() in ("auto", "none", "null")):
            if self.nullable:
                return None
            raise OptionError(f"{prefix} needs a value of type {self.type}")
        try:
            out = self._convert(value)
        except (TypeError, ValueError):
            raise OptionError(f"{prefix} expects {self._expects()}, got {brief(value)}") from None
        if self.choices is not None and out not in self.choices:
            raise OptionError(f"{prefix} must be one of {', '.join(map(str, self.choices))}; got {brief(out)}")
        values = out if isinstance(out, tuple) else (out,)
        if self.type in ("int", "float", "floats"):
            for x in values:
                if not math.isfinite(x):
                    raise OptionError(f"{prefix} must be finite, got {x!r}")
                if self.minimum is not None and x < self.minimum:
                    raise OptionError(f"{prefix} must be >= {self.minimum:g}, got {x:g}")
                if self.maximum is not None and x > self.maximum:
                    raise OptionError(f"{prefix} must be <= {self.maximum:g}, got {x:g}")
        return out

    def _expects(self) -> str:
        return {
            "int": "an integer",
            "float": "a number",
            "bool": "true or false",
            "str": "a string",
            "floats": "comma-separated numbers",
        }[self.type] + (" or 'auto'" if self.nullable else "")

    def _convert(self, value: Any) -> Any:
        if self.type == "bool":
            if isinstance(value, bool):
                return value
            text = str(value).strip().lower()
            if text in _TRUE:
                return True
            if text in _FALSE:
                return False
            raise ValueError(value)
        if self.type == "int":
            if isinstance(value, bool):
                raise TypeError(value)
            if isinstance(value, float) and not value.is_integer():
                raise ValueError(value)
            return int(str(value).strip()) if isinstance(value, str) else int(value)
        if self.type == "float":
            if isinstance(value, bool):
                raise TypeError(value)
            return float(value)
        if self.type == "floats":
            items = value.split(",") if isinstance(value, str) else list(value)
            return tuple(float(x) for x in items if str(x).strip())
        if not isinstance(value, str):
            raise TypeError(value)
        return value

    def describe(self) -> dict[str, Any]:
        """JSON-friendly description for ``nlid methods --json``."""
        return {
            "name": self.name,
            "type": self.type,
            "default": "auto" if self.default is None else to_jsonable(self.default),
            "help": self.help,
            "choices": None if self.choices is None else list(self.choices),
        }


def resolve_options(declared: tuple[Option, ...], given: Mapping[str, Any], where: str = "") -> dict[str, Any]:
    """Validate user options against the declared ones and fill defaults.

    Raises
    ------
    OptionError
        For an unknown option (with a suggestion) or a bad value.
    """
    by_name = {o.name: o for o in declared}
    for key in given:
        if key not in by_name:
            known = ", ".join(by_name) or "none"
            raise OptionError(f"{where}unknown option {brief(key)}{did_you_mean(key, by_name)}; known options: {known}")
    return {o.name: (o.parse(given[o.name], where) if o.name in given else o.default) for o in declared}


#: What a :class:`FigureArray` is: ``"frf"`` (a complex underlying-linear receptance, m/N) or
#: ``"coefficient spectrum"`` (a complex frequency-dependent estimate of one coefficient, NSI Eq. 20).
FIGURE_KINDS = ("frf", "coefficient spectrum")


@dataclass(frozen=True)
class FigureArray:
    """One array of an estimate that study reports draw, and what it is.

    An identifier declares its own with :meth:`Identifier.figure_arrays`, so
    that reports never parse its array names.

    Attributes
    ----------
    kind
        One of :data:`FIGURE_KINDS`.
    values
        Its key in :attr:`Estimate.arrays` (complex values).
    frequency
        The key of its frequency axis (Hz).
    label
        Which part of the estimate it belongs to when there are several
        (e.g. ``"well 2"``); ``""`` when there is one.
    term
        The term of a coefficient spectrum.
    """

    kind: str
    values: str
    frequency: str
    label: str = ""
    term: str = ""

    def __post_init__(self) -> None:
        if self.kind not in FIGURE_KINDS:
            raise ValueError(f"figure array {self.values!r}: kind must be one of {FIGURE_KINDS}, got {self.kind!r}")
        if self.kind == "coefficient spectrum" and not self.term:
            raise ValueError(f"figure array {self.values!r}: a coefficient spectrum needs its term")


def standard_figure_arrays(arrays: Mapping[str, Any]) -> tuple[FigureArray, ...]:
    """The figure arrays under the keys :class:`Estimate` documents, where present.

    ``frf`` against ``frf_frequency_hz``, and ``coef_spectrum:<term>`` against
    ``coef_frequency_hz`` (spectra in the order of their keys).
    """
    out: list[FigureArray] = []
    if "frf" in arrays and "frf_frequency_hz" in arrays:
        out.append(FigureArray("frf", "frf", "frf_frequency_hz"))
    if "coef_frequency_hz" in arrays:
        prefix = "coef_spectrum:"
        for key in sorted(k for k in arrays if k.startswith(prefix) and "@" not in k):
            out.append(FigureArray("coefficient spectrum", key, "coef_frequency_hz", term=key[len(prefix) :]))
    return tuple(out)


class Identifier:
    """Base class of identifiers (optional: the core relies on the attributes only).

    Subclasses set the class attributes and implement :meth:`identify`.

    Parameters
    ----------
    **options
        Values for the declared :attr:`options`; validated here and stored in
        :attr:`settings`. No work is done in the constructor.
    """

    #: Name users select the identifier by (equal to its entry-point name).
    name: ClassVar[str] = ""
    #: One line describing the method.
    summary: ClassVar[str] = ""
    #: Declared options.
    options: ClassVar[tuple[Option, ...]] = ()
    #: True if the method cannot estimate the mass.
    needs_mass: ClassVar[bool] = False
    #: ``"single"``: one degree of freedom only; ``"multi"``: also structures of several (an
    #: indexed :class:`~nlid.data.record.Record` and an :class:`~nlid.model.elements.ElementSet` in, a
    #: :class:`~nlid.contract.structure_estimate.StructureEstimate` out). The core refuses a structure for a single-DOF
    #: identifier.
    dofs: ClassVar[str] = "single"
    #: Rank as the default method (``nlid discover`` without ``--method``, the start of a refining
    #: identifier; :func:`nlid.contract.methods.choose_method`): lower first; ``None``: after the ranked ones.
    preference: ClassVar[int | None] = None
    #: One line: when to choose this method (``nlid methods``); empty: its :attr:`summary` is shown.
    advice: ClassVar[str] = ""
    #: Place of :attr:`advice` in the "Which method?" list of ``nlid methods``: lower first; ``None``: after the
    #: placed ones. (A decision guide reads "first choice, then by situation", which need not be :attr:`preference`.)
    advice_order: ClassVar[int | None] = None
    #: Documentation page that reports link to ("see docs/rfs.md"): a path or a URL; empty: none.
    docs: ClassVar[str] = ""
    #: True if the method refines another method's fit (as ``oe`` does); its ``init`` option (a string)
    #: names the method it starts from. ``nlid discover --refine`` uses the preferred such identifier.
    refines: ClassVar[bool] = False

    def __init__(self, **options: Any) -> None:
        self.settings: dict[str, Any] = resolve_options(self.options, options, where=f"{self.name}: ")

    def identify(self, record: Record, model: Model, *, mass: float | None = None) -> Estimate:
        """Estimate the coefficients of ``model`` from ``record``.

        Parameters
        ----------
        record
            The data (validated).
        model
            The terms to identify; ``px(z)`` roots are set when used.
        mass
            Known mass in kg, or ``None`` (estimate it, or raise
            :class:`~nlid.errors.InputError` if the method cannot).
        """
        raise NotImplementedError

    def identify_structure(
        self, record: Record, elements: ElementSet, *, mass: np.ndarray | None = None
    ) -> StructureEstimate:
        """Estimate a structure's elements and linear system (called for an identifier declaring ``dofs = "multi"``).

        The core hands a structure record here and a one-DOF record to :meth:`identify`, so neither
        method asks which it was given. The default passes the structure's arguments on to
        :meth:`identify`, as the contract did before this method existed.

        Parameters
        ----------
        record
            The structure record (validated).
        elements
            The elements to identify on the record's DOFs.
        mass
            The known mass matrix in kg (n x n), or ``None`` (estimate it).
        """
        return self.identify(record, elements, mass=mass)  # type: ignore[arg-type,return-value]

    @classmethod
    def figure_arrays(cls, arrays: Mapping[str, Any]) -> tuple[FigureArray, ...]:
        """Which of an estimate's ``arrays`` study reports draw, and as what.

        Parameters
        ----------
        arrays
            :attr:`Estimate.arrays` of one identification (as stored with a study run).

        Returns
        -------
        tuple of FigureArray
            In drawing order. Default: the keys :class:`Estimate` documents
            (:func:`standard_figure_arrays`); an identifier with other keys
            (several wells, several fits) declares them here.
        """
        return standard_figure_arrays(arrays)

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in self.settings.items())
        return f"{type(self).__name__}({args})"
