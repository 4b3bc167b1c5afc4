"""The force balance identifiers build on: ``f - m a = G theta`` on a common footing.

This is the plugin-facing axis of nlid (like pysindy's feature library and
differentiation, composed): :func:`regression_data` evaluates a model's terms
(the design matrix ``G``) on a record, together with the force and the
acceleration, so that every channel has passed through the same zero-phase
filters when any of them had to be estimated from the displacement
(:mod:`nlid.signal.derivatives`). The restoring force of Eq. 25 is then
``R_e = f - m a`` and the balance ``R_e = G theta + e`` (Eq. 25-26) is what
least-squares, sparse and Bayesian methods fit, and what the core scores
(:mod:`nlid.scoring`).
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass, field

import numpy as np

from ..base.validate import check_cutoff
from ..data.record import Record
from ..errors import DataError
from ..model.terms import Model
from ..signal import derivatives
from ..signal.channelsource import ChannelSource

__all__ = [
    "RegressionData",
    "regression_data",
    "settled_samples",
    "share_channels",
    "suggested_cutoff",
    "REGRESSOR_BAND_FACTOR",
    "EDGE_PERIODS",
]


#: The regressors are evaluated on z and v kept to this multiple of the
#: equation band (capped at 0.4 fs) before being cut to the band: measured on
#: paper-numerical with 2 % noise, a factor 4 instead of 1 cuts the RFS error
#: of mu from 3.1 % to 0.6 % and of c_v from 41 % to 2.5 %.
REGRESSOR_BAND_FACTOR = 4.0
#: Samples within this many cut-off periods of either end are dropped from a
#: filtered force balance: there the filters have not settled (on
#: paper-numerical the first samples' residual reaches 90 N).
EDGE_PERIODS = 3.0


@dataclass(frozen=True)
class RegressionData:
    """Force, acceleration and regressors on a common footing.

    When a channel the model needs (the acceleration, or the velocity of
    velocity-dependent terms) is estimated from the displacement, the force
    balance ``f - m a = G theta`` is formed in the band of the differentiating
    filter (cut-off ``fc``):

    * ``a`` is the displacement differentiated twice through the low-pass at
      ``fc`` (or the measured ``a`` low-passed at ``fc``);
    * each regressor ``g_i(z, v)`` is evaluated on ``z`` and ``v`` kept to the
      wider band ``REGRESSOR_BAND_FACTOR * fc`` (the terms are nonlinear, so
      their in-band part depends on the motion above ``fc``), then low-passed
      at ``fc``;
    * the force is low-passed at ``fc``; a zero-order-held force
      (``record.force_hold == "zoh"``) compared with an acceleration derived
      from the motion is first given the hold's response
      (:func:`nlid.signal.derivatives.zoh_equivalent`), since the motion feels it
      half a sample late.

    Every filter is the same zero-phase response (:mod:`nlid.signal.derivatives`), so
    no phase or gain mismatch enters. The ``EDGE_PERIODS * fs / fc`` samples
    at each end, where the filters have not settled, are dropped from every
    array. With every needed channel measured nothing is filtered or dropped:
    the samples are consistent as they are.

    Attributes
    ----------
    f, a
        Force and acceleration, shape ``(N,)``.
    G
        Regressor matrix, shape ``(N, p)``.
    z, v
        The displacement and velocity the regressors were evaluated on.
    filtered_at
        The equation band ``fc`` in Hz, or ``None``.
    provenance
        Where each channel came from (one line of text each).
    kept
        The slice of the record's samples that hold a settled force balance;
        the arrays are these samples (or every sample, with ``trim=False``).
    sources
        Where each channel came from as plain data (measured or estimated, by which filter, at which
        cut-off: :class:`~nlid.signal.channelsource.ChannelSource`); its texts are :attr:`provenance`.
    """

    f: np.ndarray
    a: np.ndarray
    G: np.ndarray
    z: np.ndarray
    v: np.ndarray | None
    filtered_at: float | None
    provenance: dict[str, str]
    kept: slice = field(default_factory=lambda: slice(None))
    sources: dict[str, ChannelSource] = field(default_factory=dict)

    def restoring_force(self, mass: float) -> np.ndarray:
        """``R_e = f - m a`` (Eq. 25)."""
        return self.f - mass * self.a


#: Most filtered regressor columns kept per record (about 8 bytes x samples each).
MAX_CACHED_COLUMNS = 256
_CACHE: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _record_cache(record: Record) -> dict:
    """The filtered channels and columns already computed for this record (dropped with the record)."""
    try:
        return _CACHE.setdefault(record, {})
    except TypeError:  # pragma: no cover - a record type without weak references: no caching
        return {}


def _cached(cache: dict, key: tuple, compute):
    if key not in cache:
        value = compute()
        for arr in value if isinstance(value, tuple) else (value,):
            if isinstance(arr, np.ndarray):
                arr.setflags(write=False)
        cache[key] = value
    return cache[key]


def share_channels(source: Record, record: Record) -> None:
    """Let ``record`` re-use what :func:`regression_data` already computed for ``source`` where it is the same.

    Two kinds of records differ from another in one part only:

    * the bias correction's noisy copies of one simulation (:mod:`nlid.bayes.bias`) differ in their motion:
      the filtered force (and the filtered measured acceleration) of ``source`` is re-used where it is equal
      sample by sample (same force hold);
    * a record whose force went through an input path (:mod:`nlid.estimation.inputpath`) differs in its force only:
      everything computed from its motion (the filtered displacement, the estimated velocity and
      acceleration, the filtered regressors, the suggested cut-off) is re-used.

    The numbers are the same to the bit; nothing is shared between records of different sampling frequencies.
    """
    if source is record or source.fs != record.fs:
        return
    src, dst = _record_cache(source), _record_cache(record)
    same_f = source.force_hold == record.force_hold and np.array_equal(source.f, record.f)
    same_a = source.is_measured("a") and record.is_measured("a") and np.array_equal(source.a, record.a)
    same_motion = (
        np.array_equal(source.z, record.z)
        and source.is_measured("v") == record.is_measured("v")
        and source.is_measured("a") == record.is_measured("a")
        and (not source.is_measured("v") or np.array_equal(source.v, record.v))
        and (not source.is_measured("a") or same_a)
    )
    for key, value in src.items():
        if not isinstance(key, tuple):
            if key == "cutoff" and same_motion:
                dst.setdefault(key, value)
            continue
        if (key[0] in ("f", "f-zoh") and same_f) or (key[0] == "a" and same_a):
            dst.setdefault(key, value)
        elif key[0] in _MOTION_KEYS and same_motion:
            dst.setdefault(key, value)


#: Cache entries computed from a record's motion alone (:func:`share_channels`).
_MOTION_KEYS = ("z", "v", "v~", "a", "a~", "col")


def settled_samples(n: int, fs: float, fc: float, unknowns: int) -> slice:
    """The samples of a filtered force balance that have settled: ``EDGE_PERIODS * fs / fc`` dropped at each end.

    Raises
    ------
    DataError
        Fewer than ``max(64, 4 unknowns)`` samples are left.
    """
    edge = int(np.ceil(EDGE_PERIODS * fs / fc))
    if n - 2 * edge < max(64, 4 * unknowns):
        raise DataError(
            f"record too short for a filtered force balance: {n} samples, {edge} dropped at each end "
            f"at the cut-off {fc:.3g} Hz"
        )
    return slice(edge, n - edge)


def suggested_cutoff(record: Record) -> float:
    """:func:`nlid.signal.derivatives.suggest_cutoff` of the record's ``z`` (Hz), computed once per record.

    The default equation band of :func:`regression_data`; an identifier that
    derives its own filters from the same rule (nsi-ip) asks here, so the
    Welch spectrum of a long record is not computed twice in one
    identification.
    """
    cache = _record_cache(record)
    if "cutoff" not in cache:
        cache["cutoff"] = derivatives.suggest_cutoff(record.z, record.fs)
    return float(cache["cutoff"])


def _lowpass_columns(values: np.ndarray, fs: float, fc: float) -> np.ndarray:
    """:func:`nlid.signal.derivatives.lowpass` of each column; a constant column (the term ``1``) is its own low-pass.

    The filter removes the line through a column's end samples and passes it
    unchanged, so a constant comes out exactly as it went in: skipping it
    gives the same numbers to the bit and saves one FFT filtering of the
    record's length. ``values`` (a new array) is filtered in place.
    """
    varying = [j for j in range(values.shape[1]) if np.any(values[:, j] != values[0, j])]
    # what lowpass does with a matrix (one column at a time), in place, the filter's response computed once
    return derivatives.lowpass_columns(values, fs, fc, varying)


def _columns(cache: dict, model: Model, z: np.ndarray, v: np.ndarray | None, fs: float, fc: float, wide: float):
    """The model's regressors evaluated on the wide-band ``z``, ``v`` and low-passed at ``fc``, column by column.

    Each column depends only on its term (and the ``px`` roots), the record
    and the two bands, so it is computed once per record: a discovery run
    fits the same terms dozens of times.
    """
    keys = [("col", fc, wide, t.name, model.px_roots if t.uses_px else None) for t in model.terms]
    missing = [i for i, k in enumerate(keys) if k not in cache]
    if missing:
        sub = Model(tuple(model.terms[i] for i in missing), model.px_roots)
        # evaluated and filtered column by column in a column-major matrix (each column contiguous), whose
        # columns the cache keeps as they are (read-only views, no copies); the caller gets its own row-major G
        values = _lowpass_columns(np.asarray(sub.evaluate(z, v, order="F"), dtype=float), fs, fc)
        if sum(1 for k in cache if k[0] == "col") + len(missing) > MAX_CACHED_COLUMNS:
            for k in [k for k in cache if k[0] == "col"]:
                del cache[k]
        for j, term in enumerate(sub.terms):
            column = values[:, j]
            column.setflags(write=False)
            cache[keys[model.terms.index(term)]] = column
        if len(missing) == len(keys):  # every column new, in the model's order: G is values, row-major
            return np.ascontiguousarray(values)
    return np.column_stack([cache[k] for k in keys]) if keys else np.empty((z.size, 0))


def regression_data(
    record: Record, model: Model, *, cutoff: float | None = None, trim: bool = True, regressors: bool = True
) -> RegressionData:
    """Evaluate the model's regressors and the force balance on a record.

    Parameters
    ----------
    record
        The data; missing ``v`` and ``a`` are estimated from ``z``.
    model
        The terms.
    cutoff
        Equation band ``fc`` in Hz (default
        :func:`nlid.signal.derivatives.suggest_cutoff` of ``z``); only used when a
        needed channel is estimated.
    trim
        Drop the unsettled ends (default). With ``trim=False`` the arrays keep
        every sample of the record and :attr:`RegressionData.kept` says which
        of them hold a settled force balance (for callers that filter
        further, or that mark the ends as missing themselves).
    regressors
        Evaluate the model's columns (default). With ``False``, ``G`` has no
        columns and the model only says which channels are needed: for
        callers that evaluate the regressors themselves.
    """
    check_cutoff(cutoff, record.fs)
    needs_v = model.uses_velocity
    estimated = not record.is_measured("a") or (needs_v and not record.is_measured("v"))
    sources = {c: record.channel_source(c) for c in record.channels}
    if not estimated:
        v = record.v if needs_v else None
        G = model.evaluate(record.z, v) if regressors else np.empty((record.n, 0))
        return RegressionData(record.f, record.a, G, record.z, v, None, _texts(sources), sources=sources)
    fs = record.fs
    cache = _record_cache(record)
    fc = suggested_cutoff(record) if cutoff is None else float(cutoff)
    wide = min(REGRESSOR_BAND_FACTOR * fc, derivatives.CUTOFF_MAX_FRACTION * fs)
    if needs_v and not record.is_measured("v") and ("z", wide) not in cache and ("v~", wide) not in cache:
        # the wide-band z and the velocity differentiated from it share one forward transform (same numbers)
        z_wide, v_wide = derivatives.lowpass_and_derivatives(record.z, fs, wide, (0, 1))
        _cached(cache, ("z", wide), lambda: z_wide)
        _cached(cache, ("v~", wide), lambda: (v_wide, derivatives.DerivativeFilter(cutoff=float(wide))))
    z = _cached(cache, ("z", wide), lambda: derivatives.lowpass(record.z, fs, wide))
    v = None
    if needs_v:
        if record.is_measured("v"):
            v = _cached(cache, ("v", wide), lambda: derivatives.lowpass(record.v, fs, wide))
        else:
            v, used = _cached(
                cache, ("v~", wide), lambda: derivatives.differentiate(record.z, fs, order=1, cutoff=wide)
            )
            sources["v"] = ChannelSource.differentiated(used, "z")
    G = _columns(cache, model, z, v, fs, fc, wide) if regressors else np.empty((record.n, 0))
    if record.is_measured("a"):
        a = _cached(cache, ("a", fc), lambda: derivatives.lowpass(record.a, fs, fc))
        f = _cached(cache, ("f", fc), lambda: derivatives.lowpass(record.f, fs, fc))
    else:
        a, used = _cached(cache, ("a~", fc), lambda: derivatives.differentiate(record.z, fs, order=2, cutoff=fc))
        sources["a"] = ChannelSource.differentiated(used, "z")
        # the acceleration of the motion feels a held force half a sample late
        if record.force_hold == "zoh":
            f = _cached(cache, ("f-zoh", fc), lambda: derivatives.zoh_equivalent(record.f, fs, fc))
        else:
            f = _cached(cache, ("f", fc), lambda: derivatives.lowpass(record.f, fs, fc))
    keep = settled_samples(record.n, fs, fc, len(model))
    prov = _texts(sources)
    if not trim:
        return RegressionData(f, a, G, z, v, fc, prov, keep, sources)
    v_kept = None if v is None else v[keep]
    return RegressionData(f[keep], a[keep], G[keep], z[keep], v_kept, fc, prov, keep, sources)


def _texts(sources: dict[str, ChannelSource]) -> dict[str, str]:
    """The one line of each channel's source (:attr:`RegressionData.provenance`)."""
    return {c: s.text for c, s in sources.items()}
