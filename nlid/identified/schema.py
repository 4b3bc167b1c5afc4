"""An identified model as plain data: the JSON layout :data:`SCHEMA` of
:meth:`nlid.identified.model.IdentifiedModel.to_dict`.

:func:`model_to_dict` writes it and :func:`model_from_dict` reads it back (what
``to_dict()`` and ``from_dict()`` of :class:`~nlid.identified.model.IdentifiedModel`
do); like :mod:`nlid.identified.plots`, this module does not import the identified
model: ``from_dict`` passes its class.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from ..base.jsonable import to_jsonable
from ..errors import InputError, brief
from ..estimation.inputpath import InputPath
from ..model.physics import Equilibria
from ..model.terms import Model, parse_term
from ..scoring import Scores
from .fileformat import check_model
from .tables import record_units

if TYPE_CHECKING:  # pragma: no cover
    from .model import IdentifiedModel

__all__ = ["SCHEMA", "model_to_dict", "model_from_dict"]

#: Identifies the JSON layout of :meth:`IdentifiedModel.to_dict`.
SCHEMA = "nlid.IdentifiedModel/1"
#: The warning of a model whose stored figures did not match its coefficients (they are recomputed).
STALE_NOTE = (
    "the coefficients do not give the stored equilibria and modal parameters (edited after the fit?): both "
    "recomputed from the coefficients, and the scores of the original fit dropped (fit.score(record) computes them)"
)


def _finite_number(value: Any) -> bool:
    """True for a real number (not a bool, a string or an array) that is finite."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        return False
    try:
        return math.isfinite(float(value))
    except OverflowError:
        return False


def model_to_dict(fit: IdentifiedModel) -> dict[str, Any]:
    """The JSON-serialisable dictionary of ``fit`` (without its arrays), in the layout :data:`SCHEMA`."""
    return to_jsonable(
        {
            "schema": SCHEMA,
            "method": fit.method,
            "terms": list(fit.terms),
            "coefficients": dict(fit.coefficients),
            "standard_errors": None
            if fit.standard_errors is None
            else {n: fit.standard_errors.get(n) for n in fit.terms},
            "units": {n: parse_term(n).coefficient_unit_in(*record_units(fit)) for n in fit.terms},
            "mass": fit.mass,
            "mass_estimated": fit.mass_estimated,
            "mass_standard_error": fit.mass_standard_error,
            "px_roots": None if fit.px_roots is None else list(fit.px_roots),
            "equilibria": None if fit.equilibria is None else fit.equilibria.to_dict(),
            "modal": [m.to_dict() for m in fit.modal],
            "eps_percent": fit.eps_percent,
            "force_residual_percent": fit.force_residual_percent,
            "scores": None if fit.scores is None else fit.scores.to_dict(),
            **fit._shared_dict(),  # options ... provenance, as every result's layout ends
            # written only when the force does not act as recorded (the layout of older models is unchanged)
            **({} if fit.input_path.identity else {"input_path": fit.input_path.to_dict()}),
        }
    )


def model_from_dict(cls: type[IdentifiedModel], data: Mapping[str, Any]) -> IdentifiedModel:
    """Rebuild a model of class ``cls`` from :func:`model_to_dict` (JSON null becomes NaN in the scores).

    Raises
    ------
    InputError
        If the dictionary does not fit the layout's schema (:mod:`nlid.identified.fileformat`: a field of the
        wrong type, an unknown field, nesting deeper than it allows), lacks the terms or coefficients,
        they do not match, or a coefficient is not a finite number (NaN, infinity, a string...).
    """
    if not isinstance(data, Mapping):
        raise InputError(f"expected a dictionary from IdentifiedModel.to_dict(), got {type(data).__name__}")
    schema = data.get("schema", SCHEMA)
    if schema != SCHEMA:
        raise InputError(f"unknown identified-model layout {brief(schema, 60)}; this nlid reads {SCHEMA!r}")
    # every field against the layout's schema (nlid.identified.fileformat), one line naming the first misfit
    check_model(data)
    try:
        terms = list(data["terms"])
        coefficients = dict(data["coefficients"])
    except (KeyError, TypeError):
        raise InputError("an identified model needs 'terms' and 'coefficients'") from None
    model = Model.from_spec(terms, defaults=False, px_roots=data.get("px_roots"))
    for name, value in coefficients.items():  # a model with a NaN, a string or a list for a coefficient is no model
        if not _finite_number(value):
            raise InputError(f"the coefficient of {brief(str(name), 60)} is {brief(value, 60)}, not a finite number")
    raw_scores = data.get("scores")
    scores = None
    if raw_scores:
        known = {f.name for f in dataclasses.fields(Scores)}
        kept = ("band_hz", "predict_horizon")  # None there means "none", not a missing number
        values = {k: (float("nan") if v is None and k not in kept else v) for k, v in raw_scores.items()}
        scores = Scores(**{k: v for k, v in values.items() if k in known})
    elif data.get("eps_percent") is not None:
        scores = Scores(float(data["eps_percent"]), float(data.get("force_residual_percent") or float("nan")))
    eq = data.get("equilibria")
    fit = cls(
        model=model,
        coefficients=coefficients,
        mass=data.get("mass"),
        mass_standard_error=data.get("mass_standard_error"),
        equilibria=None if eq is None else Equilibria.from_dict(eq),
        modal=tuple(data.get("modal") or ()),
        scores=scores,
        input_path=InputPath.from_dict(data.get("input_path")),
        **cls._shared_fields(data),
    )
    return fit._fresh()
