"""The model file format: the versioned schema of an identified model's JSON, checked on load.

``IdentifiedModel.to_dict()`` (``nlid identify --json``) and ``IdentifiedStructure.to_dict()`` write
a JSON object that users keep and share; its layout is named by its ``"schema"`` field
(``nlid.IdentifiedModel/1``, ``nlid.IdentifiedStructure/1``: version 1 is the layout nlid has written
since the field exists; a file without it is read as version 1). This module declares each field
once (:data:`MODEL_FIELDS`, :data:`STRUCTURE_FIELDS`, :data:`PROVENANCE_FIELDS`): its type, whether
it is required, and what it holds. :func:`check_model`, :func:`check_structure` and
:func:`check_provenance` check a dictionary against them before anything is built from it: the first
field that does not fit is one :class:`~nlid.errors.InputError` line naming it
(``model JSON: coefficients: must be an object of finite numbers, got 'abc'``). Unknown fields are
refused (a misspelt field is not silently dropped), and free-form parts (``options``,
``diagnostics``) must be plain JSON nested at most :data:`MAX_DEPTH` levels. The schema is written
out in ``docs/model-json.md``, which ``tests/test_hostile_round3.py`` keeps in step with the
declarations here.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..base.validate import did_you_mean
from ..errors import InputError, brief, one_line

__all__ = [
    "MAX_DEPTH",
    "Field",
    "MODEL_FIELDS",
    "STRUCTURE_FIELDS",
    "PROVENANCE_FIELDS",
    "check_model",
    "check_structure",
    "check_provenance",
    "check_json",
]

#: Deepest nesting of a model JSON (and of any free-form part of it): levels of objects and arrays.
MAX_DEPTH = 32
#: Most values (numbers, strings, objects...) a model JSON may hold.
MAX_VALUES = 1_000_000


class _Bad(Exception):
    """A value that does not fit its kind: what it must be (the message names the field)."""


# --------------------------------------------------------------------------- kinds of values
@dataclass(frozen=True)
class Kind:
    """What a field holds; :meth:`check` raises ``_Bad`` with what it must be."""

    text: str

    def check(self, value: Any, where: str) -> None:  # pragma: no cover - every kind defines it
        raise NotImplementedError

    def bad(self, value: Any) -> _Bad:
        return _Bad(f"must be {self.text}, got {_shown(value)}")


def _shown(value: Any) -> str:
    if isinstance(value, Mapping):
        return "an object"
    if isinstance(value, (list, tuple)):
        return f"a list of {len(value)}"
    return brief(value, 60)


def _real(value: Any) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_))


@dataclass(frozen=True)
class Number(Kind):
    """A JSON number: finite unless ``finite=False``, above ``minimum`` (``strict``: not equal to it)."""

    finite: bool = True
    minimum: float | None = None
    strict: bool = False
    integer: bool = False

    def check(self, value: Any, where: str) -> None:
        if not _real(value) or (self.integer and not float(value).is_integer()):
            raise self.bad(value)
        try:
            x = float(value)
        except OverflowError:
            x = math.inf
        if self.finite and not math.isfinite(x):
            raise self.bad(value)
        if self.minimum is not None and (x < self.minimum or (self.strict and x == self.minimum)):
            raise self.bad(value)


@dataclass(frozen=True)
class Text(Kind):
    """A string, one of ``choices`` when they are given."""

    choices: tuple[str, ...] = ()

    def check(self, value: Any, where: str) -> None:
        if not isinstance(value, str) or (self.choices and value not in self.choices):
            raise self.bad(value)


@dataclass(frozen=True)
class Flag(Kind):
    """``true`` or ``false``."""

    def check(self, value: Any, where: str) -> None:
        if not isinstance(value, (bool, np.bool_)):
            raise self.bad(value)


@dataclass(frozen=True)
class Nullable(Kind):
    """``null`` or ``kind``."""

    kind: Kind = Flag("")

    def check(self, value: Any, where: str) -> None:
        if value is not None:
            try:
                self.kind.check(value, where)
            except _Bad:
                raise self.bad(value) from None


@dataclass(frozen=True)
class Either(Kind):
    """One of ``kinds``."""

    kinds: tuple[Kind, ...] = ()

    def check(self, value: Any, where: str) -> None:
        for kind in self.kinds:
            try:
                kind.check(value, where)
                return
            except (_Bad, InputError):
                continue
        raise self.bad(value)


@dataclass(frozen=True)
class ListOf(Kind):
    """An array of ``item`` (of ``length`` items when given)."""

    item: Kind = Flag("")
    length: int | None = None

    def check(self, value: Any, where: str) -> None:
        if isinstance(value, (str, bytes, Mapping)) or not isinstance(value, Sequence):
            raise self.bad(value)
        if self.length is not None and len(value) != self.length:
            raise self.bad(value)
        for i, item in enumerate(value):
            _at(self.item, item, f"{where}[{i}]")


@dataclass(frozen=True)
class MapOf(Kind):
    """An object whose values are ``item`` (keys are strings)."""

    item: Kind = Flag("")

    def check(self, value: Any, where: str) -> None:
        if not isinstance(value, Mapping) or not all(isinstance(k, str) for k in value):
            raise self.bad(value)
        for key, item in value.items():
            _at(self.item, item, f"{where}.{one_line(key, 40)}" if where else one_line(key, 40))


@dataclass(frozen=True)
class Json(Kind):
    """Plain JSON (objects with string keys, arrays, strings, numbers, booleans, null)."""

    def check(self, value: Any, where: str) -> None:
        check_json(value, where)


@dataclass(frozen=True)
class Field:
    """One field of an object: its name, kind, whether it is required, and what it holds (for the docs)."""

    name: str
    kind: Kind
    required: bool
    doc: str


@dataclass(frozen=True)
class Obj(Kind):
    """An object of declared fields; with ``open``, other keys are allowed (plain JSON)."""

    fields: tuple[Field, ...] = ()
    open: bool = False

    def check(self, value: Any, where: str) -> None:
        if not isinstance(value, Mapping):
            raise self.bad(value)
        _fields(value, self.fields, where, self.open)


def _at(kind: Kind, value: Any, where: str) -> None:
    """Check ``value`` against ``kind``; a misfit becomes an :class:`InputError` naming ``where``."""
    try:
        kind.check(value, where)
    except _Bad as exc:
        raise InputError(f"model JSON: {where}: {exc}") from None


def _fields(data: Mapping[str, Any], fields: Sequence[Field], where: str, open_: bool = False) -> None:
    known = {f.name: f for f in fields}
    prefix = f"{where}." if where else ""
    for key in data:
        if key not in known:
            if not isinstance(key, str):
                raise InputError(f"model JSON: {where or 'the object'}: has a key that is not text: {brief(key, 40)}")
            if open_:
                check_json(data[key], prefix + key)
                continue
            hint = did_you_mean(key, list(known))
            raise InputError(f"model JSON: {prefix}{one_line(key, 60)}: not a field of this layout{hint}")
    for f in fields:
        if f.name not in data:
            if f.required:
                raise InputError(f"model JSON: {prefix}{f.name}: is required ({f.doc})")
            continue
        _at(f.kind, data[f.name], prefix + f.name)


def check_json(value: Any, where: str = "", depth: int = MAX_DEPTH) -> None:
    """Refuse what is not plain JSON, nested deeper than ``depth`` or holding more than :data:`MAX_VALUES` values.

    Walked without recursion, so a value nested 100 000 levels deep is one line, not a ``RecursionError``.

    Raises
    ------
    InputError
        Naming ``where`` and what is wrong.
    """
    todo: list[tuple[Any, int, str]] = [(value, 0, where)]
    seen = 0
    while todo:
        item, level, at = todo.pop()
        seen += 1
        if seen > MAX_VALUES:
            raise InputError(f"model JSON: {where or 'the file'}: holds more than {MAX_VALUES} values")
        if level > depth:
            raise InputError(f"model JSON: {at or 'the file'}: nested deeper than {depth} levels")
        if item is None or isinstance(item, (str, bool, np.bool_)) or _real(item):
            continue
        if isinstance(item, Mapping):
            for key, sub in item.items():
                if not isinstance(key, str):
                    raise InputError(f"model JSON: {at or 'the file'}: has a key that is not text: {brief(key, 40)}")
                todo.append((sub, level + 1, _path(at, f".{one_line(key, 40)}" if at else one_line(key, 40), level)))
        elif isinstance(item, (list, tuple)):
            todo.extend((sub, level + 1, _path(at, f"[{i}]", level)) for i, sub in enumerate(item))
        else:
            raise InputError(f"model JSON: {at or 'the file'}: {type(item).__name__} is not a JSON value")


def _path(at: str, step: str, level: int) -> str:
    """Where a nested value is, named down to 4 levels (``provenance.data.units.z``; deeper: ``...``)."""
    if level < 4:
        return at + step
    return at if at.endswith("...") else at + "..."


# --------------------------------------------------------------------------- the layouts
_FINITE = Number("a finite number")
_ANY_NUMBER = Nullable("a number or null", Number("a number", finite=False))
_POSITIVE = Number("a positive number", minimum=0.0, strict=True)
_NONNEGATIVE = Number("a number not below 0", minimum=0.0)
_COUNT = Number("a whole number not below 0", minimum=0.0, integer=True)
_STRINGS = ListOf("a list of strings", Text("a string"))
_PAIR = ListOf("a list of two finite numbers", _FINITE, 2)
_JSON_OBJECT = MapOf("an object of JSON values", Json("JSON"))

#: The fields of a model's provenance (:mod:`nlid.identification.provenance`): where the data came from and the call.
PROVENANCE_FIELDS: tuple[Field, ...] = (
    Field("nlid_version", Text("a string"), True, "the nlid version that identified the model"),
    Field(
        "data",
        Obj(
            "an object",
            (
                Field("source", Nullable("a string or null", Text("a string")), True, "the file, dataset:NAME..."),
                Field("sha256", Text("a string"), True, "SHA-256 of the file (or of the record's samples)"),
                Field("sha256_of", Text("file or record", ("file", "record")), True, "what sha256 hashes"),
                Field("record_sha256", Text("a string"), True, "SHA-256 of the samples identified"),
                Field("as_loaded", Nullable("true, false or null", Flag("")), False, "the samples the file gave"),
                Field(
                    "columns",
                    Nullable(
                        "a column map (text or an object of text) or null",
                        Either("", (Text(""), MapOf("", Text("")))),
                    ),
                    False,
                    "the column map as given",
                ),
                Field("fs_given", Nullable("a positive number or null", _POSITIVE), False, "fs= as given"),
                Field(
                    "units",
                    MapOf(
                        "an object of units",
                        Obj(
                            "{unit, si, factor}",
                            (
                                Field("unit", Text("a string"), True, "the unit given"),
                                Field("si", Text("a string"), True, "its SI unit"),
                                Field("factor", _POSITIVE, True, "the factor to SI"),
                            ),
                        ),
                    ),
                    False,
                    "each channel's unit as given and its factor to SI",
                ),
                Field("samples", _COUNT, False, "samples identified"),
                Field("fs", _POSITIVE, False, "sampling frequency (Hz)"),
                Field("t0", _FINITE, False, "time of the first sample (s)"),
                Field("channels", _STRINGS, False, "the channels present"),
                Field("force_hold", Text("sampled or zoh", ("sampled", "zoh")), False, "how the force was held"),
                Field("force_hold_source", Text("a string"), False, "who said how (nlid.data.forcehold)"),
                Field("channel_sources", MapOf("an object of strings", Text("a string")), False, "measured or how"),
            ),
        ),
        True,
        "the data identified",
    ),
    Field(
        "identify",
        Obj(
            "an object",
            (
                Field("method", Text("a string"), True, "the identifier"),
                Field("terms", _STRINGS, False, "the terms given (one DOF)"),
                Field("without", _STRINGS, False, "default terms removed"),
                Field("elements", _STRINGS, False, "the elements (a structure)"),
                Field("static", Flag("true or false"), False, "a constant force per DOF (a structure)"),
                Field("mass", Json("the mass"), False, "the mass given (kg; a matrix for a structure), or null"),
                Field("options", _JSON_OBJECT, False, "the identifier's settings"),
                Field("px_roots", Nullable("two finite numbers or null", _PAIR), False, "px(z) roots given"),
                Field("px_tol", _POSITIVE, False, "px(z) iteration tolerance"),
                Field("px_max_iter", Number("a whole number from 1", minimum=1.0, integer=True), False, "its cap"),
                Field("cutoff", Nullable("a positive number or null", _POSITIVE), False, "cut-off for epsilon (Hz)"),
                Field(
                    "input_path", Text("a string"), False, "the input path given (nlid.estimation.inputpath spelling)"
                ),
            ),
        ),
        True,
        "the call that identified the model",
    ),
)


def _score_fields() -> tuple[Field, ...]:
    """The fields of :class:`nlid.scoring.Scores`, each a number, a whole number or a string (``null``: unknown)."""
    import dataclasses

    from ..scoring import Scores

    kinds = {
        "str": Nullable("a string or null", Text("a string")),
        "int": Nullable("a whole number or null", _COUNT),
        "int | None": Nullable("a whole number or null", _COUNT),
    }
    return tuple(
        Field(f.name, kinds.get(str(f.type), _ANY_NUMBER), False, "a score") for f in dataclasses.fields(Scores)
    )


_PROVENANCE = Nullable("a provenance object or null", Obj("a provenance object", PROVENANCE_FIELDS))

#: The checks of what physics forbids that a model fails (:mod:`nlid.identified.plausibility`).
_FLAGS = Field(
    "flags",
    ListOf(
        "a list of objects",
        Obj(
            "{code, message, cause}",
            (
                Field("code", Text("a string"), True, "the rule broken (nlid.identified.plausibility)"),
                Field("message", Text("a string"), True, "what was found"),
                Field("cause", Text("a string"), True, "the likely cause"),
            ),
        ),
    ),
    False,
    "the checks of what physics forbids that the model fails",
)


#: The fields both layouts (one DOF and a structure) write the same way.
_METHOD = Field("method", Text("a string"), False, "the identifier's name")
_STANDARD_ERRORS = Field(
    "standard_errors",
    Nullable("an object of numbers or null", MapOf("an object of numbers or null", _ANY_NUMBER)),
    False,
    "each coefficient's standard error",
)
_UNITS = Field("units", MapOf("an object of strings", Text("a string")), False, "each coefficient's SI unit (written)")
#: The fields both layouts end with, before the data range and the provenance (``Identified._shared_dict``).
_SHARED = (
    Field("options", _JSON_OBJECT, False, "the identifier's settings"),
    Field("diagnostics", _JSON_OBJECT, False, "what the identifier reported"),
    Field("warnings", _STRINGS, False, "warnings"),
    _FLAGS,
    Field("seconds", Nullable("a number not below 0 or null", _NONNEGATIVE), False, "time of the identification"),
)


#: The fields of ``nlid.IdentifiedModel/1`` (one degree of freedom).
MODEL_FIELDS: tuple[Field, ...] = (
    Field("schema", Text("nlid.IdentifiedModel/1", ("nlid.IdentifiedModel/1",)), False, "the layout"),
    _METHOD,
    Field("terms", _STRINGS, True, "the model's terms, in order"),
    Field("coefficients", MapOf("an object of finite numbers", Json("")), True, "each term's coefficient"),
    _STANDARD_ERRORS,
    _UNITS,
    Field("mass", Nullable("a positive number or null", _POSITIVE), False, "the mass (kg)"),
    Field("mass_estimated", Flag("true or false"), False, "whether the method estimated the mass"),
    Field("mass_standard_error", _ANY_NUMBER, False, "its standard error (kg)"),
    Field("px_roots", Nullable("two finite numbers or null", _PAIR), False, "px(z) roots (m)"),
    Field(
        "equilibria",
        Nullable(
            "{stable, unstable} or null",
            Obj(
                "{stable, unstable}",
                (
                    Field("stable", ListOf("a list of finite numbers", _FINITE), False, "stable equilibria (m)"),
                    Field("unstable", ListOf("a list of finite numbers", _FINITE), False, "unstable ones (m)"),
                ),
            ),
        ),
        False,
        "the equilibria of K(z)",
    ),
    Field(
        "modal",
        ListOf(
            "a list of modal parameters",
            Obj(
                "{equilibrium, fn_hz, zeta, ...}",
                (
                    Field("equilibrium", _FINITE, True, "the well (m)"),
                    Field("fn_hz", Number("a number", finite=False), True, "natural frequency (Hz)"),
                    Field("zeta", Number("a number", finite=False), True, "damping ratio"),
                    Field("stiffness", _ANY_NUMBER, False, "tangent stiffness (N/m)"),
                    Field("damping", _ANY_NUMBER, False, "tangent damping (N s/m)"),
                    Field("source", Text("a string"), False, "how they were found"),
                ),
                open=True,
            ),
        ),
        False,
        "natural frequency and damping ratio at each stable equilibrium",
    ),
    Field("eps_percent", _ANY_NUMBER, False, "epsilon on the estimation record (%)"),
    Field("force_residual_percent", _ANY_NUMBER, False, "the residual relative to RMS(f) (%)"),
    Field(
        "scores",
        Nullable("an object of scores or null", Obj("an object of scores", _score_fields(), open=True)),
        False,
        "every score on the estimation record (nlid.scoring.Scores)",
    ),
    *_SHARED,
    Field("z_range", Nullable("two finite numbers or null", _PAIR), False, "displacement range of the record (m)"),
    Field("provenance", _PROVENANCE, False, "where the model came from (nlid.identification.provenance)"),
    Field(
        "input_path",
        Obj(
            "{delay_s, lag_s, hold, text}",
            (
                Field("delay_s", _FINITE, False, "delay of the acting force behind the force channel (s)"),
                Field("lag_s", _NONNEGATIVE, False, "time constant of a first-order lag (s)"),
                Field(
                    "hold",
                    Nullable("sampled, zoh or null", Text("sampled or zoh", ("sampled", "zoh"))),
                    False,
                    "the force's hold between samples, when not the record's",
                ),
                Field("text", Text("a string"), False, "the path in words (written)"),
            ),
        ),
        False,
        "what happens to the force before it acts (nlid.estimation.inputpath; written only when it is not the "
        "identity)",
    ),
)

_MATRIX = ListOf("a square matrix (a list of lists of finite numbers)", ListOf("a list of finite numbers", _FINITE))
_VECTORS = ListOf("a list of points", ListOf("a list of finite numbers", _FINITE))

#: The fields of ``nlid.IdentifiedStructure/1`` (several degrees of freedom).
STRUCTURE_FIELDS: tuple[Field, ...] = (
    Field("schema", Text("nlid.IdentifiedStructure/1", ("nlid.IdentifiedStructure/1",)), True, "the layout"),
    _METHOD,
    Field(
        "structure",
        Obj(
            "a structural model",
            (
                Field("M", _MATRIX, True, "mass matrix (kg)"),
                Field("C", _MATRIX, True, "damping matrix (N s/m)"),
                Field("K", _MATRIX, True, "stiffness matrix (N/m)"),
                Field("static", Nullable("a list of finite numbers or null", ListOf("numbers", _FINITE)), False, "f0"),
                Field("elements", ListOf("a list of elements", Json("")), False, "the elements on connections"),
                Field("px_roots", Json(""), False, "px roots per connection"),
                Field("coefficients", MapOf("an object of finite numbers", _FINITE), False, "each element's"),
            ),
        ),
        True,
        "the identified structure",
    ),
    _UNITS,
    _STANDARD_ERRORS,
    Field("mass_estimated", Flag("true or false"), False, "whether the method estimated the mass matrix"),
    Field(
        "equilibria",
        Nullable(
            "{stable, unstable} or null",
            Obj(
                "{stable, unstable}",
                (Field("stable", _VECTORS, False, "stable (m)"), Field("unstable", _VECTORS, False, "unstable (m)")),
            ),
        ),
        False,
        "the equilibria",
    ),
    Field("modes", ListOf("a list of objects", _JSON_OBJECT), False, "linearised modes at each stable equilibrium"),
    Field("linear_modes", Nullable("an object or null", _JSON_OBJECT), False, "the underlying linear system's"),
    Field("eps_percent", Nullable("a list or null", ListOf("numbers", _ANY_NUMBER)), False, "epsilon per DOF (%)"),
    Field(
        "force_residual_percent",
        Nullable("a list or null", ListOf("numbers", _ANY_NUMBER)),
        False,
        "force residual per DOF (%)",
    ),
    *_SHARED,
    Field("z_range", Nullable("a list of pairs or null", ListOf("pairs", _PAIR)), False, "each DOF's range (m)"),
    Field("provenance", _PROVENANCE, False, "where the model came from"),
)


def _check(data: Any, fields: Sequence[Field], what: str) -> None:
    if not isinstance(data, Mapping):
        raise InputError(f"expected a dictionary from {what}.to_dict(), got {type(data).__name__}")
    check_json(data)  # plain JSON, bounded in depth and size, before any field is looked at
    _fields(data, fields, "")


def check_model(data: Any) -> None:
    """Check an ``nlid.IdentifiedModel/1`` dictionary against :data:`MODEL_FIELDS` (:class:`InputError` if not)."""
    _check(data, MODEL_FIELDS, "IdentifiedModel")


def check_structure(data: Any) -> None:
    """Check an ``nlid.IdentifiedStructure/1`` dictionary against :data:`STRUCTURE_FIELDS`."""
    _check(data, STRUCTURE_FIELDS, "IdentifiedStructure")


def check_provenance(data: Any) -> None:
    """Check a model's provenance against :data:`PROVENANCE_FIELDS` (:class:`InputError` naming the field)."""
    if not isinstance(data, Mapping):
        raise InputError(f"a provenance is an object (IdentifiedModel.provenance), got {type(data).__name__}")
    check_json(data, "provenance")
    _fields(data, PROVENANCE_FIELDS, "provenance")
