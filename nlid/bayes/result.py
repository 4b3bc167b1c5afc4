"""The posterior a run produced: samples, summary table, damping bands, files."""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..base.dimensions import mass_unit, unit_of
from ..base.jsonable import to_jsonable
from ..data.forcehold import describe_force_hold
from ..errors import InputError
from ..estimation.balance import RegressionData
from ..identified.plausibility import Flag
from ..model import physics
from ..model.terms import Model, parse_term
from ..report.summary import Column, Summary
from ..scoring import damping_slice
from .likelihood import Likelihood
from .noise import NoiseLevel
from .sampler import Chains

__all__ = ["Posterior", "DampingBand", "QUANTILES"]

#: Quantiles reported for each coefficient.
QUANTILES = (0.05, 0.5, 0.95)
#: A posterior sd above this multiple of its normal prior's sd is a contradiction (sampling error of an sd
#: estimated from a few hundred effective samples is a few percent).
SD_SLACK = 1.25


def _equations(info: Mapping[str, Any]) -> str:
    """``"N samples"``, or for a structure ``"R equations (N samples x n DOFs)"``."""
    dofs = info.get("dofs")
    if not dofs:
        return f"{info['samples']} samples"
    return f"{info['samples']} equations ({info['samples'] // dofs} samples x {dofs} DOFs)"


@dataclass(frozen=True)
class DampingBand:
    """Posterior predictive band of ``D(z0, v)`` on one slice (paper Fig. 21 b-d).

    Attributes
    ----------
    z0, half_width
        The slice ``|z - z0| <= half_width`` (m).
    v_grid
        Velocities of the band (m/s).
    q05, q50, q95
        Quantiles of ``D(z0, v)`` over the posterior draws (N).
    v, measured
        The data in the slice: velocities and measured damping force
        ``R_e - K(z)`` (N), from :func:`nlid.scoring.damping_slice`.
    """

    z0: float
    half_width: float
    v_grid: np.ndarray
    q05: np.ndarray
    q50: np.ndarray
    q95: np.ndarray
    v: np.ndarray
    measured: np.ndarray


