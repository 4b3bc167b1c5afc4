"""How sure the prediction is: the band of the response over posterior draws.

For each draw of the coefficients from a posterior (:class:`nlid.bayes.Posterior`,
read by what it holds: ``model``, ``mass`` and ``full_samples``) every curve of a
response is continued again with the same force, band, harmonics and starting
well (the draw's stable equilibrium nearest the curve's). On a grid of
frequencies each draw gives the first-harmonic amplitudes of its *stable*
solutions there: one, or several inside a hysteresis (jump) region.

The band is taken per grid frequency, and only where the draws agree on how
many stable solutions there are: there, the ``k``-th smallest amplitude of
every draw gives the ``k``-th band (its quantiles ``(1 - level) / 2`` and
``(1 + level) / 2``). Where they disagree (near a jump, draws jump at
different frequencies) the frequency is *unresolved*: no band is drawn there
and the result says which frequencies they are. :meth:`ResponseBand.coverage`
tells whether another response (the truth's) lies inside the band at the
resolved frequencies.

Draws run in parallel processes (``jobs``, default every core). Draws of a model with Coulomb signs are
all regularised alike (:func:`_regularisation`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ..errors import InputError, NlidError
from .curves import ResponseCurve
from .fitted import Fitted

__all__ = ["ResponseBand", "BandCurve", "response_band", "stable_amplitudes", "GRID"]

#: Frequencies of the band's grid.
GRID = 200


def stable_amplitudes(curve: ResponseCurve, grid: np.ndarray, dof: int) -> list[list[float]]:
    """The first-harmonic amplitudes of the curve's stable solutions at each grid frequency, sorted."""
    f = curve.frequency_hz
    a = curve.amplitude(dof + 1)
    out: list[list[float]] = [[] for _ in grid]
    for k in range(len(f) - 1):
        if not (curve.stable[k] and curve.stable[k + 1]) or f[k] == f[k + 1]:
            continue
        lo, hi = sorted((f[k], f[k + 1]))
        inside = np.flatnonzero((grid >= lo) & (grid < hi) | (grid == hi) & (k + 1 == len(f) - 1))
        for g in inside:
            w = (grid[g] - f[k]) / (f[k + 1] - f[k])
            out[g].append(float((1 - w) * a[k] + w * a[k + 1]))
    return [sorted(x) for x in out]


@dataclass(frozen=True)
class BandCurve:
    """The band of one curve.

    Attributes
    ----------
    force, start
        The curve's force (N) and the equilibrium it started from.
    frequency_hz
        The grid (Hz).
    count
        The number of stable solutions the draws agree on at each frequency (0 where they disagree).
    low, median, high
        ``(ranks, grid)``: the band of the ``k``-th smallest stable amplitude (NaN where not resolved).
    """

    force: float
    start: tuple[float, ...]
    frequency_hz: np.ndarray
    count: np.ndarray
    low: np.ndarray
    median: np.ndarray
    high: np.ndarray

    @property
    def resolved(self) -> np.ndarray:
        """Where the draws agree on the number of stable solutions."""
        return self.count > 0

    def unresolved_ranges(self) -> list[tuple[float, float]]:
        """The unresolved stretches of the grid as ``(from, to)`` Hz."""
        out = []
        bad = ~self.resolved
        k = 0
        while k < bad.size:
            if bad[k]:
                j = k
                while j + 1 < bad.size and bad[j + 1]:
                    j += 1
                out.append((float(self.frequency_hz[k]), float(self.frequency_hz[j])))
                k = j + 1
            else:
                k += 1
        return out

    def to_dict(self) -> dict[str, Any]:
        """Plain data."""
        return {
            "force": self.force,
            "start": list(self.start),
            "frequency_hz": self.frequency_hz.tolist(),
            "count": self.count.tolist(),
            "low": self.low.tolist(),
            "median": self.median.tolist(),
            "high": self.high.tolist(),
            "unresolved_hz": [list(r) for r in self.unresolved_ranges()],
        }


