"""What nsi-ip and nsi-shift share: options, velocity, cut-offs, BLAS threads, result pieces."""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from nlid.plugin import (
    CHANNEL_SOURCES,
    ChannelSource,
    DataError,
    FigureArray,
    InputError,
    Option,
    Record,
    derivatives,
    source_entries,
    suggested_cutoff,
)

if TYPE_CHECKING:
    from .fit import NSIFit
    from .reconstruction import Reconstruction

__all__ = [
    "COMMON_OPTIONS",
    "Velocity",
    "velocity_diagnostics",
    "velocity_estimate",
    "denoise_operator",
    "blas_threads",
    "fit_arrays",
    "well_suffix",
    "figure_arrays",
    "reconstruction",
    "reconstruction_diagnostics",
]

#: Default number of block rows (past and future horizons each). Measured with
#: nsi-ip on paper-numerical at 2 % noise (median of seeds 0-4, c_v / zeta- /
#: zeta+ errors): 50 rows 10.6 / 10.5 / 10.5 %, 75 rows 1.0 / 1.2 / 1.2 %, 100
#: rows 0.80 / 0.65 / 0.72 %, 150 rows 0.71 / 0.78 / 0.79 % (the stiffness
#: coefficients are within 0.2 % from 50 rows on). 100 is the margin over 75;
#: the cost grows as (2 i c)^3.
DEFAULT_BLOCK_ROWS = 100
#: Default cut-off of the velocity differentiator and of the de-noising
#: low-pass: this multiple of :func:`nlid.signal.derivatives.suggest_cutoff` of z (the
#: frequency where the displacement spectrum meets 100 x its noise floor),
#: capped at 0.4 fs. Measured with nsi-ip on paper-numerical at 2 % noise
#: (median of seeds 0-4, c_v / zeta-+ errors): 1.5 x (64 Hz) 0.80 / 0.65 / 0.72 %,
#: 2 x 0.77 / 0.79 / 0.93 %, 2.5 x 1.6 / 1.6 / 1.8 %, fs/20 (102 Hz, the
#: prototype's rule) 1.4 / 1.4 / 1.6 %, 1 x (43 Hz) 1.8 / 1.6 / 1.6 %; without
#: noise the rule gives ~490 Hz and every coefficient within 0.01 %.
CUTOFF_FACTOR = 1.5

COMMON_OPTIONS: tuple[Option, ...] = (
    Option(
        "block_rows",
        "int",
        DEFAULT_BLOCK_ROWS,
        "block rows i of the past and future horizons (the data Gram has 2i block rows)",
        minimum=2,
    ),
    Option("order", "int", None, "model order (auto: largest singular-value gap)", minimum=1, nullable=True),
    Option("max_order", "int", 10, "largest order the automatic choice considers", minimum=1),
    Option(
        "band",
        "str",
        "halfpower",
        "band of the coefficient average and ULS fit: half-power band of the ULS resonance, or [wn/2, 2wn]",
        choices=("halfpower", "octave"),
    ),
    Option("band_hz", "floats", None, "fixed band 'lo,hi' in Hz instead of 'band'", nullable=True, minimum=0.0),
    Option(
        "velocity",
        "str",
        None,
        "velocity for the basis functions: auto (measured v if present, else from z), "
        "differentiate (from z), integrate (from a measured a), measured",
        choices=("differentiate", "integrate", "measured"),
        nullable=True,
    ),
    Option(
        "velocity_cutoff",
        "float",
        None,
        "low-pass cut-off (Hz) of the differentiator for v from z (auto: 1.5 x the noise-floor cut-off of z)",
        minimum=0.0,
        nullable=True,
    ),
    Option(
        "denoise_cutoff",
        "float",
        None,
        "cut-off (Hz) of the low-pass that de-noises z in the basis functions (auto: as velocity_cutoff)",
        minimum=0.0,
        nullable=True,
    ),
    Option(
        "force_hold",
        "str",
        None,
        "how the force acts between samples: zoh (held, e.g. a DAC or the presets), sampled (a continuous "
        "signal's samples), auto (the record's meta 'force_hold', 'sampled' if absent)",
        choices=("zoh", "sampled"),
        nullable=True,
    ),
    Option("reconstruct", "bool", True, "complete v and de-noise z from the clean force (second pass)"),
    Option(
        "acceleration",
        "str",
        "fuse",
        "a measured acceleration: fuse (z below a crossover, a above it, for the basis functions' z and v "
        "when v comes from z) or ignore",
        choices=("fuse", "ignore"),
    ),
    Option(
        "crossover",
        "float",
        None,
        "crossover (Hz) of the z/a fusion (auto: where the two noise densities meet)",
        minimum=0.0,
        nullable=True,
    ),
    Option("noise_correction", "bool", True, "errors-in-variables correction of the data Gram and the B step"),
    Option(
        "intersample",
        "str",
        "gauss",
        "interval mean of the basis functions: gauss (Hermite interpolant), trapezoid, zoh (sample values)",
        choices=("gauss", "trapezoid", "zoh"),
    ),
    Option(
        "sign_calibration",
        "bool",
        True,
        "use E[sign(v_true) | v] = erf(v / sqrt(2) sigma_v) for sign(v) factors when v comes from noisy z",
    ),
    Option("noise_max_lag", "int", 128, "largest lag (samples) of the noise correction", minimum=0),
    Option(
        "zeta_max",
        "float",
        0.5,
        "a ULS is accepted only with damping ratios below this (rejects near-zero stiffness)",
        minimum=0.0,
        maximum=1.0,
    ),
    Option(
        "blas_threads",
        "int",
        1,
        "BLAS threads during the identification (auto: leave as is); 1 is fastest on a busy machine",
        minimum=1,
        nullable=True,
    ),
)


