"""A posterior as the ecosystem reads it: an :class:`xarray.DataTree` (ArviZ 1.0's format), saved as netCDF.

:meth:`nlid.bayes.Posterior.to_datatree` builds the tree for every posterior
(one DOF and structures):

``posterior``
    One variable per sampled coefficient, dims ``(chain, draw)``: ``chain``
    is emcee's walker and ``draw`` the kept steps (burn-in dropped, thinned:
    the samples every nlid summary reads). Attributes: the SI unit, the term,
    the identifier's estimate, the prior, the autocorrelation time (steps)
    and the effective sample size.
``sample_stats``
    ``lp``: the log posterior density of each draw (up to a constant); the
    walkers' mean acceptance fraction as the attribute ``acceptance_fraction``
    (emcee reports the acceptance per walker over the whole run, not per draw).
``observed_data``
    The record's channels on its time axis (``t`` as the coordinate ``time``),
    each with its SI unit; absent when the posterior does not carry its record.

The root's attributes say what the summaries mean: nlid's tables, JSON and
figures report the **0.90 equal-tailed** interval (quantiles 0.05 and 0.95);
ArviZ's own default differs (0.94 HDI before 1.0, 0.89 from 1.0), so pass the
level (``ci_prob=0.9, ci_kind="eti"`` in ArviZ 1.0) to compare like with like.

xarray is optional (``pip install 'nlid[netcdf]'``: xarray and h5netcdf);
without it :func:`posterior_datatree` raises an :class:`~nlid.errors.InputError`
that says so. netCDF names cannot hold ``/``: a term such as ``tanh(v/0.01)``
is stored as ``tanh(v∕0.01)`` (U+2215), its spelling kept in the ``term`` attribute.
"""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import InputError

if TYPE_CHECKING:  # pragma: no cover
    import xarray as xr

    from .result import Posterior

__all__ = [
    "posterior_datatree",
    "write_netcdf",
    "netcdf_available",
    "require_netcdf",
    "variable_name",
    "CREDIBLE_LEVEL",
]

#: The level of the equal-tailed interval every nlid summary of a posterior reports (quantiles 0.05 and 0.95).
CREDIBLE_LEVEL = 0.9
#: What the extra installs (the message of a missing one names it).
EXTRA = "pip install 'nlid[netcdf]'"
#: The netCDF engines nlid writes with, in order of preference (both write groups; scipy's does not).
ENGINES = ("h5netcdf", "netCDF4")


def _installed(name: str) -> bool:
    return importlib.util.find_spec(name) is not None


def netcdf_available() -> bool:
    """True when xarray (with ``DataTree``) and a netCDF-4 engine are installed, so ``posterior.nc`` can be written."""
    return _xarray(required=False) is not None and any(_installed(e) for e in ENGINES)


def _xarray(required: bool = True) -> Any:
    """The xarray module when it has ``DataTree`` (xarray >= 2024.10); else ``None``, or an error when required."""
    if _installed("xarray"):
        import xarray

        if hasattr(xarray, "DataTree"):
            return xarray
        if required:
            raise InputError(
                f"to_datatree needs xarray >= 2024.10 (xarray.DataTree); xarray {xarray.__version__} is installed "
                f"({EXTRA})"
            )
        return None
    if required:
        raise InputError(f"to_datatree needs the optional package xarray ({EXTRA})")
    return None


def variable_name(term: str) -> str:
    """The netCDF variable name of a coefficient: its term with ``/`` written as U+2215 (``/`` separates groups)."""
    return term.replace("/", "\u2215")


def _posterior_group(post: Posterior, xr: Any) -> Any:
    chains = post.chains
    kept = chains.chain[chains.burn :: chains.thin]  # (draws, walkers, d): exactly post.samples, reshaped
    coords = {"chain": np.arange(kept.shape[1]), "draw": np.arange(kept.shape[0])}
    tau, ess, summary = post.tau, post.n_effective, post.summary_dict()
    variables = {}
    for i, name in enumerate(post.names):
        attrs = {
            "units": post.unit(name),
            "term": name,
            "start": float(post.start[name]),
            "prior": post.priors.get(name, ""),
            "tau_steps": float(tau[name]),
            "n_effective": float(ess[name]),
            "q05": summary[name]["q05"],
            "q95": summary[name]["q95"],
        }
        if name in post.reference:
            attrs["reference"] = float(post.reference[name])
        variables[variable_name(name)] = xr.DataArray(kept[:, :, i].T.copy(), dims=("chain", "draw"), attrs=attrs)
    attrs = {
        "description": "coefficients of R(z, v) = f - m a, each in its SI unit (attribute units)",
        "chain": "emcee walker",
        "draw": f"kept step (burn-in {chains.burn} steps dropped, thinned by {chains.thin})",
    }
    return xr.Dataset(variables, coords=coords, attrs=attrs)