@dataclass(frozen=True)
class ResponseBand:
    """The band of a response over posterior draws (module docstring).

    Attributes
    ----------
    curves
        One :class:`BandCurve` per curve of the response.
    level
        The band's probability (0.9: the 5 % and 95 % quantiles).
    draws
        Draws asked; ``failed`` how many gave no curve (their messages in ``errors``).
    dof
        The DOF (0-based) whose amplitude is banded.
    seconds
        Wall time.
    """

    curves: tuple[BandCurve, ...]
    level: float
    draws: int
    failed: int
    dof: int
    seconds: float
    errors: tuple[str, ...] = ()

    def coverage(self, other: Any) -> list[float]:
        """Per curve: the fraction of resolved frequencies where ``other`` (a response with the same curves)
        has as many stable solutions and each inside its band."""
        out = []
        for band, curve in zip(self.curves, other.curves, strict=True):
            amps = stable_amplitudes(curve, band.frequency_hz, self.dof)
            hits = []
            for g in np.flatnonzero(band.resolved):
                a = amps[g]
                ok = len(a) == band.count[g] and all(band.low[k, g] <= x <= band.high[k, g] for k, x in enumerate(a))
                hits.append(ok)
            out.append(float(np.mean(hits)) if hits else float("nan"))
        return out

    def summary_lines(self) -> list[tuple[str, str]]:
        """``(key, value)`` lines for :meth:`nlid.response.FrequencyResponse.summary`."""
        out = [
            (
                f"{self.level:.0%} band",
                f"{self.draws - self.failed} of {self.draws} posterior draws continued ({self.seconds:.3g} s)",
            )
        ]
        for i, b in enumerate(self.curves):
            ranges = b.unresolved_ranges()
            text = ", ".join(f"{lo:.4g}-{hi:.4g}" for lo, hi in ranges) if ranges else "none"
            out.append((f"curve {i}: unresolved (Hz)", f"{text} ({np.mean(~b.resolved):.0%} of the grid)"))
        if self.errors:
            out.append(("failed draws", "; ".join(dict.fromkeys(self.errors))))
        return out

    def to_dict(self) -> dict[str, Any]:
        """Plain data."""
        return {
            "level": self.level,
            "draws": self.draws,
            "failed": self.failed,
            "dof": self.dof,
            "seconds": self.seconds,
            "curves": [c.to_dict() for c in self.curves],
            "errors": list(dict.fromkeys(self.errors)),
        }

    def draw(self, ax: Any, dof: int, colours: dict[float, str]) -> None:
        """Shade the band on ``ax`` (only for the banded DOF), the unresolved frequencies hatched."""
        if dof != self.dof:
            return
        for b in self.curves:
            colour = colours.get(float(b.force), "C0")
            for k in range(b.low.shape[0]):
                ax.fill_between(b.frequency_hz, b.low[k], b.high[k], color=colour, alpha=0.2, lw=0)
            for lo, hi in b.unresolved_ranges():
                ax.axvspan(lo, hi, color=colour, alpha=0.06, hatch="//", lw=0)
        ax.fill_between([], [], [], color="0.5", alpha=0.2, label=f"{self.level:.0%} posterior band")


def _draw_curves(args: tuple) -> tuple[list[list[list[float]]] | None, str]:
    """One draw: the stable amplitudes of every curve on the grid (run in a worker process)."""
    fitted, theta, requests, settings, pattern, grid, dof = args
    from threadpoolctl import threadpool_limits

    from .solve import continue_frequency

    try:
        with threadpool_limits(limits=1):
            f = fitted.with_theta(theta)
            stable, unstable = f.stable_unstable()
            if not stable:
                return None, "a draw has no stable equilibrium"
            system = f.system()
            saddles = tuple(float(u[0]) for u in unstable)
            wells = tuple(float(s[0]) for s in stable)
            out = []
            for force, start, band, eps in requests:
                z0 = min(stable, key=lambda s: float(np.sum((s - np.asarray(start)) ** 2)))
                mine = settings if eps is None else replace(settings, regularisation=eps)
                curve = continue_frequency(system, force, band, z0, mine, pattern, saddles=saddles, wells=wells)
                out.append(stable_amplitudes(curve, grid, dof))
            return out, ""
    except (NlidError, np.linalg.LinAlgError, FloatingPointError) as exc:
        return None, str(exc)


