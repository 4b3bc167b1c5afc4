"""The verbs of nlid's Python API, exported from the package: ``import nlid; nlid.<verb>(...)``.

============================  ==============================================================
:func:`load`                  a record from a file or a bundled benchmark (``"dataset:emps"``)
:func:`simulate`              a record simulated from a preset, with noise, in one call
:func:`nlid.identify`         an :class:`~nlid.identified.IdentifiedModel` from a record
:func:`compare`               several methods on one record, as a tidy :class:`pandas.DataFrame`
:func:`posterior`             posterior of chosen coefficients (emcee), from an identified model
:func:`discover`              the residual -> missing-effect loop, as an object with its steps
:func:`run_study`             a benchmark study (built-in name or TOML file)
============================  ==============================================================

The modules these verbs draw on are named differently on purpose
(:mod:`nlid.simulation`, :mod:`nlid.bayes`, :mod:`nlid.discovery`), so that
importing one of them never replaces a verb on the package.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .errors import InputError, NlidError
from .identified import IdentifiedModel
from .pipeline import as_model, identify
from .record import Record
from .sources import as_record

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd
    import xarray as xr

    from .bayes import Posterior
    from .discovery import DiscoveryResult
    from .study import StudyOutcome

__all__ = ["load", "simulate", "compare", "posterior", "discover", "run_study"]


def load(
    source: str | Path | Record | pd.DataFrame | xr.Dataset | Mapping[str, Any],
    *,
    columns: str | Mapping[str, str] | None = None,
    fs: float | None = None,
    force_hold: str | None = None,
) -> Record:
    """Read a record from a file, a bundled benchmark, a DataFrame, an xarray Dataset or a mapping of arrays.

    Files and tables share one column map and one set of rules (a DataFrame
    written to CSV and loaded gives the same record as the DataFrame itself);
    see :func:`nlid.sources.as_record`.

    Parameters
    ----------
    source
        A ``.csv`` (header names), ``.npz`` (read without pickle) or MATLAB
        ``.mat`` file; ``"dataset:NAME[:PART]"`` for a measured benchmark
        read from ``$NLID_DATA_DIR`` (``dataset:emps``, ``dataset:silverbox``,
        ``dataset:silverbox:arrow``; see :mod:`nlid.datasets`); a pandas
        DataFrame (a named index is one more column: an index named ``t``
        is the time axis; see :meth:`Record.from_frame <nlid.record.Record.from_frame>`);
        an xarray Dataset (its coordinates and variables are the columns;
        xarray is optional); a mapping such as ``{"t": t, "f": f, "z": z}``;
        or a :class:`~nlid.record.Record`, returned as is.
    columns
        Which columns are which channels, with optional scale factors, e.g.
        ``"f=vir*gtau,z=qm"`` or ``{"f": "vir*gtau", "z": "qm"}`` (channels
        ``t, f, z, v, a``; default: columns named like the channels).
    fs
        Sampling frequency (Hz) when the file or table has no time column.
    force_hold
        ``"sampled"`` (a sampled continuous force, the default for measured
        data) or ``"zoh"`` (held over each sample); default: what the file's
        ``.meta.json`` says.

    Raises
    ------
    DataError
        An unreadable file, a missing column, a NaN (channel and index named)...
    InputError
        A source of another type (a list, a bare numpy array...), named in the message.

    Examples
    --------
    ``nlid.load(frame, columns="t=time,f=load_N,z=disp_mm*0.001")`` reads a
    DataFrame ``frame`` exactly as ``nlid.load("rig.csv", columns=...)``
    reads the same columns from a file.
    """
    return as_record(source, columns=columns, fs=fs, force_hold=force_hold)


def simulate(
    preset: str = "paper-numerical",
    *,
    seed: int = 0,
    noise: float | Mapping[str, float] = 0.0,
    channels: str | Sequence[str] = ("z", "v", "a"),
    **overrides: Any,
) -> Record:
    """A record simulated from a preset (:mod:`nlid.presets`), in one call.

    Parameters
    ----------
    preset
        ``"paper-numerical"`` (the paper's Sec. 3) or ``"paper-experimental"``
        (an analogue of its Sec. 4 rig).
    seed
        Seed of the force and of the noise.
    noise
        Measurement noise as a fraction of each response channel's standard
        deviation (``0.02`` = 2 %), one number or ``{"z": 0.02, "a": 0.02}``.
    channels
        Response channels recorded (``z`` always): ``"z,a"`` or ``("z", "a")``.
    **overrides
        Preset fields (``duration=30``, ``fs=1024``, ``force_rms=20``) or
        ``coefficients={...}``.

    Returns
    -------
    Record
        With the truth in ``meta["truth"]``.
    """
    from .presets import get_preset

    p = get_preset(preset)
    if overrides:
        p = p.with_overrides(**overrides)
    if isinstance(channels, str):
        channels = tuple(c.strip() for c in channels.split(",") if c.strip())
    return p.simulate(seed, noise=noise, channels=tuple(channels))


def _reference_of(record: Record, reference: Any) -> dict[str, Any]:
    if reference is None:
        truth = record.meta.get("truth")
        return dict(truth) if isinstance(truth, Mapping) else {}
    if isinstance(reference, IdentifiedModel):
        eq = reference.equilibria
        return {
            "coefficients": dict(reference.coefficients),
            "mass": reference.mass,
            "equilibria": None if eq is None else list(eq.stable),
            "modal": [m.to_dict() for m in reference.modal],
        }
    if isinstance(reference, Mapping):
        out = dict(reference)
        if "coefficients" not in out and not {"mass", "equilibria", "modal"} & set(out):
            out = {"coefficients": out}  # a bare {term: value}
        return out
    raise InputError(f"reference must be a dict, an IdentifiedModel or None, got {type(reference).__name__}")


def _error_pct(value: float, ref: float | None) -> float:
    if ref is None or not ref or not math.isfinite(value):
        return math.nan
    return 100.0 * (value - ref) / abs(ref)


def _rows(fit: IdentifiedModel, reference: Mapping[str, Any], holdout: Record | None) -> list[dict[str, Any]]:
    from .physics import equilibria as equilibria_of
    from .physics import modal as modal_of
    from .terms import Model

    ref_coeffs = {}
    for k, v in (reference.get("coefficients") or {}).items():
        try:
            ref_coeffs[Model.from_spec([k], defaults=False).names[0]] = float(v)
        except NlidError:
            continue
    se = fit.standard_errors or {}
    rows: list[dict[str, Any]] = []

    def add(quantity: str, name: str, value: float, unit: str, ref: float | None = None, std: float = math.nan):
        rows.append(
            {
                "method": fit.method,
                "quantity": quantity,
                "name": name,
                "value": float(value),
                "std_error": float(std),
                "unit": unit,
                "reference": math.nan if ref is None else float(ref),
                "error_pct": _error_pct(float(value), ref),
            }
        )

    for name, term in zip(fit.terms, fit.model.terms, strict=True):
        add("coefficient", name, fit.coefficients[name], term.coefficient_unit, ref_coeffs.get(name), se.get(name, math.nan))
    if fit.mass is not None:
        ref_mass = reference.get("mass") if fit.mass_estimated else None
        add("mass", "mass", fit.mass, "kg", ref_mass, fit.mass_standard_error or math.nan)
    # equilibria and modes, matched to the reference's stable equilibria (nearest first)
    ref_eq = list(reference.get("equilibria") or [])
    ref_modal = list(reference.get("modal") or [])
    if not ref_eq and ref_coeffs and fit.z_range is not None:
        try:
            true_model = Model.from_spec(list(ref_coeffs), defaults=False, px_roots=reference.get("px_roots"))
            ref_eq = list(equilibria_of(true_model, ref_coeffs, fit.z_range).stable)
            if reference.get("mass"):
                ref_modal = [m.to_dict() for m in modal_of(true_model, ref_coeffs, float(reference["mass"]), ref_eq)]
        except NlidError:
            ref_eq, ref_modal = [], []
    stable = sorted(fit.equilibria.stable) if fit.equilibria is not None else []
    from .study.metrics import match_equilibria

    match = match_equilibria(ref_eq, stable) if ref_eq else {}
    inverse = {j: i for i, j in match.items()}
    modal_by_eq = {m.equilibrium: m for m in fit.modal}
    for j, z in enumerate(stable):
        i = inverse.get(j)
        label = f"s{j + 1}" if i is None else f"s{i + 1}"
        ref_z = ref_eq[i] if i is not None else None
        add("equilibrium", label, z, "m", ref_z)
        m = modal_by_eq.get(z) or min(fit.modal, key=lambda mm: abs(mm.equilibrium - z), default=None)
        if m is None:
            continue
        ref_m = ref_modal[i] if i is not None and i < len(ref_modal) else {}
        add("fn_hz", label, m.fn_hz, "Hz", ref_m.get("fn_hz"))
        add("zeta", label, m.zeta, "1", ref_m.get("zeta"))
    if fit.scores is not None:
        add("eps_percent", "estimation", fit.scores.eps_percent, "%")
        add("force_residual_percent", "estimation", fit.scores.force_residual_percent, "%")
    if holdout is not None and fit.mass is not None:
        held = fit.score(holdout)
        add("eps_percent", "holdout", held.eps_percent, "%")
        add("force_residual_percent", "holdout", held.force_residual_percent, "%")
        add("freerun_rmse", "holdout", held.freerun_rmse, holdout.units.get("z", "m"))
    if fit.seconds is not None:
        add("seconds", "identification", fit.seconds, "s")
    return rows


def compare(
    record: Record,
    terms: str | Iterable[str] | Any,
    methods: Sequence[str] | None = None,
    *,
    mass: float | None = None,
    reference: Mapping[str, Any] | IdentifiedModel | None = None,
    holdout: Record | None = None,
    options: Mapping[str, Mapping[str, Any]] | None = None,
    without: str | Iterable[str] = (),
    px_roots: Sequence[float] | None = None,
    errors: str = "record",
) -> pd.DataFrame:
    """Identify one model with several methods on one record; one tidy table of the results.

    Parameters
    ----------
    record
        The data.
    terms
        The model (as for :func:`nlid.identify`).
    methods
        Identifier names (default: every installed identifier).
    mass
        Known mass (kg); ``None`` lets each method estimate it (methods that
        cannot are reported as failed).
    reference
        True or reference values: ``{"coefficients": {...}, "mass": ...,
        "equilibria": [...], "modal": [...]}``, a bare ``{term: value}``, or an
        :class:`~nlid.identified.IdentifiedModel`. Default: the record's
        ``meta["truth"]`` (simulated records carry it); equilibria and modes of
        the reference are computed from its coefficients when not given.
    holdout
        A held-out record: adds epsilon, the force residual and the free-run
        error on it (:meth:`nlid.IdentifiedModel.score`).
    options
        ``{method: {option: value}}``.
    without, px_roots
        As for :func:`nlid.identify`.
    errors
        ``"record"`` (a failing method gets one row with ``quantity = "failed"``
        and the message in ``note``) or ``"raise"``.

    Returns
    -------
    pandas.DataFrame
        One row per method and quantity: ``method``, ``quantity``
        (``coefficient``, ``mass``, ``equilibrium``, ``fn_hz``, ``zeta``,
        ``eps_percent``, ``force_residual_percent``, ``freerun_rmse``,
        ``seconds``), ``name`` (the term, ``s1``... for the stable
        equilibria matched to the reference, or which record), ``value``,
        ``std_error``, ``unit``, ``reference``, ``error_pct`` (signed,
        percent of ``|reference|``) and ``note``. The fitted models are in
        ``frame.attrs["models"]``.
    """
    record = as_record(record)
    import pandas as pd

    from .registry import default_registry

    if errors not in ("record", "raise"):
        raise InputError(f"errors must be 'record' or 'raise', got {errors!r}")
    model = as_model(terms, without=without, px_roots=px_roots)
    names = list(methods) if methods is not None else default_registry().names()
    if not names:
        raise InputError("no method to compare: none is installed and methods= is empty")
    ref = _reference_of(record, reference)
    rows: list[dict[str, Any]] = []
    fits: dict[str, IdentifiedModel] = {}
    for name in names:
        try:
            fit = identify(record, model, name, mass=mass, options=(options or {}).get(name))
        except NlidError as exc:
            if errors == "raise":
                raise
            rows.append({"method": name, "quantity": "failed", "name": "", "value": math.nan, "note": str(exc)})
            continue
        fits[name] = fit
        rows += [{**r, "note": ""} for r in _rows(fit, ref, holdout)]
    columns = ["method", "quantity", "name", "value", "std_error", "unit", "reference", "error_pct", "note"]
    frame = pd.DataFrame(rows, columns=columns)
    frame.attrs["models"] = fits
    return frame


def posterior(
    record: Record, fit: IdentifiedModel, *, params: str | Iterable[str] = "damping", **settings: Any
) -> Posterior:
    """Posterior of chosen coefficients of an identified model, sampled with emcee.

    Parameters
    ----------
    record
        The record the model was identified on.
    fit
        The :class:`~nlid.identified.IdentifiedModel` (its mass is used).
    params
        ``"damping"`` (every velocity-dependent term), ``"all"`` or terms.
    **settings
        :class:`nlid.bayes.PosteriorSampler` settings: ``seed``, ``priors``,
        ``walkers``, ``noise``, ``others``, ``bias_correction``...

    Returns
    -------
    nlid.bayes.Posterior
    """
    record = as_record(record)
    from .bayes import PosteriorSampler

    return PosteriorSampler(params, **settings).run(record, fit)


def discover(
    record: Record, declared: str | Iterable[str], method: str | None = None, **settings: Any
) -> DiscoveryResult:
    """Find the effects a declared model lacks (see :func:`nlid.discovery.discover` for the settings).

    Returns
    -------
    nlid.discovery.DiscoveryResult
        ``.steps`` (each accepted effect with the error before and after),
        ``.final_model`` (an :class:`~nlid.identified.IdentifiedModel`),
        ``.summary()``, ``.to_dict()``.
    """
    record = as_record(record)
    from .discovery import discover as _discover

    return _discover(record, declared, method, **settings)


def run_study(
    study: str | Path,
    out: str | Path | None = None,
    *,
    jobs: int | None = None,
    executor: str = "local",
    rerun: bool = False,
    report: bool = True,
    progress: bool | None = None,
    force: bool = False,
) -> StudyOutcome:
    """Run a study (a built-in name such as ``"paper-numerical"`` or a TOML file) and write its report.

    Parameters
    ----------
    study
        Built-in study name (``nlid study list``) or path to a ``.toml`` file.
    out
        Output folder (default ``nlid-studies/<name>``); finished runs found
        there are reused (the study resumes).
    jobs
        Concurrent runs (default: every core).
    executor
        ``"local"`` or ``"dask"``.
    rerun
        Run everything again.
    report
        Write ``results.csv``, ``summary.md``, figures and ``report.html``.
    progress
        Show a progress line (default: when stderr is a terminal).
    force
        Write into a folder that holds files nlid did not write (never
        replacing them; see :mod:`nlid.outputs`).
    """
    from .study import load_study, make_executor
    from .study import run_study as _run

    config = load_study(study)
    folder = Path(out) if out is not None else Path("nlid-studies") / config.name
    return _run(
        config,
        folder,
        executor=make_executor(executor, jobs=jobs),
        rerun=rerun,
        report=report,
        progress=progress,
        force=force,
    )