@dataclass(frozen=True)
class Velocity:
    """The velocity used in the basis functions and how it was obtained.

    Attributes
    ----------
    v
        The velocity (m/s).
    differentiate
        The differentiator applied to ``z`` (a linear operator), or ``None``
        if ``v`` did not come from ``z``.
    source
        How it was obtained, as plain data (reported under ``diagnostics["channel_sources"]["v"]``).
    """

    v: np.ndarray
    differentiate: Callable[[np.ndarray], np.ndarray] | None
    source: ChannelSource

    @property
    def provenance(self) -> str:
        """One line for the diagnostics (``diagnostics["velocity"]``)."""
        return self.source.text

    @property
    def cutoff(self) -> float | None:
        """Cut-off of the differentiator (Hz) or ``None``."""
        return self.source.cutoff_hz if self.differentiate is not None else None


def default_cutoff(z: np.ndarray, fs: float, suggested: float | None = None) -> float:
    """Default cut-off of the velocity differentiator and the de-noising low-pass (Hz).

    ``CUTOFF_FACTOR`` times :func:`nlid.signal.derivatives.suggest_cutoff` of ``z``
    (``suggested``, when already known), capped at
    ``nlid.signal.derivatives.CUTOFF_MAX_FRACTION`` of fs.
    """
    base = derivatives.suggest_cutoff(z, fs) if suggested is None else suggested
    return min(CUTOFF_FACTOR * base, derivatives.CUTOFF_MAX_FRACTION * fs)


#: Warning when the force's intersample behaviour is assumed, not known.
HOLD_ASSUMED = (
    "the record does not say how the force acted between samples: assumed a sampled continuous signal; "
    "if it was held over each sample (DAC output, simulation), pass --force-hold zoh (on paper-numerical "
    "the wrong assumption changes c_v and the damping ratios by 13 %)"
)


def force_hold(record: Record, how: str | None) -> tuple[str, bool]:
    """The force's intersample behaviour (the option, or the record's ``force_hold``) and whether it was assumed."""
    if how is not None:
        return how, False
    return record.force_hold, "force_hold" not in record.meta


def velocity_diagnostics(vel: Velocity) -> dict[str, Any]:
    """The velocity's diagnostics: its line of text, its differentiator's cut-off and its typed source."""
    return {
        "velocity": vel.provenance,
        "velocity_cutoff_hz": vel.cutoff,
        CHANNEL_SOURCES: source_entries({"v": vel.source}),
    }


