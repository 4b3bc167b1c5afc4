"""Study runs on the structure presets (``3dof-cubic``, ``2dof-double-well``, ``beam-5mode``).

A study dataset naming a structure preset (``preset = "3dof-cubic"``, its
``terms`` elements on connections, ``channels = ["z1", "z2", "z3"]`` or
``["z"]``) is run by :func:`execute_structure_run` instead of the one-DOF
path of :mod:`nlid.study.worker`: the record is simulated from the preset
with the run's seed, identified by :func:`nlid.identify` (the method must
declare ``dofs = "multi"``), and the row holds, besides the run's cost and
residual (``eps_percent``: the largest of the DOFs'):

* ``coef:<element>`` and ``coef_error_pct:<element>``: each element's
  coefficient and its signed relative error (the families of one DOF's terms,
  keyed by the canonical element name);
* ``linear_fn_hz:mK``, ``linear_zeta:mK`` and their errors
  ``linear_fn_error_pct:mK``, ``linear_zeta_error_pct:mK``: the underlying
  linear system's K-th mode (by frequency) against the truth's, and the
  largest of each, ``linear_fn_error_max_pct``, ``linear_zeta_error_max_pct``;
* per stable equilibrium of the truth ``sK`` (matched to the nearest
  identified one): ``eq_error_pct:sK`` (``100 |z* - z*_ref| / |z*_ref|``,
  the vector norm) and ``well_fn_error_pct:sK.mJ``,
  ``well_zeta_error_pct:sK.mJ`` of its linearised modes; ``eq_found``,
  ``eq_expected``, ``eq_missing``.

The columns are declared in :mod:`nlid.study.columns`. The reference stored with
the run is ``{"coefficients": ..., "structure": <the preset's truth>}``.
A held-out record and damping slices are not scored for structures (a
dataset asking for them gets a warning in its rows). A ``[posterior]`` table
samples the structure's unknowns (:mod:`nlid.bayes.structure`; ``params =
"elements"`` for every element) and adds the credible-interval columns of
:func:`nlid.bayes.posterior_metrics` (``ci_lo:``, ``ci_hi:``, ``ci_width:``,
``ci_covers:`` per sampled unknown).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from ..base.validate import ESTIMATE
from ..identified.compared import equilibrium_label
from . import columns as col
from .metrics import posterior_columns, timed_identification

__all__ = ["is_structure_preset", "check_structure_terms", "execute_structure_run", "structure_metrics"]


def is_structure_preset(name: str) -> bool:
    """True when ``name`` is a structure preset (:data:`nlid.simulation.structure_presets.STRUCTURE_PRESETS`)."""
    from ..simulation.structure_presets import STRUCTURE_PRESETS

    return name in STRUCTURE_PRESETS


def check_structure_terms(terms: str, preset: Any, without: Any = ()) -> None:
    """Parse a dataset's elements on the preset's DOFs (raises :class:`~nlid.errors.NlidError`)."""
    from ..identification.structure_fit import as_elements

    as_elements(terms, preset.model().n_dofs, without=without)


def _relative(x: float, ref: float) -> float:
    return float(100.0 * (x - ref) / abs(ref)) if ref else float("nan")


def _mode_rows(row: dict, fn: np.ndarray, zeta: np.ndarray, ref: Mapping[str, Any], labels: list[str], fams) -> None:
    f_val, f_err, z_val, z_err = fams
    ref_fn, ref_zeta = np.asarray(ref["fn_hz"], dtype=float), np.asarray(ref["zeta"], dtype=float)
    for k, label in enumerate(labels):
        if k >= ref_fn.size:
            break
        found = k < fn.size
        if f_val is not None:
            row[f_val.key(label)] = float(fn[k]) if found else None
            row[z_val.key(label)] = float(zeta[k]) if found else None
        row[f_err.key(label)] = _relative(fn[k], ref_fn[k]) if found else None
        row[z_err.key(label)] = _relative(zeta[k], ref_zeta[k]) if found else None


def structure_metrics(result: Any, truth: Mapping[str, Any]) -> dict[str, Any]:
    """The element, linear-mode and per-well columns of one identified structure against the truth."""
    from ..model.modes import StructureModes

    row: dict[str, Any] = {}
    for name, ref in dict(truth["coefficients"]).items():
        value = result.coefficient(name)
        row[col.COEF.key(name)] = value
        row[col.COEF_ERROR.key(name)] = _relative(value, float(ref))
    ref_linear = truth["linear_modes"]
    lm = result.linear_modes
    labels = [f"m{k + 1}" for k in range(len(ref_linear["fn_hz"]))]
    fams = (col.LINEAR_FN, col.LINEAR_FN_ERROR, col.LINEAR_ZETA, col.LINEAR_ZETA_ERROR)
    _mode_rows(row, lm.fn_hz, lm.zeta, ref_linear, labels, fams)
    for agg, fam in (
        (col.LINEAR_FN_ERROR_MAX, col.LINEAR_FN_ERROR),
        (col.LINEAR_ZETA_ERROR_MAX, col.LINEAR_ZETA_ERROR),
    ):
        values = [abs(row[fam.key(lab)]) for lab in labels if row.get(fam.key(lab)) is not None]
        row[agg.key()] = max(values) if values else None
    ref_stable = [np.asarray(p, dtype=float) for p in truth["equilibria"]["stable"]]
    ref_modes = [StructureModes.from_dict(m) for m in truth["modes"]]
    found = [np.asarray(p, dtype=float) for p in (result.equilibria.stable if result.equilibria else ())]
    modes = list(result.modes)
    missing = 0
    for k, (z_ref, m_ref) in enumerate(zip(ref_stable, ref_modes, strict=False)):
        label = equilibrium_label(k)
        if not found:
            missing += 1
            continue
        j = int(np.argmin([np.linalg.norm(p - z_ref) for p in found]))
        scale = np.linalg.norm(z_ref)
        # a well far from its reference is not this well (the relative error of z* > 50 %)
        if scale > 0 and np.linalg.norm(found[j] - z_ref) > 0.5 * scale:
            missing += 1
            continue
        if scale > 0:  # relative to |z*_ref|: not defined for a well at the origin
            row[col.EQ_ERROR.key(label)] = float(100 * np.linalg.norm(found[j] - z_ref) / scale)
        if j < len(modes):
            mlabels = [f"{label}.m{i + 1}" for i in range(len(m_ref))]
            ref_dict = {"fn_hz": m_ref.fn_hz, "zeta": m_ref.zeta}
            _mode_rows(row, modes[j].fn_hz, modes[j].zeta, ref_dict, mlabels, (None, col.WELL_FN_ERROR, None,
                                                                              col.WELL_ZETA_ERROR))  # fmt: skip
    row[col.EQ_FOUND.key()] = len(found)
    row[col.EQ_EXPECTED.key()] = len(ref_stable)
    row[col.EQ_MISSING.key()] = missing
    return row


def execute_structure_run(spec: Any, base_row: Mapping[str, Any]) -> dict[str, Any]:
    """Simulate, identify and score one run of a structure dataset (module docstring).

    Returns
    -------
    dict
        ``{"run_id", "row", "result", "reference", "arrays"}`` as :func:`nlid.study.worker.execute_run`.
    """
    from ..base.jsonable import to_jsonable
    from ..identification.pipeline import identify

    ds = spec.dataset
    preset = ds.source.preset()
    noise = ds.source.noise
    noise = dict(noise) if isinstance(noise, Mapping) else float(noise)
    record = preset.simulate(spec.seed, noise=noise, channels=ds.source.channels)
    truth = record.meta["reference"]
    mass = ds.mass.value(None, record.mass)
    if mass is None:  # the study estimates it: say so, or identify takes the record's mass matrix
        mass = ESTIMATE
    result, cost = timed_identification(
        lambda: identify(record, spec.terms, spec.method, mass=mass, options=dict(spec.options), without=spec.without),
        record,
    )
    row = {**base_row, **cost}
    row[col.EPS.key()] = max(result.eps_percent) if result.eps_percent else None
    notes = list(result.warnings)
    if type(ds.holdout).__name__ != "NoHoldout" or ds.slices:
        notes.append("held-out scores and damping slices are not computed for structures of several DOFs")
    notes += [f"NOT TRUSTED: {flag}" for flag in result.flags]  # what physics forbids, as on one DOF
    if spec.response is not None:  # said, never silently left out
        notes.append("response: not computed for a structure in a study (nlid.response.frequency_response on the fit)")
    row[col.WARNINGS.key()] = " | ".join(notes)
    row.update(structure_metrics(result, truth))
    if spec.posterior is not None:  # the element coefficients' intervals (nlid.bayes.structure)
        from .. import bayes
        from ..errors import NlidError

        try:
            posterior = bayes.posterior_metrics(
                record, result, {"coefficients": truth["coefficients"]}, **dict(spec.posterior)
            )
            row.update(posterior_columns(posterior))
        except NlidError as exc:  # a posterior that cannot be reported is a warning: the run keeps its metrics
            row[col.WARNINGS.key()] = " | ".join([*notes, f"posterior: {exc}"])
    reference = {"coefficients": dict(truth["coefficients"]), "structure": truth}
    return {
        "run_id": spec.run_id,
        "row": to_jsonable(row),
        "result": result.to_dict(),
        "reference": to_jsonable(reference),
        "arrays": {k: np.asarray(v) for k, v in result.arrays.items()},
    }