def _sample_stats_group(post: Posterior, xr: Any) -> Any:
    chains = post.chains
    lp = chains.log_prob[chains.burn :: chains.thin].T.copy()
    coords = {"chain": np.arange(lp.shape[0]), "draw": np.arange(lp.shape[1])}
    lp_attrs = {"description": "log posterior density of the draw, up to a constant (prior + likelihood)"}
    attrs = {
        "acceptance_fraction": float(chains.acceptance),
        "acceptance_description": "mean over the walkers of emcee's acceptance fraction over the whole run",
        "walkers": chains.walkers,
        "steps": chains.steps,
        "burn": chains.burn,
        "thin": chains.thin,
    }
    return xr.Dataset({"lp": xr.DataArray(lp, dims=("chain", "draw"), attrs=lp_attrs)}, coords=coords, attrs=attrs)


def _observed_group(record: Any, xr: Any) -> Any:
    arrays = record.to_dict()
    t = np.asarray(arrays.pop("t"), dtype=float)
    units = dict(getattr(record, "units", {}) or {})
    variables = {
        name: xr.DataArray(np.asarray(x, dtype=float), dims=("time",), attrs={"units": str(units.get(name, ""))})
        for name, x in arrays.items()
    }
    attrs = {"fs_hz": float(record.fs), "force_hold": str(record.force_hold)}
    source = (record.meta or {}).get("source")
    if source:
        attrs["source"] = str(source)
    time = xr.DataArray(t, dims=("time",), attrs={"units": "s"})
    return xr.Dataset(variables, coords={"time": time}, attrs=attrs)


def _root_attrs(post: Posterior) -> dict[str, Any]:
    import emcee

    from .. import __version__

    lo, hi = (1 - CREDIBLE_LEVEL) / 2, (1 + CREDIBLE_LEVEL) / 2
    return {
        "credible_interval": CREDIBLE_LEVEL,
        "credible_interval_kind": "equal-tailed",
        "credible_interval_quantiles": np.array([lo, hi]),
        "credible_interval_note": (
            f"nlid's summaries (print(post), posterior_table.csv, posterior.json q05/q95) report the "
            f"{CREDIBLE_LEVEL:.2f} equal-tailed interval; ArviZ's default differs (0.94 HDI before 1.0, 0.89 from "
            f"1.0): pass ci_prob={CREDIBLE_LEVEL:g}, ci_kind='eti' (ArviZ 1.0) to compare like with like"
        ),
        "inference_library": "emcee",
        "inference_library_version": str(emcee.__version__),
        "creation_library": "nlid",
        "creation_library_version": __version__,
        "method": post.method,
        "others": post.others,
        "mass_kg": json.dumps(post.mass),
        "not_sampled": json.dumps(post.not_sampled),
        "bias_correction": int(bool(post.likelihood.info.get("bias_correction"))),
        "bias_shift_sd": json.dumps(post.bias_shifts),
        "warnings": json.dumps(list(post.warnings)),
    }


def posterior_datatree(post: Posterior, record: Any = None) -> xr.DataTree:
    """The posterior as an :class:`xarray.DataTree` with the groups of the module docstring.

    Parameters
    ----------
    post
        The posterior (one DOF or a structure).
    record
        The record whose channels fill ``observed_data`` (default: the one the
        posterior was sampled from, when it carries it).

    Raises
    ------
    InputError
        xarray (>= 2024.10, with ``DataTree``) is not installed.
    """
    xr = _xarray()
    groups = {"posterior": _posterior_group(post, xr), "sample_stats": _sample_stats_group(post, xr)}
    record = record if record is not None else post.record
    if record is not None:
        groups["observed_data"] = _observed_group(record, xr)
    tree = xr.DataTree.from_dict({f"/{k}": v for k, v in groups.items()})
    tree.attrs.update(_root_attrs(post))
    return tree


def require_netcdf() -> str:
    """The netCDF engine nlid writes with (``"h5netcdf"`` or ``"netcdf4"``).

    Raises
    ------
    InputError
        xarray (with ``DataTree``), or both h5netcdf and netCDF4, are not installed.
    """
    _xarray()
    engine = next((e for e in ENGINES if _installed(e)), None)
    if engine is None:
        raise InputError(f"writing posterior.nc needs the optional package h5netcdf or netCDF4 ({EXTRA})")
    return engine.lower()


def write_netcdf(tree: xr.DataTree, path: str | Path) -> Path:
    """Write the tree as one netCDF-4 file (its groups as netCDF groups) with the first engine installed.

    Raises
    ------
    InputError
        A package is missing (:func:`require_netcdf`).
    """
    path = Path(path)
    tree.to_netcdf(path, engine=require_netcdf())
    return path
