"""The identified model: one immutable object every layer of nlid shares.

:func:`nlid.identify` returns an :class:`IdentifiedModel`. It binds the
:class:`~nlid.model.terms.Model` (with its ``px(z)`` roots) to the identified
coefficients and mass, and carries what the core computed from them the same
way for every method: the equilibria (Sec. 2.1), the modal parameters at each
stable equilibrium (Eq. 8, 22), and the scores on the estimation record
(:mod:`nlid.scoring`: epsilon of Eq. 26 and the force residual). Studies,
discovery, posteriors and the command line consume this object; nobody
rebuilds a model from a dictionary of coefficients.

Example::

    import nlid

    record = nlid.simulate("paper-numerical", seed=0, noise=0.02, channels="z")
    fit = nlid.identify(record, "z^3, z^2, v*|v|", method="rfs", mass=0.2)
    fit                       # short repr; a table in Jupyter
    print(fit.summary())      # the table `nlid identify` prints
    fit.score(other_record)   # epsilon, force residual, free-run error
    fit.to_dict()             # JSON (what `nlid identify --json` prints)

Its plain-data layout is in :mod:`nlid.identified.schema`, its tables in
:mod:`nlid.identified.tables` and its figures in :mod:`nlid.identified.plots`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from .. import scoring
from ..base import numerics
from ..base.dimensions import mass_unit
from ..base.frozen import FrozenDict
from ..base.validate import check_mass
from ..contract.estimate import Estimate
from ..data.record import Record
from ..errors import InputError, NlidError
from ..estimation.inputpath import InputPath, input_path
from ..model import physics
from ..model.physics import Equilibria, Modal
from ..model.terms import Model
from ..report.summary import Summary
from ..scoring import Prediction, Residual, Scores, TransientRule
from . import plausibility
from . import plots as modelplots
from .plausibility import Flag
from .result import Identified, Recomputed
from .schema import STALE_NOTE, model_from_dict, model_to_dict
from .tables import coefficient_frame, model_summary, record_units

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd

__all__ = [
    "IdentifiedModel",
]


@dataclass(frozen=True, eq=False)
class IdentifiedModel(Identified):
    """A model with its identified coefficients, mass and everything derived from them.

    Build it with :func:`nlid.identify` (or :meth:`from_dict`); the
    constructor is public for methods that produce a model another way, and
    validates what it is given.

    Attributes
    ----------
    model
        The terms, with the ``px(z)`` roots the identification settled on.
    coefficients
        ``{canonical term: value}`` in model order, each the coefficient of
        its term in ``R(z, v) = f - m z''`` (SI units, read-only).
    mass
        Mass in kg (given or estimated), ``None`` if unknown.
    method
        The identifier's name.
    mass_estimated
        ``True`` when the method estimated the mass.
    standard_errors
        Standard error of each coefficient, when the method gives them.
    mass_standard_error
        Standard error of an estimated mass.
    equilibria
        Stable and unstable equilibria of the identified ``K(z)`` (m).
    modal
        Modal parameters at each stable equilibrium (:class:`~nlid.model.physics.Modal`).
    scores
        Scores on the estimation record (:class:`~nlid.scoring.Scores`,
        without the free run), ``None`` when the mass is unknown.
    options
        The identifier's settings (its options with defaults filled).
    diagnostics
        Method-specific details (read-only).
    warnings
        Things the user should know.
    flags
        The checks of what physics forbids that the model fails (:class:`~nlid.identified.plausibility.Flag`:
        a negative or supercritical damping ratio, a force residual above 100 %, a friction law that feeds
        energy in, a given mass the record contradicts); empty when it passes them. A flagged model cannot
        be trusted: ``nlid`` commands exit with status 1 on it (:mod:`nlid.identified.plausibility`).
    seconds
        Wall time of the identification.
    z_range
        ``(min, max)`` of the estimation record's displacement (m).
    arrays
        Large numeric outputs of the method (not in :meth:`to_dict`).
    input_path
        What happens to a record's force before it acts on the model (:class:`~nlid.estimation.inputpath.InputPath`:
        a delay, a first-order lag, the force's hold between samples); the identity when the force acts
        as recorded. Every score, prediction and simulation on a record applies it to the record's force.
    provenance
        Where the model came from, enough to identify it again from its JSON
        alone: the nlid version, the data's source and SHA-256, the column
        map and units it was read with, and the call (terms, method, options,
        mass). :func:`nlid.identify` fills it (layout and how to repeat it:
        :mod:`nlid.identification.provenance`); empty for a model made another way.
    """

    model: Model
    coefficients: Mapping[str, float]
    mass: float | None
    method: str
    mass_estimated: bool = False
    standard_errors: Mapping[str, float] | None = None
    mass_standard_error: float | None = None
    equilibria: Equilibria | None = None
    modal: tuple[Modal, ...] = ()
    scores: Scores | None = None
    options: Mapping[str, Any] = field(default_factory=FrozenDict)
    diagnostics: Mapping[str, Any] = field(default_factory=FrozenDict)
    warnings: tuple[str, ...] = ()
    flags: tuple[Flag, ...] = ()
    seconds: float | None = None
    z_range: tuple[float, float] | None = None
    arrays: Mapping[str, np.ndarray] = field(default_factory=FrozenDict, repr=False)
    provenance: Mapping[str, Any] = field(default_factory=FrozenDict, repr=False)
    input_path: InputPath = field(default_factory=InputPath)

    def __post_init__(self) -> None:
        if not isinstance(self.model, Model):
            raise InputError(f"model must be an nlid Model, got {type(self.model).__name__}")
        names = self.model.names
        given = {self.model.terms[self.model.index(k)].name: v for k, v in dict(self.coefficients).items()}
        missing = [n for n in names if n not in given]
        if missing or len(given) != len(names):
            raise InputError(f"coefficients are given for {sorted(given)} but the model is {list(names)}")
        set_ = object.__setattr__
        set_(self, "coefficients", FrozenDict({n: float(given[n]) for n in names}))
        if self.standard_errors is not None:
            se = {self.model.terms[self.model.index(k)].name: v for k, v in dict(self.standard_errors).items()}
            set_(self, "standard_errors", FrozenDict({n: float(se[n]) for n in names if se.get(n) is not None}))
        if self.mass is not None:
            set_(self, "mass", check_mass(self.mass))
        set_(self, "modal", tuple(Modal.from_dict(m) for m in self.modal))
        self._freeze_shared()
        set_(self, "input_path", input_path(self.input_path))
        if self.z_range is not None:
            set_(self, "z_range", (float(min(self.z_range)), float(max(self.z_range))))

    # ------------------------------------------------------------------ built by the core
    @classmethod
    def from_estimate(
        cls,
        estimate: Estimate,
        *,
        model: Model,
        record: Record,
        method: str,
        mass: float | None = None,
        options: Mapping[str, Any] | None = None,
        seconds: float | None = None,
        cutoff: float | None = None,
        diagnostics: Mapping[str, Any] | None = None,
        numerical: Sequence[str] = (),
    ) -> IdentifiedModel:
        """Complete an identifier's :class:`~nlid.contract.estimate.Estimate` (what :func:`nlid.identify` does).

        Equilibria and modal parameters come from :mod:`nlid.model.physics` (modal
        only if the method did not measure its own), the scores on the
        estimation record from :mod:`nlid.scoring` (always from the data).
        A result with a figure that is not finite (:meth:`problems`) is
        refused; one that breaks a rule of physics is returned with its
        :attr:`flags` (:func:`nlid.identified.plausibility.check`); numpy's
        runtime warnings never reach the terminal: they are named in that refusal, or, when every figure is finite, in
        :attr:`warnings`.

        Parameters
        ----------
        estimate
            What the identifier returned.
        model
            The model it was identified with (``px(z)`` roots set).
        record
            The estimation record.
        method
            The identifier's name.
        mass
            The given mass (kg), ``None`` if the method estimated it.
        options
            The identifier's settings.
        seconds
            Wall time.
        cutoff
            Equation band (Hz) for the scores.
        diagnostics
            Diagnostics the core adds (e.g. the ``px(z)`` iteration).
        numerical
            Runtime warnings collected while the estimate was computed
            (:func:`nlid.base.numerics.collect_warnings`).

        Raises
        ------
        IdentificationError
            When a reported figure (coefficient, standard error, mass,
            equilibrium, natural frequency, damping ratio, epsilon, force
            residual) is not finite.
        """
        with numerics.collect_warnings() as caught:
            draft = cls._complete(estimate, model, record, method, mass, options, seconds, cutoff, diagnostics)
        found = [*numerical, *caught]
        return plausibility.trusted(draft, method, found, lambda fit: plausibility.check(fit, record, cutoff=cutoff))

    @classmethod
    def _complete(
        cls,
        estimate: Estimate,
        model: Model,
        record: Record,
        method: str,
        mass: float | None,
        options: Mapping[str, Any] | None,
        seconds: float | None,
        cutoff: float | None,
        diagnostics: Mapping[str, Any] | None,
    ) -> IdentifiedModel:
        warnings = list(estimate.warnings)
        if mass is not None:
            used, estimated = float(mass), False
        elif estimate.mass is not None:
            used, estimated = float(estimate.mass), True
        else:
            used, estimated = None, False
        z_range = (float(record.z.min()), float(record.z.max()))
        theta = model.vector(dict(estimate.coefficients))
        try:
            eq: Equilibria | None = physics.equilibria(model, theta, z_range)
        except NlidError as exc:
            eq = None
            warnings.append(f"equilibria not computed: {exc}")
        except np.linalg.LinAlgError as exc:  # e.g. a subnormal leading coefficient of K(z)
            eq = None
            warnings.append(f"equilibria not computed: the roots of K(z) could not be computed ({exc})")
        if estimate.modal is not None:
            modal: tuple[Modal, ...] = tuple(Modal.from_dict(m) for m in estimate.modal)
        elif eq is not None and used is not None:
            modal = tuple(physics.modal(model, theta, used, eq.stable, z_range))
        else:
            modal = ()
        draft = cls(
            model=model,
            coefficients=estimate.coefficients,
            mass=used,
            method=method,
            mass_estimated=estimated,
            standard_errors=estimate.standard_errors,
            mass_standard_error=estimate.mass_standard_error if estimated else None,
            equilibria=eq,
            modal=modal,
            options=options or {},
            seconds=seconds,
            z_range=z_range,
            arrays=estimate.arrays,
        )
        diag = {**dict(estimate.diagnostics), **dict(diagnostics or {})}
        scores = None
        if used is not None:
            scores = scoring.score(draft, record, cutoff=cutoff, free_run=False)
            diag.setdefault("eps_band_hz", scores.band_hz)
        else:
            warnings.append("epsilon not computed: the mass is unknown")
        return dataclasses.replace(draft, scores=scores, diagnostics=diag, warnings=tuple(warnings))

    def problems(self) -> list[str]:
        """The reported figures that are not finite, or contradict each other (empty when all is well).

        Checked: coefficients, standard errors (finite, not negative), mass
        and its standard error, equilibria, natural frequencies (positive),
        damping ratios, and epsilon and the force residual on the estimation
        record.
        """
        out = []
        found = numerics.nonfinite("coefficients", self.coefficients)
        out += [found] if found else []
        out += self._standard_error_problems()
        se_mass = self.mass_standard_error
        if se_mass is not None and not (numerics.is_finite(se_mass) and se_mass >= 0):
            out.append(f"the standard error of the mass is {se_mass}")
        if self.equilibria is not None:
            bad_eq = [z for z in self.equilibria.all if not numerics.is_finite(z)]
            if bad_eq:
                out.append(f"an equilibrium is {bad_eq[0]}")
        for m in self.modal:
            if not (numerics.is_finite(m.fn_hz) and m.fn_hz > 0 and numerics.is_finite(m.zeta)):
                out.append(f"the modal parameters at z* = {m.equilibrium:.6g} m are fn = {m.fn_hz} Hz, zeta = {m.zeta}")
        if self.scores is not None:
            scores = {"epsilon": self.scores.eps_percent, "the force residual": self.scores.force_residual_percent}
            found = numerics.nonfinite("", scores)
            out += [found] if found else []
        return out

    # ------------------------------------------------------------------ plain views
    @property
    def terms(self) -> tuple[str, ...]:
        """Canonical names of the terms, in model order."""
        return self.model.names

    @property
    def px_roots(self) -> tuple[float, float] | None:
        """``(z-, z+)`` of ``px(z)`` (Eq. 9-11), if the model uses it."""
        return self.model.px_roots

    @property
    def theta(self) -> np.ndarray:
        """The coefficients as a (read-only) vector in model order."""
        out = np.array([self.coefficients[n] for n in self.model.names])
        out.flags.writeable = False
        return out

    @property
    def eps_percent(self) -> float | None:
        """Epsilon (Eq. 26) on the estimation record."""
        return None if self.scores is None else self.scores.eps_percent

    @property
    def force_residual_percent(self) -> float | None:
        """The force residual on the estimation record."""
        return None if self.scores is None else self.scores.force_residual_percent

    def coefficient(self, term: str) -> float:
        """The coefficient of ``term`` (any spelling)."""
        return self.coefficients[self.model.terms[self.model.index(term)].name]

    # ------------------------------------------------------------------ the physics of the model
    def restoring_force(self, z: np.ndarray, v: np.ndarray) -> np.ndarray:
        """``R(z, v) = K(z) + D(z, v)`` (N), Eq. 25.

        Evaluated element-wise like a numpy function: a NaN (or an infinity) in ``z`` or ``v`` gives
        NaN (or what the terms make of the infinity) at that element, without an error or a warning,
        so that arrays with gaps can be evaluated. The same holds for :meth:`elastic`,
        :meth:`damping` and :meth:`potential`; test the inputs with :func:`numpy.isfinite` where a gap
        must not pass.
        """
        return physics.restoring(self.model, self.theta, z, v)

    def elastic(self, z: np.ndarray) -> np.ndarray:
        """The elastic force ``K(z)`` (N), Eq. 6 (the constant term included)."""
        return physics.elastic(self.model, self.theta, z)

    def damping(self, z: np.ndarray, v: np.ndarray) -> np.ndarray:
        """The damping force ``D(z, v)`` (N), Eq. 14 / 24."""
        return physics.damping(self.model, self.theta, z, v)

    def potential(self, z: np.ndarray) -> np.ndarray:
        """The potential ``U(z) = int_0^z K`` (J), Eq. 7."""
        return physics.potential(self.model, self.theta, z)

    # ------------------------------------------------------------------ meeting data
    def residual(self, record: Record, *, cutoff: float | None = None) -> Residual:
        """The residual ``f - m a - R(z, v)`` on a record (:func:`nlid.scoring.residual`)."""
        return scoring.residual(self, record, cutoff=cutoff)

    def score(
        self,
        record: Record,
        *,
        cutoff: float | None = None,
        free_run: bool = True,
        rule: TransientRule | str | Mapping[str, Any] | None = None,
        horizon: int | None = None,
    ) -> Scores:
        """Epsilon (Eq. 26), force residual and free-run error on a record (:func:`nlid.scoring.score`).

        The same function scores models in ``nlid study``, ``nlid discover``
        and the posterior, so one model on one record gets one number.

        Parameters
        ----------
        record
            The data.
        cutoff
            Equation band (Hz) for estimated channels.
        free_run
            Also compute the free-run error.
        rule
            The free run's transient rule (:mod:`nlid.scoring.rules`): ``"first-sample"``,
            ``"window:50"``, ``"periodic"``, ``"periodic:8192"`` or a rule object; default: the record's
            (:func:`nlid.scoring.default_rule`). ``Scores.freerun_rule`` says which was applied.
        horizon
            Also compute the ``horizon``-step-ahead prediction error (:meth:`predict`).
        """
        return scoring.score(self, record, cutoff=cutoff, free_run=free_run, rule=rule, horizon=horizon)

    def predict(
        self,
        record: Record,
        horizon: int,
        *,
        rule: TransientRule | str | Mapping[str, Any] | None = None,
        partitions: int | None = None,
    ) -> Prediction:
        """The ``horizon``-step-ahead prediction of the displacement (:func:`nlid.scoring.predict`).

        Every sample from ``horizon`` on is simulated over ``horizon`` samples from the measured state before
        it; a chaotic record, whose free run means nothing, gets a finite error this way. ``partitions``
        simulates only some of the ``horizon`` interleaved sets of runs (:func:`nlid.scoring.predict`).

        Returns
        -------
        nlid.scoring.Prediction
            ``z`` (NaN where not predicted), ``rmse``, ``nrmse_percent``, ``fit_percent``, ``horizon``, ``rule``.
        """
        return scoring.predict(self, record, horizon, rule=rule, partitions=partitions)

    def simulate(
        self,
        force: np.ndarray,
        fs: float,
        *,
        x0: Sequence[float] = (0.0, 0.0),
        force_hold: str = "sampled",
        oversample: int | None = None,
    ) -> Record:
        """Free run of the model driven by a force: ``m z'' + R(z, z') = f`` (:func:`nlid.simulation.free_run`).

        Parameters
        ----------
        force
            Force samples (N).
        fs
            Their sampling frequency (Hz).
        x0
            Initial displacement (m) and velocity (m/s).
        force_hold
            ``"sampled"`` (a sampled continuous force, interpolated between
            samples) or ``"zoh"`` (held over each sample).
        oversample
            RK4 sub-steps per sample (default
            :data:`nlid.simulation.FREE_RUN_OVERSAMPLE`).

        Returns
        -------
        Record
            ``f``, ``z``, ``v``, ``a`` with the model as ``meta["reference"]``.
        """
        from ..simulation import FREE_RUN_OVERSAMPLE, free_run

        if self.mass is None:
            raise InputError("simulating needs the mass: the model has none (give mass= when identifying)")
        force = np.asarray(force, dtype=float)
        q = FREE_RUN_OVERSAMPLE if oversample is None else oversample
        acting, hold = force, force_hold
        if not self.input_path.identity:  # the force that acts: through the model's input path
            hold = self.input_path.hold or force_hold
            acting = self.input_path.acting_force(force, float(fs), hold)
        z, v, a = free_run(self.model, self.theta, self.mass, acting, fs, force_hold=hold, x0=x0, oversample=q)
        meta = {
            "mass": self.mass,
            "source": f"simulated: {self.method} model ({', '.join(self.terms)})",
            "force_hold": force_hold,
            "reference": {
                "coefficients": dict(self.coefficients),
                "mass": self.mass,
                "px_roots": None if self.px_roots is None else list(self.px_roots),
            },
        }
        return Record(f=force, z=z, v=v, a=a, fs=float(fs), meta=meta)

    # ------------------------------------------------------------------ plain data
    def _recomputed(self) -> Recomputed | None:
        if self.z_range is None or self.mass is None:
            return None
        eq = physics.equilibria(self.model, self.theta, self.z_range)
        computed = physics.modal(self.model, self.theta, self.mass, eq.stable, self.z_range)
        derived = [m for m in self.modal if not m.source]
        replacement = {"equilibria": eq, "modal": tuple(computed), "scores": None}
        return eq, [(derived, computed)], replacement, STALE_NOTE

    def to_dict(self) -> dict[str, Any]:
        """JSON-serialisable dictionary (without :attr:`arrays`); :meth:`from_dict` reverses it."""
        return model_to_dict(self)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> IdentifiedModel:
        """Rebuild a model from :meth:`to_dict` (JSON null becomes NaN in the scores).

        Raises
        ------
        InputError
            If the dictionary lacks the terms or coefficients, they do not match, or a coefficient
            is not a finite number (NaN, infinity, a string...).
        """
        return model_from_dict(cls, data)

    def to_frame(self, units: str | Mapping[str, str] | None = None) -> pd.DataFrame:
        """One row per term: ``coefficient``, ``std_error``, ``unit``, ``family`` (index: the term).

        Parameters
        ----------
        units
            ``None`` (SI, the default), ``"input"`` (the units the data were
            given in, from :attr:`provenance`) or the units to show, e.g.
            ``{"z": "mm", "f": "kN"}`` (channels ``f``, ``z``, ``v``; a
            velocity not named is the displacement's per second). Each
            coefficient is converted by its term's powers of displacement and
            velocity (:func:`nlid.data.units.coefficient_conversion`).
        """
        return coefficient_frame(self, units)

    # ------------------------------------------------------------------ text and HTML
    def summary(self, units: str | Mapping[str, str] | None = None) -> Summary:
        """The table ``nlid identify`` prints: coefficients, equilibria, modes, residuals.

        A :class:`~nlid.report.summary.Summary`: ``print()`` it (or ``str()``) for the
        text, ``.as_markdown()`` / ``.as_html()`` for the other media.

        Parameters
        ----------
        units
            ``None`` (SI, the default), ``"input"`` (the units the data were
            given in) or e.g. ``{"z": "mm", "f": "kN"}``: coefficients,
            standard errors, the ``px(z)`` roots and the equilibria are shown
            in them (as :meth:`to_frame`); the mass stays in kg.
        """
        return model_summary(self, units)

    def __repr__(self) -> str:
        mass = "mass unknown" if self.mass is None else f"mass={self.mass:.4g} {mass_unit(*record_units(self))}"
        if self.mass is not None:
            mass += " (estimated)" if self.mass_estimated else " (given)"
        eps = "" if self.eps_percent is None else f", eps={self.eps_percent:.3g} %"
        return f"<IdentifiedModel {self.method!r}: {', '.join(self.terms)}; {mass}{eps}{self._flagged()}>"

    # ------------------------------------------------------------------ figures
    def plot_stiffness(self, ax: Any = None, *, potential: bool = False) -> Any:
        """``K(z)`` (or ``U(z)``) over the data range with the equilibria marked; returns the axes."""
        return modelplots.plot_stiffness(self, ax=ax, potential=potential)

    def plot_surface(self, record: Record, ax: Any = None, *, cutoff: float | None = None) -> Any:
        """The elastic slice of the restoring surface: ``f - m a - D(z, v)`` of the data and ``K(z)``."""
        return modelplots.plot_surface(self, record, ax=ax, cutoff=cutoff)

    def plot_damping_slice(self, record: Record, z0: float, ax: Any = None, *, cutoff: float | None = None) -> Any:
        """The damping force near ``z0`` against ``v``, data and model (paper Fig. 21 b-d)."""
        return modelplots.plot_damping_slice(self, record, z0, ax=ax, cutoff=cutoff)

    def plot_residual(self, record: Record, against: str = "z", ax: Any = None, *, cutoff: float | None = None) -> Any:
        """The residual ``f - m a - R`` against ``"z"`` or ``"v"`` (binned mean drawn over the points)."""
        return modelplots.plot_residual(self, record, against=against, ax=ax, cutoff=cutoff)

    def plot_freerun(self, record: Record, *, rule: Any = None, ax: Any = None) -> Any:
        """Measured ``z`` against the free run on the record's force, the error and the transient rule (``rule=``)."""
        from .responseplots import plot_freerun

        return plot_freerun(self, record, rule=rule, ax=ax)

    def plot_frf(self, *, ax: Any = None, freq: Any = None, phase: bool = True, identified: bool = True) -> Any:
        """The receptance linearised at each stable equilibrium, and the method's own FRF (``identified=``)."""
        from .responseplots import plot_frf

        return plot_frf(self, ax=ax, freq=freq, phase=phase, identified=identified)
