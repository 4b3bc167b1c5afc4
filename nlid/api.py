"""The verbs of nlid's Python API, exported from the package: ``import nlid; nlid.<verb>(...)``.

============================  ==============================================================
:func:`load`                  a record from a file or a bundled benchmark (``"dataset:emps"``)
:func:`simulate`              a record simulated from a preset, with noise, in one call
:func:`nlid.identify`         an :class:`~nlid.identified.model.IdentifiedModel` from a record
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

import contextlib
import math
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

from .data.record import Record
from .data.sources import as_record
from .errors import InputError, NlidError, brief
from .identification.pipeline import as_model, identify
from .identified.model import IdentifiedModel
from .identified.reference import FRAME_COLUMNS, Reference
from .identified.reference import compare as compare_fit
from .scoring import TransientRule, rule_from_spec

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd
    import xarray as xr

    from .bayes import Posterior
    from .discovery import DiscoveryResult
    from .discovery.structure_result import StructureDiscoveryResult
    from .study import StudyOutcome

__all__ = ["load", "simulate", "compare", "posterior", "discover", "run_study"]


def load(
    source: str | Path | Record | pd.DataFrame | xr.Dataset | Mapping[str, Any],
    *,
    columns: str | Mapping[str, str] | None = None,
    fs: float | None = None,
    force_hold: str | None = None,
    units: str | Mapping[str, str] | None = None,
) -> Record:
    """Read a record from a file, a bundled benchmark, a DataFrame, an xarray Dataset or a mapping of arrays.

    Files and tables share one column map and one set of rules (a DataFrame
    written to CSV and loaded gives the same record as the DataFrame itself);
    see :func:`nlid.data.sources.as_record`.

    Parameters
    ----------
    source
        A ``.csv`` (header names), ``.npz`` (read without pickle), MATLAB
        ``.mat`` (v7.3 too: ``nlid[hdf5]``), HDF5 ``.h5`` (``nlid[hdf5]``)
        or ``.parquet`` file (``nlid[parquet]``); ``"dataset:NAME[:PART]"`` for a measured benchmark
        read from ``$NLID_DATA_DIR`` (``dataset:emps``, ``dataset:silverbox``,
        ``dataset:silverbox:arrow``; see :mod:`nlid.data.datasets`); a pandas
        DataFrame (a named index is one more column: an index named ``t``
        is the time axis; see :meth:`Record.from_frame <nlid.data.record.Record.from_frame>`);
        an xarray Dataset (its coordinates and variables are the columns;
        xarray is optional); a mapping such as ``{"t": t, "f": f, "z": z}``;
        or a :class:`~nlid.data.record.Record`, returned as is.
    columns
        Which columns are which channels, with optional scale factors, e.g.
        ``"f=vir*gtau,z=qm"`` or ``{"f": "vir*gtau", "z": "qm"}`` (channels
        ``t, f, z, v, a``; default: columns named like the channels). A
        channel may carry its unit: ``"z[mm]=disp,a[g]=acc"``.
    fs
        Sampling frequency (Hz) when the file or table has no time column.
    force_hold
        ``"sampled"`` (a sampled continuous force, the default for measured
        data) or ``"zoh"`` (held over each sample); default: what the file's
        ``.meta.json`` says.
    units
        The unit of each channel, ``{"z": "mm", "a": "g"}`` or ``"z=mm,a=g"``
        (the vocabulary is :mod:`nlid.data.units`); converted to SI on the way in
        and kept in ``record.meta["input_units"]``. Default SI.

    Raises
    ------
    DataError
        An unreadable file, a missing column, a NaN (channel and index named)...
    InputError
        A source of another type (a list, a bare numpy array...), named in the
        message; a unit outside the vocabulary (channel, unit and the units
        accepted named).

    Examples
    --------
    ``nlid.load(frame, columns="t=time,f=load_N,z=disp_mm*0.001")`` reads a
    DataFrame ``frame`` exactly as ``nlid.load("rig.csv", columns=...)``
    reads the same columns from a file.
    """
    return as_record(source, columns=columns, fs=fs, force_hold=force_hold, units=units)


def simulate(
    preset: str = "paper-numerical",
    *,
    seed: int = 0,
    noise: float | Mapping[str, float] = 0.0,
    channels: str | Sequence[str] = ("z", "v", "a"),
    **overrides: Any,
) -> Record:
    """A record simulated from a preset (:mod:`nlid.simulation.presets`), in one call.

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
        With the truth in ``meta["reference"]`` (also readable as ``meta["truth"]``).
    """
    from .simulation.presets import get_preset

    p = get_preset(preset)
    if overrides:
        p = p.with_overrides(**overrides)
    if isinstance(channels, str):
        channels = tuple(c.strip() for c in channels.split(",") if c.strip())
    return p.simulate(seed, noise=noise, channels=tuple(channels))


def compare(
    record: Any,
    terms: str | Iterable[str] | Any,
    methods: Sequence[str] | None = None,
    *,
    mass: float | None = None,
    reference: Mapping[str, Any] | IdentifiedModel | Reference | None = None,
    holdout: Record | str | Path | float | None = None,
    options: Mapping[str, Mapping[str, Any]] | None = None,
    without: str | Iterable[str] | None = (),
    px_roots: Sequence[float] | None = None,
    errors: str = "record",
    rule: TransientRule | str | Mapping[str, Any] | None = None,
) -> pd.DataFrame:
    """Identify one model with several methods on one record; one tidy table of the results.

    Parameters
    ----------
    record
        The data.
    terms
        The model (as for :func:`nlid.identify`).
    methods
        Identifier names, as a list or one comma-separated string (default:
        every installed identifier except those that refine another's fit,
        ``refines = True`` such as ``oe``: they cost 10-100 times more, and
        the built-in studies leave them out too; name them to include them).
    mass
        Known mass (kg); ``None`` lets each method estimate it (methods that
        cannot are reported as failed).
    reference
        True or reference values: ``{"coefficients": {...}, "mass": ...,
        "equilibria": [...], "modal": [...]}``, a bare ``{term: value}``, an
        :class:`~nlid.identified.model.IdentifiedModel` or a
        :class:`~nlid.identified.reference.Reference` (:meth:`~nlid.identified.reference.Reference.of`).
        Default: the record's ``meta["reference"]`` (simulated records carry
        their truth there, measured benchmarks their published values);
        equilibria and modes of the reference are computed from its
        coefficients when not given.
    holdout
        A held-out record (or what :func:`load` reads: a file, ``"dataset:..."``),
        or the fraction of ``record`` to hold out (``0.25``: its last quarter,
        whole periods of a periodic record, as :class:`nlid.discovery.Split`
        divides it; the methods are then identified on the rest): adds epsilon,
        the force residual and the free-run error on it
        (:meth:`nlid.IdentifiedModel.score`).
    options
        ``{method: {option: value}}``.
    without, px_roots
        As for :func:`nlid.identify`.
    errors
        ``"record"`` (a failing method gets one row with ``quantity = "failed"``
        and the message in ``note``) or ``"raise"``.
    rule
        The transient rule of the free run on ``holdout`` (:mod:`nlid.scoring.rules`:
        ``"first-sample"``, ``"window:50"``, ``"periodic"``, ``"periodic:8192"``
        or a rule); default: the held-out record's own
        (:func:`nlid.scoring.default_rule`). The ``freerun_rmse`` row's
        ``note`` names the rule it was computed under.
        An unknown method name, or an option value a method refuses, is refused before
        anything runs (:class:`~nlid.errors.InputError`, with a suggestion), whatever ``errors``.

    On an indexed :class:`~nlid.data.record.Record` (several DOFs) ``terms`` are elements on
    connections (``"z3^3, (z1-z2)^3"``, checked before any method runs) and the rows are
    each element's coefficient, the underlying linear modes (``m1``, ``m2``...) and each
    DOF's residual against the structure's reference (:mod:`nlid.identification.structure_compare`);
    ``holdout``, ``rule`` and ``px_roots`` do not apply.

    Returns
    -------
    pandas.DataFrame
        One row per method and quantity: ``method``, ``quantity``
        (``coefficient``, ``mass``, ``equilibrium``, ``fn_hz``, ``zeta``,
        ``eps_percent``, ``force_residual_percent``, ``freerun_rmse``,
        ``seconds``), ``name`` (the term, ``s1``... for the stable
        equilibria matched to the reference, or which record), ``value``,
        ``std_error``, ``unit``, ``reference``, ``error_pct`` (signed,
        percent of ``|reference|``), ``note``, and the assumption about the record's force between
        samples with where it came from, ``force_hold`` and ``force_hold_source`` (the same on every row,
        and in ``frame.attrs["force_hold"]``: :mod:`nlid.data.forcehold`). The fitted models are in
        ``frame.attrs["models"]``.
    """
    record = as_record(record)
    import pandas as pd

    from .contract.methods import comparison_methods
    from .contract.registry import default_registry
    from .errors import PluginError

    if errors not in ("record", "raise"):
        raise InputError(f"errors must be 'record' or 'raise', got {errors!r}")
    structure = record.indexed  # several DOFs: elements on connections
    model = None if structure else as_model(terms, without=without, px_roots=px_roots)
    if isinstance(methods, str):
        methods = [m.strip() for m in methods.split(",") if m.strip()]
    registry = default_registry()
    names = list(methods) if methods is not None else comparison_methods(registry)
    if not names:
        raise InputError("no method to compare: none is installed and methods= is empty")
    for name in names:  # a misspelt name is the user's error, found before anything runs
        if not isinstance(name, str):
            raise InputError(f"methods= holds identifier names, got {type(name).__name__} {brief(name)}")
        if name not in registry.identifiers and name not in registry.failures:
            registry.get(name)  # raises InputError: unknown method, with a suggestion
    stray = [k for k in (options or {}) if k not in names]
    if stray:
        raise InputError(f"options= are given for {brief(stray[0])}, which is not among the methods compared ({names})")
    for name, given in (options or {}).items():  # option values are user input too: refused before anything runs
        if name in registry.identifiers:
            with contextlib.suppress(PluginError):  # the plugin itself is broken: that method's row says so
                registry.create(name, given)
    if structure:
        if holdout is not None or rule is not None or px_roots is not None:
            raise InputError("holdout=, rule= and px_roots= do not apply to a structure of several DOFs")
        from .identification.structure_compare import compare_structure

        srows, sfits = compare_structure(
            record,
            terms,
            names,
            mass=mass,
            reference=reference,
            options=options,
            without=without,
            errors=errors,
        )
        frame = pd.DataFrame(srows, columns=FRAME_COLUMNS)
        frame.attrs["models"] = sfits
        return _said(frame, record)
    ref = Reference.of(record, reference)
    rule = None if rule is None else rule_from_spec(rule)
    if isinstance(holdout, Record) and holdout.indexed:
        raise InputError("holdout=: a structure's record cannot hold out a one-DOF record's comparison")
    if holdout is not None and not isinstance(holdout, Record):
        if isinstance(holdout, (str, Path)):
            holdout = cast(Record, as_record(holdout))
        else:
            from .base.validate import HOLDOUT_FRACTION
            from .discovery.inputs import Split

            HOLDOUT_FRACTION.check(holdout, "holdout=")
            record, holdout, _ = Split(holdout=float(holdout)).divide(record)
    rows: list[dict[str, Any]] = []
    fits: dict[str, IdentifiedModel] = {}
    assert model is not None
    for name in names:
        try:
            fit = cast(IdentifiedModel, identify(record, model, name, mass=mass, options=(options or {}).get(name)))
        except NlidError as exc:
            if errors == "raise":
                raise
            rows.append({"method": name, "quantity": "failed", "name": "", "value": math.nan, "note": str(exc)})
            continue
        fits[name] = fit
        rows += [{"note": "", **r} for r in compare_fit(fit, ref, cast("Record | None", holdout), rule).records()]
    frame = pd.DataFrame(rows, columns=FRAME_COLUMNS)
    frame.attrs["models"] = fits
    return _said(frame, record)


def _said(frame: Any, record: Any) -> Any:
    """The frame with the record's force-hold assumption and its source (:mod:`nlid.data.forcehold`) on every row
    (columns ``force_hold``, ``force_hold_source``) and in ``frame.attrs["force_hold"]``."""
    from .data.forcehold import force_hold_source

    hold, source = record.force_hold, force_hold_source(record.meta)
    frame["force_hold"], frame["force_hold_source"] = hold, source
    frame.attrs["force_hold"] = {"hold": hold, "source": source}
    return frame


def posterior(
    record: Any, fit: IdentifiedModel, *, params: str | Iterable[str] = "damping", **settings: Any
) -> Posterior:
    """Posterior of chosen coefficients of an identified model, sampled with emcee.

    Parameters
    ----------
    record
        The record the model was identified on.
    fit
        The :class:`~nlid.identified.model.IdentifiedModel` (its mass is used).
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
    record: Any, declared: str | Iterable[str], method: str | None = None, **settings: Any
) -> DiscoveryResult | StructureDiscoveryResult:
    """Find the effects a declared model lacks (see :func:`nlid.discovery.discover` for the settings).

    On an indexed :class:`~nlid.data.record.Record` (several DOFs) this is
    :func:`nlid.discovery.structure.discover_structure`: ``declared`` are the
    declared elements (``"tanh(v3/0.001)"``), the settings are its own, and the
    result is a :class:`~nlid.discovery.structure_result.StructureDiscoveryResult`
    naming the connection that carries the missing element.

    Returns
    -------
    nlid.discovery.DiscoveryResult or nlid.discovery.structure_result.StructureDiscoveryResult
        ``.steps`` (each accepted effect with the error before and after),
        ``.final_model`` (an :class:`~nlid.identified.model.IdentifiedModel`),
        ``.summary()``, ``.to_dict()``.
    """
    record = as_record(record)
    if record.indexed:  # several DOFs: which connection lacks an element
        from .discovery.structure import discover_structure

        if method is not None:
            raise InputError(
                "method= does not apply to a structure record: discover fits every DOF by one joint least squares"
            )
        return discover_structure(record, declared, **settings)
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
        replacing them; see :mod:`nlid.runtime.outputs`).
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