def velocity_estimate(record: Record, how: str | None, cutoff: float | None) -> Velocity:
    """The velocity for the basis functions (option ``velocity``).

    Raises
    ------
    DataError
        If the requested channel is missing.
    """
    fs = record.fs
    if how == "integrate":
        if record.a is None:
            raise DataError("velocity=integrate needs an acceleration channel 'a'")
        rec = record.with_velocity_from_acceleration()
        return Velocity(np.asarray(rec.v), None, rec.channel_source("v"))
    if how == "measured" or (how is None and record.is_measured("v")):
        if record.v is None:
            raise DataError("velocity=measured needs a velocity channel 'v'")
        return Velocity(np.asarray(record.v), None, record.channel_source("v"))
    # the record's suggested cut-off is computed once: the core's scores use it too (nlid.plugin.suggested_cutoff)
    fc = default_cutoff(record.z, fs, suggested_cutoff(record)) if cutoff is None else float(cutoff)
    if not 0 < fc < fs / 2:
        raise InputError(f"velocity_cutoff must lie between 0 and the Nyquist frequency {fs / 2:g} Hz, got {fc:g}")

    def differentiate(x: np.ndarray) -> np.ndarray:
        return derivatives.differentiate(x, fs, order=1, cutoff=fc)[0]

    used = derivatives.DerivativeFilter(cutoff=fc)
    return Velocity(differentiate(record.z), differentiate, ChannelSource.differentiated(used, "z"))


def denoise_operator(
    z: np.ndarray, fs: float, cutoff: float | None, auto: float | None = None
) -> tuple[Callable[[np.ndarray], np.ndarray], float]:
    """The zero-phase low-pass that de-noises ``z`` and its cut-off (Hz).

    ``auto`` is :func:`default_cutoff` of ``z`` when it is already known
    (the velocity's differentiator uses the same rule on the same ``z``).
    """
    if cutoff is None:
        fc = default_cutoff(z, fs) if auto is None else float(auto)
    else:
        fc = float(cutoff)
    if not 0 < fc < fs / 2:
        raise InputError(f"denoise_cutoff must lie between 0 and the Nyquist frequency {fs / 2:g} Hz, got {fc:g}")

    def lowpass(x: np.ndarray) -> np.ndarray:
        return derivatives.lowpass(x, fs, fc)

    return lowpass, fc


def blas_threads(n: int | None) -> contextlib.AbstractContextManager:
    """Limit BLAS threads for the duration of a call (``None``: leave them alone).

    The matrices are at most a few thousand square, where one thread is as
    fast as two on an idle machine and much faster on a busy one (prototype,
    2-core machine under load: 0.7-0.9 s with one thread, 2.5-14 s with two).
    """
    if n is None:
        return contextlib.nullcontext()
    return _controller().limit(limits=int(n), user_api="blas")


_CONTROLLER: list[Any] = []


def _controller() -> Any:
    """One ``threadpoolctl.ThreadpoolController`` per process (listing the loaded libraries costs ~2 ms a call).

    ``scipy.linalg`` is imported first: scipy's BLAS is a library of its own,
    next to numpy's, and the identifiers' numerical modules are imported only
    inside the call, so a limit taken before would miss it.
    """
    if not _CONTROLLER:
        import scipy.linalg  # noqa: F401 - loads scipy's BLAS before the libraries are listed
        from threadpoolctl import ThreadpoolController

        _CONTROLLER.append(ThreadpoolController())
    return _CONTROLLER[0]


def check_length(n: int, block_rows: int, channels: int) -> None:
    """Raise a clear error when the record is too short for the Gram."""
    s = 2 * block_rows
    if n - s + 1 < s * channels:
        raise DataError(
            f"record too short for NSI: {n} samples, but {2 * block_rows} block rows of {channels} channels "
            f"need at least {s * channels + s - 1}; lower block_rows"
        )


def eigen_list(lc: np.ndarray | None) -> list[list[float]] | None:
    """Eigenvalues as ``[[re, im], ...]`` for JSON."""
    return None if lc is None else [[float(x.real), float(x.imag)] for x in lc]


def fit_summary(fit: NSIFit) -> dict[str, Any]:
    """JSON-friendly summary of one fit."""
    from .fit import format_eigenvalues

    return {
        "order": int(fit.order),
        "singular_values": [float(x) for x in fit.singular_values[:20]],
        "band_hz": [fit.band[0] / (2 * np.pi), fit.band[1] / (2 * np.pi)],
        "uls": {
            "m": fit.uls.m,
            "c": fit.uls.c,
            "k": fit.uls.k,
            "fn_hz": fit.uls.fn,
            "zeta": fit.uls.zeta,
            "eigenvalues": eigen_list(fit.uls.eigenvalues),
            "eigenvalues_text": format_eigenvalues(fit.uls.eigenvalues),
        },
        "quality": {s.name: s.quality for s in fit.spectra},
    }