@dataclass
class Posterior:
    """Posterior over the sampled coefficients (the others integrated out, or fixed at the identifier's estimate).

    Attributes
    ----------
    model
        The model (``px`` roots set); for a structure, its unknowns
        (:class:`~nlid.bayes.structure.StructureParameters`).
    names
        Sampled terms, in model order.
    chains
        The converged emcee run.
    start
        The identifier's estimate of every coefficient (walkers start there;
        the unsampled ones stay there).
    priors
        Prior of each sampled term, as text.
    likelihood
        The adjusted likelihood (centre, covariance, diagnostics).
    mass
        Mass used (kg); for a structure the mass matrix (rows, kg).
    method
        The identifier that gave the start.
    seconds
        Wall time of the whole posterior (likelihood, correction, sampling).
    others
        ``"fixed"`` (unsampled coefficients at the identifier's estimate) or
        ``"marginal"`` (integrated out).
    gaussian
        Mean and covariance of the sampled coefficients in the likelihood's
        Gaussian limit (flat priors), for comparison with the samples.
    data
        The force balance (for damping slices); not serialised.
    warnings
        Things the user should know (e.g. numerical warnings while sampling).
    reference
        The record's reference coefficients (``record.meta["reference"]``, :mod:`nlid.identified.reference`), by
        term; empty when the record carries none. Drawn as the truth in the corner plot; not serialised.
    units
        SI unit of each coefficient when the names are not one-DOF terms (a structure's ``K[1,2]``...);
        ``None``: each term's own unit.
    record
        The record the posterior was sampled from (the ``observed_data`` of :meth:`to_datatree`); not serialised.
    flags
        Why the posterior cannot be trusted (:class:`~nlid.identified.plausibility.Flag`): the identified
        model's own flags, and a bias correction beyond :data:`nlid.bayes.trust.CORRECTION_BOUND_SD`
        (checked by simulation); empty when there is none. ``nlid posterior`` exits with status 1 on one.
    force_hold
        ``(hold, source)``: the record's force between samples and where that came from
        (:mod:`nlid.data.forcehold`); ``None`` when not known.
    channel_units
        ``{"f", "z"}``: the units of the record's force and displacement (``N`` and ``m``, or ``V`` for an
        electrical analogue); the mass and the noise levels are shown in units derived from them
        (:mod:`nlid.base.dimensions`). ``None``: SI.
    """

    model: Model | Any
    names: tuple[str, ...]
    chains: Chains
    start: dict[str, float]
    priors: dict[str, str]
    likelihood: Likelihood
    mass: float | list[list[float]]
    method: str
    seconds: float
    others: str = "marginal"
    gaussian: tuple[np.ndarray, np.ndarray] | None = field(default=None, repr=False)
    data: RegressionData | None = field(default=None, repr=False)
    warnings: tuple[str, ...] = ()
    reference: dict[str, float] = field(default_factory=dict, repr=False)
    units: dict[str, str] | None = field(default=None, repr=False)
    record: Any = field(default=None, repr=False, compare=False)
    flags: tuple[Flag, ...] = ()
    force_hold: tuple[str, str] | None = None
    channel_units: dict[str, str] | None = None

    def unit(self, name: str) -> str:
        """SI unit of a sampled coefficient."""
        if self.units is not None:
            return self.units[name]
        return parse_term(name).coefficient_unit

    def _mass_text(self) -> str:
        if isinstance(self.mass, (int, float)):
            force, length = self._channels()
            return f"mass {self.mass:.6g} {mass_unit(force, length)}"
        diag = ", ".join(f"{row[k]:.6g}" for k, row in enumerate(self.mass))
        return f"mass matrix diagonal {diag} kg"

    def _channels(self) -> tuple[str, str]:
        units = self.channel_units or {}
        return units.get("f", "N"), units.get("z", "m")

    # ------------------------------------------------------------------ numbers
    @property
    def samples(self) -> np.ndarray:
        """Samples of the sampled coefficients, shape ``(n, d)``."""
        return self.chains.samples

    @property
    def not_sampled(self) -> dict[str, float]:
        """The coefficients that were not sampled, with the identifier's estimates.

        With ``others="fixed"`` the likelihood held them at these values; with
        ``"marginal"`` it integrated them out (the values serve only where a
        full coefficient vector is needed, e.g. :meth:`full_samples`).
        """
        return {n: x for n, x in self.start.items() if n not in self.names}

    @property
    def gaussian_limit(self) -> tuple[np.ndarray, np.ndarray]:
        """Mean and covariance of the sampled coefficients in the likelihood's Gaussian limit."""
        if self.gaussian is not None:
            return self.gaussian
        idx = [self.model.index(n) for n in self.names]
        return self.likelihood.conditional(idx, self.model.vector(self.start))

    def full_samples(self, draws: int | None = None, rng: np.random.Generator | None = None) -> np.ndarray:
        """Samples as full coefficient vectors in model order (unsampled ones at the identifier's estimate).

        Parameters
        ----------
        draws
            Random subset of this many samples (default: all).
        rng
            Generator of the subset.
        """
        samples = self.samples
        if draws is not None and draws < samples.shape[0]:
            rng = rng if rng is not None else np.random.default_rng(0)
            samples = samples[rng.choice(samples.shape[0], size=draws, replace=False)]
        full = np.tile(self.model.vector(self.start), (samples.shape[0], 1))
        full[:, [self.model.index(n) for n in self.names]] = samples
        return full

    @property
    def bias_shifts(self) -> dict[str, float]:
        """How far the bias correction moved each sampled coefficient, in its standard deviations.

        ``(theta_c - theta_hat) / sd`` with ``theta_hat`` the least-squares
        estimate of the force balance, ``theta_c`` the corrected one and
        ``sd`` the corrected estimate's standard deviation; empty without
        the correction.
        """
        shifts = self.likelihood.info.get("bias_shift_sd", {})
        return {n: float(shifts[n]) for n in self.names if n in shifts}

    @property
    def large_corrections(self) -> dict[str, dict[str, float]]:
        """The sampled coefficients the bias correction moved by more than one standard deviation.

        ``{term: {"least_squares", "corrected", "shift_sd"}}``. Such a
        correction is only as right as the noise levels it simulated
        (``likelihood.info["noise"]``): the text table and the JSON document
        show it so that a wrong one is never silent.
        """
        lik = self.likelihood
        out = {}
        for name, shift in self.bias_shifts.items():
            if abs(shift) > 1.0:
                i = self.model.index(name)
                out[name] = {
                    "least_squares": float(lik.estimate[i]),
                    "corrected": float(lik.center[i]),
                    "shift_sd": shift,
                }
        return out

    def summary_dict(self) -> dict[str, dict[str, float]]:
        """``{term: {"mean", "sd", "q05", "q50", "q95"}}`` (what :meth:`summary` returned before it became a table)."""
        s = self.samples
        q = np.quantile(s, QUANTILES, axis=0)
        return {
            name: {
                "mean": float(s[:, i].mean()),
                "sd": float(s[:, i].std(ddof=1)),
                "q05": float(q[0, i]),
                "q50": float(q[1, i]),
                "q95": float(q[2, i]),
            }
            for i, name in enumerate(self.names)
        }

    def problems(self, prior_sd: Mapping[str, float] | None = None) -> list[str]:
        """Reported figures that are not finite or contradict each other (empty when all is well).

        Parameters
        ----------
        prior_sd
            Standard deviation of each sampled term's normal prior: a
            posterior cannot be wider than a normal prior (with a log-concave
            likelihood its variance is at most the prior's), so a standard
            deviation more than :data:`SD_SLACK` times the prior's means the
            walkers did not sample one posterior.
        """
        out = []
        for name, s in self.summary_dict().items():
            if not all(np.isfinite(x) for x in s.values()):
                out.append(f"the summary of {name} is not finite ({', '.join(f'{k} {x:.4g}' for k, x in s.items())})")
                continue
            if not s["q05"] <= s["mean"] <= s["q95"]:
                out.append(
                    f"the mean of {name} ({s['mean']:.5g}) lies outside its own 5-95 % range "
                    f"[{s['q05']:.5g}, {s['q95']:.5g}]"
                )
            limit = (prior_sd or {}).get(name)
            if limit is not None and s["sd"] > SD_SLACK * limit:
                out.append(f"the sd of {name} ({s['sd']:.3g}) exceeds the sd of its normal prior ({limit:.3g})")
        return out

    def interval(self, level: float = 0.9) -> dict[str, tuple[float, float]]:
        """Equal-tailed credible interval of each sampled coefficient."""
        if not 0 < level < 1:
            raise InputError(f"credible level must lie between 0 and 1, got {level}")
        lo, hi = np.quantile(self.samples, [(1 - level) / 2, (1 + level) / 2], axis=0)
        return {n: (float(lo[i]), float(hi[i])) for i, n in enumerate(self.names)}

    @property
    def tau(self) -> dict[str, float]:
        """Integrated autocorrelation time of each sampled coefficient (steps)."""
        return {n: float(t) for n, t in zip(self.names, self.chains.tau, strict=True)}

    @property
    def n_effective(self) -> dict[str, float]:
        """Effective sample size of each sampled coefficient."""
        return {n: float(x) for n, x in zip(self.names, self.chains.n_effective, strict=True)}

    def to_dict(self) -> dict[str, Any]:
        """The JSON document of ``nlid posterior --json``."""
        lik = self.likelihood
        idx = [self.model.index(n) for n in self.names]
        mean, cov = self.gaussian_limit
        return to_jsonable(
            {
                "params": self.summary_dict(),
                "tau": self.tau,
                "acceptance": self.chains.acceptance,
                "n_effective": self.n_effective,
                "seconds": self.seconds,
                "method": self.method,
                "mass": self.mass,
                "start": {n: self.start[n] for n in self.names},
                "others": self.others,
                "fixed": self.not_sampled if self.others == "fixed" else {},
                "not_sampled": list(self.not_sampled),
                "bias_shift_sd": self.bias_shifts,
                "large_corrections": self.large_corrections,
                "priors": self.priors,
                "warnings": [*self.warnings, *(f"NOT TRUSTED: {f}" for f in self.flags)],
                "flags": [f.to_dict() for f in self.flags],
                "channel_units": dict(self.channel_units or {"f": "N", "z": "m"}),
                "force_hold": None
                if self.force_hold is None
                else {"hold": self.force_hold[0], "source": self.force_hold[1]},
                "units": {n: self.unit(n) for n in self.names},
                "sampler": {
                    "walkers": self.chains.walkers,
                    "steps": self.chains.steps,
                    "burn": self.chains.burn,
                    "thin": self.chains.thin,
                    "samples": int(self.samples.shape[0]),
                },
                "likelihood": {
                    "gaussian_mean": dict(zip(self.names, mean.tolist(), strict=True)),
                    "gaussian_sd": dict(zip(self.names, np.sqrt(np.diag(cov)).tolist(), strict=True)),
                    "least_squares": {n: float(lik.estimate[i]) for n, i in zip(self.names, idx, strict=True)},
                    **lik.info,
                },
            }
        )

    def table(self):
        """A :class:`pandas.DataFrame`: one row per sampled coefficient."""
        import pandas as pd

        rows = []
        ess = self.n_effective
        for name, s in self.summary_dict().items():
            rows.append(
                {
                    "term": name,
                    "unit": self.unit(name),
                    "start": self.start[name],
                    **s,
                    "tau": self.tau[name],
                    "n_effective": ess[name],
                }
            )
        return pd.DataFrame(rows)

    def to_datatree(self, record: Any = None) -> Any:
        """The posterior as an :class:`xarray.DataTree`, ArviZ 1.0's format (:mod:`nlid.bayes.datatree`).

        Groups ``posterior``, ``sample_stats`` and ``observed_data``; the root's attributes state the interval level
        nlid's summaries use (0.90 equal-tailed). :meth:`save` writes it as ``posterior.nc``;
        ``arviz.summary(tree, ci_prob=0.9, ci_kind="eti")`` (ArviZ 1.0) reads it.

        Parameters
        ----------
        record
            The record for ``observed_data`` (default: the one the posterior was sampled from).

        Raises
        ------
        InputError
            xarray is not installed (``pip install 'nlid[netcdf]'``).
        """
        from .datatree import posterior_datatree

        return posterior_datatree(self, record)

    def __repr__(self) -> str:
        parts = ", ".join(f"{n} {s['mean']:.4g} +/- {s['sd']:.2g}" for n, s in self.summary_dict().items())
        flagged = f"; NOT TRUSTED: {', '.join(f.code for f in self.flags)}" if self.flags else ""
        return f"<Posterior {self.method!r} ({self.others} others): {parts}{flagged}>"

    def _repr_html_(self) -> str:
        return self.summary().as_html()

    def summary(self) -> Summary:
        """The table ``nlid posterior`` prints: each sampled coefficient's mean, sd, quantiles, tau and ESS.

        A :class:`~nlid.report.summary.Summary` (``print()`` it, or ``.as_markdown()`` /
        ``.as_html()``); the numbers as a mapping are :meth:`summary_dict`.
        """
        out = Summary(f"posterior of {len(self.names)} coefficient(s); start: {self.method}, {self._mass_text()}")
        ess = self.n_effective
        out.add_table(
            [
                Column("term"),
                Column("mean", "right", 11),
                Column("sd", "right", 9),
                Column("5 %", "right", 11),
                Column("50 %", "right", 11),
                Column("95 %", "right", 11),
                Column("tau", "right", 6),
                Column("ESS", "right", 7),
                Column("unit"),
            ],
            [
                [
                    name,
                    f"{s['mean']:.5g}",
                    f"{s['sd']:.3g}",
                    f"{s['q05']:.5g}",
                    f"{s['q50']:.5g}",
                    f"{s['q95']:.5g}",
                    f"{self.tau[name]:.1f}",
                    f"{ess[name]:.0f}",
                    self.unit(name),
                ]
                for name, s in self.summary_dict().items()
            ],
        )
        if self.not_sampled and self.others == "marginal":
            out.add_fields([("integrated out (not sampled)", ", ".join(self.not_sampled))], gap=True)
        elif self.not_sampled:
            fixed = ", ".join(f"{n} = {x:.6g}" for n, x in self.not_sampled.items())
            out.add_fields([("fixed at the identifier's estimate", fixed)], gap=True)
        info = self.likelihood.info
        lines = [
            (
                "sampler",
                f"{self.chains.walkers} walkers x {self.chains.steps} steps (burn-in {self.chains.burn}, "
                f"thin {self.chains.thin}), acceptance {self.chains.acceptance:.2f}, "
                f"chain length {self.chains.steps / max(self.chains.tau):.0f} tau",
            )
        ]
        band = info.get("band_hz")
        where = f" in the band below {band:.4g} Hz" if band else ""
        bias = "no bias correction"
        if info.get("bias_correction"):
            bias = "errors-in-variables bias corrected by simulation"
            q = info.get("bias_substeps")
            if q:  # absent from a posterior saved before the sub-steps were recorded
                bias += f" ({q} RK4 step{'s' if q > 1 else ''} per sample)"
        lines.append(
            (
                "likelihood",
                f"equation error over {_equations(info)}{where}, effective {info['dof']:.0f} "
                f"(residual correlated over {info['tau_residual_samples']:.1f} samples), {bias}",
            )
        )
        if self.force_hold is not None:
            lines.append(("force between samples", describe_force_hold(*self.force_hold)))
        noise = info.get("noise", {})
        if noise:
            length = self._channels()[1]
            unit = {"z": length, "v": unit_of((length, 1), ("s", -1))}
            levels = ", ".join(NoiseLevel(**level).describe(unit.get(level["channel"])) for level in noise.values())
            lines.append(("noise levels simulated by the correction", levels))
        for name, c in self.large_corrections.items():
            lines.append(
                (
                    "note",
                    f"the bias correction moved {name} by {c['shift_sd']:+.1f} sd (least squares "
                    f"{c['least_squares']:.5g} -> {c['corrected']:.5g}); it is only as right as the noise levels "
                    "above",
                )
            )
        lines.append(("time", f"{self.seconds:.3g} s"))
        lines += [("warning", w) for w in self.warnings]
        lines += [("NOT TRUSTED", str(f)) for f in self.flags]
        out.add_fields(lines, gap=True)
        return out

    def format_table(self) -> str:
        """A human-readable summary: the text of :meth:`summary`."""
        return self.summary().as_text()

    # ------------------------------------------------------------------ damping bands
    def damping_bands(
        self,
        positions: Sequence[float] | None = None,
        *,
        half_width: float | None = None,
        grid: int = 120,
        draws: int = 400,
        seed: int = 0,
    ) -> list[DampingBand]:
        """Posterior predictive bands of ``D(z0, v)`` on slices (paper Fig. 21 b-d).

        Parameters
        ----------
        positions
            Slice positions ``z0`` in m; default :meth:`default_slices`.
        half_width
            Half width of each slice (default 5 % of the displacement range).
        grid
            Velocity points of the band.
        draws
            Posterior draws the band is computed from.
        seed
            Seed of the draws.
        """
        if self.data is None or self.data.v is None:
            raise InputError("damping bands need the force balance with velocity (a model with velocity terms)")
        positions = self.default_slices() if positions is None else list(positions)
        theta = self.full_samples(draws, np.random.default_rng(seed))
        centre = theta.mean(axis=0)
        out = []
        for z0 in positions:
            sl = damping_slice(self.data, self.model, centre, self.mass, float(z0), half_width, grid)
            # D is linear in the coefficients: one regressor matrix serves every draw
            G = self.model.evaluate(np.full(grid, float(z0)), sl.v_grid)
            damp = [i for i, t in enumerate(self.model.terms) if t.family == "damping"]
            curves = theta[:, damp] @ G[:, damp].T
            q = np.quantile(curves, QUANTILES, axis=0)
            out.append(DampingBand(sl.z0, sl.half_width, sl.v_grid, q[0], q[1], q[2], sl.v, sl.measured))
        return out

    def default_slices(self) -> list[float]:
        """Slice positions: the equilibria of the mean model (wells and barrier), else the z quartiles."""
        z = self.data.z if self.data is not None else None
        try:
            zr = None if z is None else (float(z.min()), float(z.max()))
            eq = physics.equilibria(self.model, self.full_samples().mean(axis=0), zr)
            points = [p for p in eq.all if zr is None or zr[0] <= p <= zr[1]]
        except InputError:
            points = []
        if not points and z is not None:
            points = [float(x) for x in np.quantile(z, [0.25, 0.5, 0.75])]
        return points

    # ------------------------------------------------------------------ files
    def save(
        self,
        out_dir: str | Path,
        *,
        figures: bool = True,
        slices: Sequence[float] | None = None,
        force: bool = False,
        netcdf: bool | None = None,
    ) -> list[Path]:
        """Write the table (CSV), the document (JSON), the samples (NPZ and netCDF) and the figures (PNG).

        Files: ``posterior_table.csv``, ``posterior.json``,
        ``posterior_samples.npz`` (``samples``, ``names``, ``chain``,
        ``log_prob``, ``tau``, ``not_sampled_names``, ``not_sampled_estimates`` and the damping
        bands), ``posterior.nc`` (:meth:`to_datatree`), ``posterior_corner.png``, ``posterior_trace.png``,
        ``posterior_damping.png``. nlid writes only into folders it created or
        that were empty; ``force=True`` writes beside files it did not write,
        never replacing them (:mod:`nlid.runtime.outputs`).

        Parameters
        ----------
        netcdf
            Write ``posterior.nc``: ``None`` (default) when xarray and h5netcdf (or netCDF4) are installed,
            ``True`` always (an :class:`~nlid.errors.InputError` when they are not), ``False`` never.
        """
        from ..runtime.outputs import POSTERIOR_OUTPUTS, output_folder
        from .datatree import netcdf_available, require_netcdf

        if netcdf is None:
            netcdf = netcdf_available()
        elif netcdf:
            require_netcdf()  # the missing package is said before anything is written
        with output_folder(out_dir, POSTERIOR_OUTPUTS, force=force) as out:
            return self._save(out, figures, slices, bool(netcdf))

    def _save(self, out: Path, figures: bool, slices: Sequence[float] | None, netcdf: bool = False) -> list[Path]:
        paths = []
        path = out / "posterior_table.csv"
        self.table().to_csv(path, index=False)
        paths.append(path)
        path = out / "posterior.json"
        path.write_text(json.dumps(self.to_dict(), indent=2, allow_nan=False) + "\n")
        paths.append(path)
        bands = []
        if self.data is not None and self.data.v is not None:
            bands = self.damping_bands(slices)
        arrays: dict[str, np.ndarray] = {
            "samples": self.samples,
            "names": np.array(self.names),
            "chain": self.chains.chain,
            "log_prob": self.chains.log_prob,
            "tau": self.chains.tau,
            "not_sampled_names": np.array(list(self.not_sampled), dtype=str),
            "not_sampled_estimates": np.array(list(self.not_sampled.values()), dtype=float),
        }
        for i, b in enumerate(bands):
            for key in ("v_grid", "q05", "q50", "q95"):
                arrays[f"damping{i}_{key}"] = getattr(b, key)
            arrays[f"damping{i}_z0"] = np.array(b.z0)
        path = out / "posterior_samples.npz"
        np.savez(path, **arrays)
        paths.append(path)
        if netcdf:
            from .datatree import write_netcdf

            paths.append(write_netcdf(self.to_datatree(), out / "posterior.nc"))
        if figures:
            from ..report.plotting import save_figure
            from .plots import corner_figure, damping_figure, trace_figure

            paths += save_figure(corner_figure(self), out / "posterior_corner", formats=("png",))
            paths += save_figure(trace_figure(self), out / "posterior_trace", formats=("png",))
            if bands:
                paths += save_figure(
                    damping_figure(bands, self.data.filtered_at if self.data is not None else None, self._channels()),
                    out / "posterior_damping",
                    formats=("png",),
                )
        return paths
