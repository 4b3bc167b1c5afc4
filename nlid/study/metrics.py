"""The metrics of one run: one flat row of numbers, flags and notes.

Column names (errors are percentages, signed unless noted):

``eps_percent``
    Eq. 26 on the estimation data, computed by the core from the data and the
    returned coefficients (:func:`nlid.identify` never trusts the plugin's).
``eps_holdout_percent``
    Eq. 26 of the identified model on the held-out data
    (:meth:`nlid.IdentifiedModel.score`, the one scoring path of
    :mod:`nlid.scoring`).
``coef:<term>``, ``coef_error_pct:<term>``
    Identified coefficient and ``100 (theta - theta_ref) / |theta_ref|`` for
    every term with a non-zero reference.
``mass``, ``mass_error_pct``
    Mass used or estimated; its error when estimated and a reference exists.
``eq_expected``, ``eq_found``, ``eq_missing``
    Reference stable equilibria, identified ones, and reference equilibria no
    identified one could be matched to (a method that misses a well shows it).
``eq:sK``, ``eq_error_pct:sK``, ``eq_error_max_pct``
    Identified equilibrium matched to the K-th reference stable equilibrium
    (ascending), its error relative to ``|z*_ref|`` (absolute, Table 7
    style), and the largest of them (``NaN`` if one is missing).
``fn_hz:sK``, ``fn_error_pct:sK``, ``zeta:sK``, ``zeta_error_pct:sK``
    Underlying-linear natural frequency and damping ratio at that
    equilibrium (Eq. 8, 22) and their errors.
``rms:<term>``, ``quality:<term>``
    RMS contribution of each term to the identified restoring force (paper
    Fig. 22) and the method's quality indicator when it reports one (NSI's
    E[Re/Im], paper Table 5); see :func:`surface_metrics`.
``freerun_nrmse_pct``, ``freerun_rmse``, ``freerun_note``
    Free-run simulation error of the identified model driven by the held-out
    force, with the chaos check (:func:`nlid.scoring.free_run_error`: the
    same number ``nlid discover`` reports for the same model and record):
    ``100 RMS(z_sim - z) / std(z)`` and the RMS error in the record's unit;
    the note says why it was skipped.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .. import physics
from ..balance import regression_data
from ..errors import NlidError
from ..identified import IdentifiedModel
from ..record import Record
from ..scoring import damping_slice

__all__ = [
    "coefficient_metrics",
    "equilibrium_metrics",
    "holdout_metrics",
    "surface_metrics",
]

NAN = float("nan")


def _pct(value: float, ref: float) -> float:
    return 100.0 * (value - ref) / abs(ref) if ref else NAN


def coefficient_metrics(result: IdentifiedModel, reference: dict[str, Any]) -> dict[str, float]:
    """``coef:<term>``, ``coef_error_pct:<term>``, ``mass`` and ``mass_error_pct``."""
    row: dict[str, float] = {}
    ref = reference.get("coefficients") or {}
    for name, value in result.coefficients.items():
        row[f"coef:{name}"] = float(value)
        if ref.get(name):
            row[f"coef_error_pct:{name}"] = _pct(value, ref[name])
    row["mass"] = NAN if result.mass is None else float(result.mass)
    if result.mass_estimated and result.mass is not None and reference.get("mass"):
        row["mass_error_pct"] = _pct(result.mass, reference["mass"])
    return row


def match_equilibria(expected: list[float], found: list[float]) -> dict[int, int]:
    """Pair reference and identified equilibria, nearest first, each used once.

    Returns
    -------
    dict
        ``{index in expected: index in found}``; unmatched expected ones are absent.
    """
    pairs = sorted((abs(e - f), i, j) for i, e in enumerate(expected) for j, f in enumerate(found))
    used_i: set[int] = set()
    used_j: set[int] = set()
    out = {}
    for _, i, j in pairs:
        if i in used_i or j in used_j:
            continue
        out[i] = j
        used_i.add(i)
        used_j.add(j)
    return out


def equilibrium_metrics(result: IdentifiedModel, reference: dict[str, Any]) -> dict[str, float]:
    """Equilibrium counts and errors, and the modal parameters at each matched equilibrium."""
    found = sorted(result.equilibria.stable) if result.equilibria is not None else []
    row: dict[str, float] = {"eq_found": float(len(found))}
    expected = reference.get("equilibria")
    if not expected:
        for k, m in enumerate(result.modal, start=1):
            row[f"fn_hz:s{k}"] = m.fn_hz
            row[f"zeta:s{k}"] = m.zeta
        return row
    ref_modal = reference.get("modal") or []
    match = match_equilibria(list(expected), found)
    # modal parameters are matched on their own: a method may linearise at its
    # own reference point (nsi-shift: each well's shifted zero) rather than at
    # the equilibrium of the combined model
    modal = list(result.modal)
    modal_match = match_equilibria(list(expected), [m.equilibrium for m in modal])
    row["eq_expected"] = float(len(expected))
    row["eq_missing"] = float(len(expected) - len(match))
    errors = []
    for i, z_ref in enumerate(expected):
        label = f"s{i + 1}"
        if i not in match:
            row[f"eq:{label}"] = NAN
            row[f"eq_error_pct:{label}"] = NAN
            errors.append(NAN)
            continue
        z = found[match[i]]
        err = 100.0 * abs(z - z_ref) / abs(z_ref) if z_ref else NAN
        row[f"eq:{label}"] = z
        row[f"eq_error_pct:{label}"] = err
        errors.append(err)
        m = modal[modal_match[i]] if i in modal_match else None
        if m is not None:
            row[f"fn_hz:{label}"] = m.fn_hz
            row[f"zeta:{label}"] = m.zeta
            if i < len(ref_modal):
                row[f"fn_error_pct:{label}"] = _pct(m.fn_hz, ref_modal[i]["fn_hz"])
                row[f"zeta_error_pct:{label}"] = _pct(m.zeta, ref_modal[i]["zeta"])
    row["eq_error_max_pct"] = max(errors) if errors and not any(math.isnan(e) for e in errors) else NAN
    return row


def holdout_metrics(heldout: Record | None, fit: IdentifiedModel, free_run: bool = True) -> dict[str, Any]:
    """``eps_holdout_percent`` and the free-run columns, from :meth:`nlid.IdentifiedModel.score`."""
    row: dict[str, Any] = {
        "eps_holdout_percent": NAN,
        "freerun_nrmse_pct": NAN,
        "freerun_rmse": NAN,
        "freerun_note": "skipped: disabled in the study" if not free_run else "skipped: no held-out data",
    }
    if heldout is None:
        return row
    scores = fit.score(heldout, free_run=free_run)
    row["eps_holdout_percent"] = scores.eps_percent
    if free_run:
        row.update(
            freerun_nrmse_pct=scores.freerun_nrmse_percent,
            freerun_rmse=scores.freerun_rmse,
            freerun_note=scores.freerun_note,
        )
    return row


#: Largest number of measured points kept per damping slice (for the figure).
SLICE_POINTS = 3000


def surface_metrics(
    record: Record,
    result: IdentifiedModel,
    slices: tuple[float, ...] = (),
) -> tuple[dict[str, float], dict[str, np.ndarray]]:
    """What the identified restoring surface is made of, and how it meets the data.

    Returns
    -------
    row : dict
        ``rms:<term>``: RMS of each term's contribution ``theta_i g_i`` over
        the record (paper Fig. 22); ``quality:<term>``: the method's own
        quality indicator when it reports one in ``diagnostics["quality"]``
        (NSI: E[Re/Im], paper Table 5).
    arrays : dict
        For each position ``z0`` in ``slices`` (paper Fig. 21 b-d, needs the
        mass and a velocity-dependent model): ``slice<k>:z0``, the measured
        damping force near ``z0`` against velocity (``slice<k>:v``,
        ``slice<k>:measured``, at most :data:`SLICE_POINTS` of them) and the
        identified ``D(z0, v)`` (``slice<k>:v_grid``, ``slice<k>:model``).
    """
    model = result.model
    row: dict[str, float] = {}
    for term, value in (result.diagnostics.get("quality") or {}).items():
        if value is not None:
            row[f"quality:{term}"] = float(value)
    data = regression_data(record, model)
    for term, value in physics.rms_contributions(model, result.theta, data.z, data.v).items():
        row[f"rms:{term}"] = value
    arrays: dict[str, np.ndarray] = {}
    if result.mass is None or data.v is None:
        return row, arrays
    for k, z0 in enumerate(slices):
        try:
            sl = damping_slice(data, model, result.theta, result.mass, z0)
        except NlidError:
            continue
        keep = np.linspace(0, sl.v.size - 1, min(SLICE_POINTS, sl.v.size)).astype(int)
        arrays[f"slice{k}:z0"] = np.array(sl.z0)
        arrays[f"slice{k}:v"] = sl.v[keep]
        arrays[f"slice{k}:measured"] = sl.measured[keep]
        arrays[f"slice{k}:v_grid"] = sl.v_grid
        arrays[f"slice{k}:model"] = sl.model
    return row, arrays