def _regularisation(curve: ResponseCurve, hi_hz: float) -> float | None:
    """The Coulomb regularisation every draw of a curve uses: the curve's own, or the one it would have had.

    Draws of a model with Coulomb signs are all regularised alike (:data:`nlid.response.solve.REGULARISATION`
    times the nominal curve's largest linearised velocity amplitude), so that a draw is never computed
    exactly while its neighbour sticks, and no draw spends a continuation finding that out.
    """
    from .solve import REGULARISATION

    if "regularisation" in curve.meta:
        return float(curve.meta["regularisation"][0])
    if not curve.meta.get("jumps"):
        return None
    return REGULARISATION * 2 * np.pi * hi_hz * float(curve.meta["x_ref"])


def _pool(jobs: int):
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    return ProcessPoolExecutor(max_workers=jobs, mp_context=multiprocessing.get_context("fork"))


def response_band(
    response,
    posterior,
    *,
    draws: int = 100,
    level: float = 0.9,
    seed: int = 0,
    jobs: int | None = None,
    grid: int = GRID,
) -> ResponseBand:
    """The band of ``response`` over ``draws`` posterior draws (module docstring).

    Parameters
    ----------
    response
        A :class:`~nlid.response.FrequencyResponse` of a one-DOF model (continued in frequency).
    posterior
        A posterior of the same model's coefficients (:func:`nlid.posterior`).
    draws
        Draws continued.
    level
        Probability of the band.
    seed
        Seed of the choice of draws.
    jobs
        Worker processes (default :func:`nlid.runtime.parallel.workers`; 1 runs in this process).
    grid
        Frequencies of the band's grid.

    Raises
    ------
    InputError
        A structure, a response not continued in frequency, a bad ``level`` or ``draws``, or a posterior
        without samples.
    """
    import time

    from ..runtime.parallel import workers

    fitted: Fitted = response.model
    if not isinstance(fitted, Fitted) or not fitted.one_dof:
        raise InputError("the posterior band is for a one-DOF model's response")
    if any(c.parameter != "frequency" for c in response.curves):
        raise InputError("the posterior band needs a response continued in frequency")
    if not 0 < level < 1:
        raise InputError(f"level= must be between 0 and 1, got {level!r}")
    if isinstance(draws, bool) or not isinstance(draws, int) or draws < 2:
        raise InputError(f"draws= must be an integer of at least 2, got {draws!r}")
    if not hasattr(posterior, "full_samples") or not hasattr(posterior, "model"):
        raise InputError(f"posterior= must be a posterior of the model's coefficients, got {type(posterior).__name__}")
    t0 = time.perf_counter()
    samples = posterior.full_samples(draws, np.random.default_rng(seed))
    model = posterior.model
    mass = posterior.mass if isinstance(posterior.mass, (int, float)) else fitted.mass
    base = Fitted(model=model, theta=np.asarray(samples[0]), mass=float(mass), z_range=fitted.z_range)
    lo, hi = response.band_hz
    grid_hz = np.linspace(lo, hi, int(grid))
    requests = [(float(c.force[0]), c.start, (lo, hi), _regularisation(c, hi)) for c in response.curves]
    dof = response._lead
    tasks = [(base, theta, requests, response.settings, np.asarray(response.forced), grid_hz, dof) for theta in samples]
    n = workers() if jobs is None else max(1, int(jobs))
    if n == 1:
        results = [_draw_curves(t) for t in tasks]
    else:
        with _pool(n) as pool:
            results = list(pool.map(_draw_curves, tasks))
    good = [r for r, _ in results if r is not None]
    errors = tuple(e for r, e in results if r is None)
    if not good:
        raise InputError(f"no posterior draw gave a response: {errors[0] if errors else 'unknown'}")
    q = ((1 - level) / 2, 0.5, (1 + level) / 2)
    bands = []
    for ci, c in enumerate(response.curves):
        per = [g[ci] for g in good]
        counts = np.array([[len(p[k]) for k in range(grid_hz.size)] for p in per])
        agree = np.all(counts == counts[0], axis=0)
        ranks = max(1, int(counts.max()))
        low, mid, high = (np.full((ranks, grid_hz.size), np.nan) for _ in range(3))
        count = np.where(agree, counts[0], 0)
        for k in range(grid_hz.size):
            for r in range(count[k]):
                vals = np.array([p[k][r] for p in per])
                low[r, k], mid[r, k], high[r, k] = np.quantile(vals, q)
        bands.append(BandCurve(float(c.force[0]), c.start, grid_hz, count, low, mid, high))
    return ResponseBand(tuple(bands), float(level), int(draws), len(errors), dof, time.perf_counter() - t0, errors)


