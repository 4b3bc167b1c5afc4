"""The metrics of one run: one flat row of numbers, flags and notes.

Column names (each family declared once in :mod:`nlid.study.columns`;
errors are percentages, signed unless noted):

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
``freerun_nrmse_pct``, ``freerun_fit_pct``, ``freerun_rmse``, ``freerun_note``
    Free-run simulation error of the identified model driven by the held-out
    force, with the chaos check (:func:`nlid.scoring.free_run_error`: the
    same number ``nlid discover`` reports for the same model and record):
    ``100 RMS(z_sim - z) / std(z)``, MATLAB ``compare``'s fit
    ``100 (1 - |z - z_sim| / |z - mean(z)|)`` and the RMS error in the
    record's unit; the note says why it was skipped.
``ci_lo:<term>``, ``ci_hi:<term>``, ``ci_width:<term>``, ``ci_covers:<term>``, ``posterior:...``
    A ``[posterior]`` table's credible intervals and their coverage (:func:`posterior_columns`, from
    :func:`nlid.bayes.posterior_metrics`).
``freerun_rule``, ``freerun_scored_samples``
    The transient rule the free run was scored under, as applied (the
    dataset's ``freerun_rule``, else the held-out record's own:
    :func:`nlid.scoring.default_rule`; a held-out part of a periodic record is
    scored in periodic steady state), and the number of samples scored.

The core returns typed values (a :class:`~nlid.identified.reference.Comparison`'s
:class:`~nlid.identified.compared.CoefficientComparison` and
:class:`~nlid.identified.compared.EquilibriumComparison`, the
:class:`~nlid.bayes.PosteriorMetrics`, the :class:`~nlid.scoring.Scores`); the
functions here flatten them into the study's columns.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from ..data.record import Record
from ..errors import InputError, NlidError
from ..estimation.balance import regression_data
from ..identified.compared import CoefficientComparison, EquilibriumComparison, equilibrium_label
from ..identified.model import IdentifiedModel
from ..identified.reference import Comparison, Reference, compare
from ..model import physics
from ..runtime.memory import PeakMemory
from ..scoring import damping_slice
from . import columns as col

if TYPE_CHECKING:  # the posterior is loaded only by a study that asks for it
    from ..bayes import PosteriorMetrics

__all__ = [
    "coefficient_columns",
    "equilibrium_columns",
    "comparison_columns",
    "posterior_columns",
    "coefficient_metrics",
    "equilibrium_metrics",
    "holdout_metrics",
    "surface_metrics",
]

NAN = float("nan")


def timed_identification(identify: Callable[[], Any], record: Any) -> tuple[Any, dict[str, Any]]:
    """Run ``identify`` (a call of :func:`nlid.identify` on ``record``); its result and the run's cost columns.

    ``seconds`` is the call's wall time and ``peak_memory_mb`` the memory it added
    (:class:`nlid.runtime.memory.PeakMemory`: untraced where the system keeps the peak, so the times of
    different methods compare); ``method_seconds`` is the identifier's own time; ``samples``, ``z_min``
    and ``z_max`` describe the record (one DOF or a structure's every channel).
    """
    with PeakMemory() as peak:
        start = time.perf_counter()
        result = identify()
        seconds = time.perf_counter() - start
    return result, {
        col.SECONDS.key(): seconds,
        col.PEAK_MEMORY.key(): peak.bytes / 1e6,
        col.METHOD_SECONDS.key(): result.seconds,
        col.SAMPLES.key(): record.n,
        col.Z_MIN.key(): float(record.z.min()),
        col.Z_MAX.key(): float(record.z.max()),
    }


def coefficient_columns(values: CoefficientComparison) -> dict[str, float]:
    """``coef:<term>``, ``coef_error_pct:<term>`` (non-zero references only), ``mass``, ``mass_error_pct``."""
    row: dict[str, float] = {}
    for name, value in values.coefficients.items():
        row[col.COEF.key(name)] = value
        if name in values.errors:
            row[col.COEF_ERROR.key(name)] = values.errors[name]
    row[col.MASS.key()] = values.mass
    if values.mass_error is not None:
        row[col.MASS_ERROR.key()] = values.mass_error
    return row


def equilibrium_columns(values: EquilibriumComparison) -> dict[str, float]:
    """Equilibrium counts and errors, and the modal parameters matched to each reference equilibrium.

    Without reference equilibria: ``eq_found`` and the fit's modes (``fn_hz:sK``, ``zeta:sK`` in its order).
    """
    row: dict[str, float] = {col.EQ_FOUND.key(): float(values.found)}
    if not values.wells:
        for k, m in enumerate(values.modes):
            row[col.FN.key(equilibrium_label(k))] = m.fn_hz
            row[col.ZETA.key(equilibrium_label(k))] = m.zeta
        return row
    row[col.EQ_EXPECTED.key()] = float(len(values.wells))
    row[col.EQ_MISSING.key()] = float(values.missing)
    for i, well in enumerate(values.wells):
        label = equilibrium_label(i)
        row[col.EQ.key(label)] = NAN if well.found is None else well.found
        row[col.EQ_ERROR.key(label)] = well.error
        if well.mode is not None:
            row[col.FN.key(label)] = well.mode.fn_hz
            row[col.ZETA.key(label)] = well.mode.zeta
            if well.fn_error is not None and well.zeta_error is not None:
                row[col.FN_ERROR.key(label)] = well.fn_error
                row[col.ZETA_ERROR.key(label)] = well.zeta_error
    row[col.EQ_ERROR_MAX.key()] = values.error_max
    return row


def comparison_columns(comparison: Comparison) -> dict[str, float]:
    """The columns of a fit against its reference: :func:`coefficient_columns` then :func:`equilibrium_columns`."""
    return {**coefficient_columns(comparison.coefficients()), **equilibrium_columns(comparison.equilibria())}


def posterior_columns(values: PosteriorMetrics) -> dict[str, float | bool]:
    """``posterior:level``, then per sampled term ``ci_lo``, ``ci_hi``, ``ci_width`` and (truth known) ``ci_covers``,
    then ``posterior:tau``, ``posterior:seconds`` and ``posterior:max_bias_shift_sd``."""
    row: dict[str, float | bool] = {col.POSTERIOR_LEVEL.key(): values.level}
    for name, (lo, hi) in values.intervals.items():
        row[col.CI_LO.key(name)], row[col.CI_HI.key(name)], row[col.CI_WIDTH.key(name)] = lo, hi, hi - lo
        if name in values.covers:
            row[col.CI_COVERS.key(name)] = values.covers[name]
    row[col.POSTERIOR_TAU.key()] = values.tau
    row[col.POSTERIOR_SECONDS.key()] = values.seconds
    row[col.POSTERIOR_BIAS_SHIFT.key()] = values.max_bias_shift_sd
    return row


def coefficient_metrics(result: IdentifiedModel, reference: Reference | Mapping[str, Any]) -> dict[str, float]:
    """:func:`coefficient_columns` of ``result`` against ``reference`` (:meth:`Comparison.coefficients`)."""
    return coefficient_columns(compare(result, reference).coefficients())


def equilibrium_metrics(result: IdentifiedModel, reference: Reference | Mapping[str, Any]) -> dict[str, float]:
    """:func:`equilibrium_columns` of ``result`` against ``reference`` (:meth:`Comparison.equilibria`: the
    reference's equilibria are the columns, the modes are matched to them by position)."""
    return equilibrium_columns(compare(result, reference).equilibria())


def holdout_metrics(
    heldout: Record | None, fit: IdentifiedModel, free_run: bool = True, rule: str = ""
) -> dict[str, Any]:
    """``eps_holdout_percent`` and the free-run columns, from :meth:`nlid.IdentifiedModel.score`.

    ``rule`` is the dataset's ``freerun_rule`` (:func:`nlid.scoring.rule_from_spec`'s spelling; empty: the
    held-out record's own).
    """
    row: dict[str, Any] = {
        col.EPS_HOLDOUT.key(): NAN,
        col.FREERUN_NRMSE.key(): NAN,
        col.FREERUN_FIT.key(): NAN,
        col.FREERUN_RMSE.key(): NAN,
        col.FREERUN_NOTE.key(): "skipped: disabled in the study" if not free_run else "skipped: no held-out data",
        col.FREERUN_RULE.key(): "",
        col.FREERUN_SCORED.key(): 0,
    }
    if heldout is None:
        return row
    scores = fit.score(heldout, free_run=free_run, rule=(rule or None) if free_run else None)
    row[col.EPS_HOLDOUT.key()] = scores.eps_percent
    if free_run:
        row[col.FREERUN_NRMSE.key()] = scores.freerun_nrmse_percent
        row[col.FREERUN_FIT.key()] = scores.freerun_fit_percent
        row[col.FREERUN_RMSE.key()] = scores.freerun_rmse
        row[col.FREERUN_NOTE.key()] = scores.freerun_note
        row[col.FREERUN_RULE.key()] = scores.freerun_rule
        row[col.FREERUN_SCORED.key()] = scores.freerun_scored_samples
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
            row[col.QUALITY.key(term)] = float(value)
    data = regression_data(record, model)
    for term, value in physics.rms_contributions(model, result.theta, data.z, data.v).items():
        row[col.RMS.key(term)] = value
    arrays: dict[str, np.ndarray] = {}
    if result.mass is None or data.v is None:
        return row, arrays
    for k, z0 in enumerate(slices):
        try:
            sl = damping_slice(data, model, result.theta, result.mass, z0)
        except NlidError:
            continue
        keep = np.linspace(0, sl.v.size - 1, min(SLICE_POINTS, sl.v.size)).astype(int)
        arrays[col.SLICES.key(k, "z0")] = np.array(sl.z0)
        arrays[col.SLICES.key(k, "v")] = sl.v[keep]
        arrays[col.SLICES.key(k, "measured")] = sl.measured[keep]
        arrays[col.SLICES.key(k, "v_grid")] = sl.v_grid
        arrays[col.SLICES.key(k, "model")] = sl.model
    return row, arrays


def _peaks(response: Any) -> dict[float, tuple[float, float]]:
    """``{force: (frequency Hz, amplitude m)}``: the largest first-harmonic amplitude of the forced DOF over the
    stable points of the curves in frequency, per force amplitude."""
    lead = int(np.argmax(np.abs(response.forced))) + 1
    peaks: dict[float, tuple[float, float]] = {}
    for curve in response.curves:
        if curve.parameter != "frequency" or not np.any(curve.stable):
            continue
        amp = np.where(curve.stable, curve.amplitude(lead), -np.inf)
        k = int(np.argmax(amp))
        force = float(curve.force[0])
        if force not in peaks or amp[k] > peaks[force][1]:
            peaks[force] = (float(curve.frequency_hz[k]), float(amp[k]))
    return peaks


def response_metrics(
    result: IdentifiedModel, reference: Reference, *, force: Any, band: Any, harmonics: int = 7
) -> dict[str, Any]:
    """A study's ``[response]`` columns: the fit's frequency response beside the reference's true model's.

    The response is :func:`nlid.response.frequency_response` at the force amplitudes (N) over the band
    (Hz). The peak (frequency and first-harmonic amplitude of the forced DOF, the largest over the stable
    points) at the largest force is reported; against a reference that can run as a model
    (:meth:`~nlid.identified.reference.Reference.true_model`: coefficients and mass known, e.g. a simulated
    record's truth) the errors of the peak's frequency and amplitude, the largest over the force
    amplitudes (``response:peak_hz_error_pct``, ``response:peak_m_error_pct``).

    Raises
    ------
    NlidError
        The response cannot be computed (the worker turns it into a warning of the run).
    """
    from ..response import frequency_response

    start = time.perf_counter()
    fitted = frequency_response(result, force, band, harmonics=harmonics)
    peaks = _peaks(fitted)
    out: dict[str, Any] = {col.RESPONSE_FOLDS.key(): len(fitted.folds)}
    if peaks:
        top = max(peaks)
        out[col.RESPONSE_PEAK_HZ.key()], out[col.RESPONSE_PEAK_M.key()] = peaks[top]
    try:
        truth = reference.true_model("the dataset's reference")
    except InputError:
        truth = None
    if truth is not None and peaks:
        true_peaks = _peaks(frequency_response(truth, force, band, harmonics=harmonics))
        common = [f for f in peaks if f in true_peaks and true_peaks[f][1] > 0]
        if common:
            out[col.RESPONSE_PEAK_HZ_ERROR.key()] = max(
                100 * abs(peaks[f][0] - true_peaks[f][0]) / true_peaks[f][0] for f in common
            )
            out[col.RESPONSE_PEAK_M_ERROR.key()] = max(
                100 * abs(peaks[f][1] - true_peaks[f][1]) / true_peaks[f][1] for f in common
            )
    out[col.RESPONSE_SECONDS.key()] = time.perf_counter() - start
    return out