#: Key of a coefficient spectrum: this prefix, the term, the fit's suffix (:func:`well_suffix`).
SPECTRUM_PREFIX = "coef_spectrum:"


def well_suffix(index: int) -> str:
    """Suffix of the array keys of fit ``index`` (from 0): none for the first, ``@wellN`` for the others."""
    return "" if index == 0 else f"@well{index}"


def fit_arrays(fit: NSIFit, suffix: str = "") -> dict[str, np.ndarray]:
    """The arrays of a fit under the keys of :class:`nlid.plugin.Estimate` (``suffix``: :func:`well_suffix`)."""
    f_hz = fit.w_plot / (2 * np.pi)
    out = {
        f"singular_values{suffix}": np.asarray(fit.singular_values),
        f"frf_frequency_hz{suffix}": f_hz,
        f"frf{suffix}": np.asarray(fit.frf),
        f"coef_frequency_hz{suffix}": f_hz,
    }
    for s in fit.spectra:
        out[f"{SPECTRUM_PREFIX}{s.name}{suffix}"] = np.asarray(s.value)
    return out


def figure_arrays(arrays: Mapping[str, Any], wells: bool) -> tuple[FigureArray, ...]:
    """What reports draw from the arrays :func:`fit_arrays` wrote (the identifiers' ``figure_arrays``).

    Every fit's FRF, then every coefficient spectrum, in the order of their keys; with ``wells``
    (nsi-shift: one fit per stable well) each is labelled with its well.
    """
    frfs: list[FigureArray] = []
    spectra: list[FigureArray] = []
    for key in sorted(arrays):
        name, _, well = key.partition("@")
        suffix = f"@{well}" if well else ""
        label = f"well {int(well[len('well') :]) + 1 if well else 1}" if wells else ""
        if name == "frf":
            frfs.append(FigureArray("frf", key, f"frf_frequency_hz{suffix}", label))
        elif name.startswith(SPECTRUM_PREFIX):
            term = name[len(SPECTRUM_PREFIX) :]
            spectra.append(FigureArray("coefficient spectrum", key, f"coef_frequency_hz{suffix}", label, term))
    return (*frfs, *spectra)


def reconstruction(
    record: Record, vel: Velocity, f_held: np.ndarray, uls: tuple[float, float, float], opt: dict[str, Any]
) -> tuple[Reconstruction, float | None]:
    """The second pass's displacement and velocity, and the de-noising cut-off (``None`` when fused).

    With a measured acceleration, a velocity derived from ``z`` and
    ``acceleration = fuse``: :func:`nlid_nsi.reconstruction.fuse_motion`;
    otherwise the force-driven completion and de-noising of
    :func:`nlid_nsi.reconstruction.reconstruct_motion`.
    """
    from .reconstruction import fuse_motion, reconstruct_motion

    z = np.asarray(record.z, dtype=float)
    if record.a is not None and vel.differentiate is not None and opt["acceleration"] == "fuse":
        # a crossover outside (0, fs/2) is refused by nlid.signal.derivatives.complementary, naming the option
        rec = fuse_motion(z, record.a, record.f, f_held, record.dt, uls, opt["crossover"])
        return rec, None
    auto = vel.cutoff if vel.differentiate is not None and opt.get("velocity_cutoff") is None else None
    lowpass, fc = denoise_operator(z, record.fs, opt["denoise_cutoff"], auto)
    return reconstruct_motion(z, vel.v, f_held, record.dt, uls, lowpass, vel.differentiate), fc


def reconstruction_diagnostics(rec: Reconstruction | None) -> dict[str, float | None]:
    """The second pass's noise estimates and fusion crossover (``None`` each without a second pass).

    Keys ``noise_std_estimate_m``, ``acceleration_noise_std_estimate`` (m/s^2,
    ``None`` unless fused) and ``crossover_hz`` (``None`` unless fused).
    """
    src_a = None if rec is None else rec.source("a")
    return {
        "noise_std_estimate_m": None if rec is None else float(np.sqrt(rec.noise_var)),
        "acceleration_noise_std_estimate": None if src_a is None else float(np.sqrt(src_a.var)),
        "crossover_hz": None if rec is None else rec.crossover,
    }