@dataclass(frozen=True)
class SavedPosterior:
    """Posterior samples read back from the files of ``nlid posterior --out`` (:func:`load_posterior`)."""

    model: Any
    mass: float
    names: tuple[str, ...]
    samples: np.ndarray
    fixed: dict[str, float]

    def full_samples(self, draws: int | None = None, rng: np.random.Generator | None = None) -> np.ndarray:
        """Full coefficient vectors in model order (the unsampled ones at their saved estimates)."""
        samples = self.samples
        if draws is not None and draws < samples.shape[0]:
            rng = rng if rng is not None else np.random.default_rng(0)
            samples = samples[rng.choice(samples.shape[0], size=draws, replace=False)]
        theta = np.array(self.fixed_vector)
        full = np.tile(theta, (samples.shape[0], 1))
        full[:, [self.model.index(n) for n in self.names]] = samples
        return full

    @property
    def fixed_vector(self) -> np.ndarray:
        """The model's coefficients with the unsampled ones at their saved estimates."""
        return self.model.vector({n: self.fixed.get(n, 0.0) for n in self.model.names})


def load_posterior(path: Any, fitted: Fitted) -> SavedPosterior:
    """The samples that ``nlid posterior --out DIR`` saved (the folder, its ``posterior.json`` or its
    ``posterior_samples.npz``), on the model ``fitted`` holds (the one the posterior was sampled for).

    Raises
    ------
    InputError
        No samples file, or sampled terms the model does not have.
    """
    from pathlib import Path

    p = Path(path)
    npz = p / "posterior_samples.npz" if p.is_dir() else p.with_name("posterior_samples.npz")
    if not npz.is_file():
        raise InputError(f"no posterior samples at {npz} (write them with nlid posterior's out= folder)")
    if not fitted.one_dof:
        raise InputError("the posterior band is for a one-DOF model's response")
    with np.load(npz, allow_pickle=False) as data:
        names = tuple(str(x) for x in data["names"])
        samples = np.asarray(data["samples"], dtype=float)
        fixed_names = [str(x) for x in data["not_sampled_names"]]
        fixed_values = np.asarray(data["not_sampled_estimates"], dtype=float)
    model = fitted.model
    missing = [n for n in names if n not in model]
    if missing:
        raise InputError(f"the posterior samples {', '.join(missing)}, which the model ({model}) does not have")
    fixed = {model.terms[model.index(n)].name: float(x) for n, x in zip(fixed_names, fixed_values, strict=True)}
    base = dict(zip(model.names, np.asarray(fitted.theta, dtype=float), strict=True))
    base.update(fixed)
    return SavedPosterior(
        model, float(fitted.mass), tuple(model.terms[model.index(n)].name for n in names), samples, base
    )
