"""The columns of a study row, each family declared once: key, label kind, unit, error kind, title, digits, table.

A study row (one run: :func:`nlid.study.worker.execute_run`) is a flat
``{column: value}`` mapping. Its columns come in *families*: a scalar
column (``mass``, ``eps_holdout_percent``) or one column per term
(``coef_error_pct:<term>``), per matched stable equilibrium
(``fn_hz:s1``) and so on. Each family is one :class:`ColumnFamily`
below; producers build keys through it (``COEF_ERROR.key("z^3")``) and
consumers read through it (``COEF_ERROR.labels(frame.columns)``,
``COEF_ERROR.header("z^3")``), so that no module spells a column key.
Adding a study column is one declaration here plus its producer: a scalar
family with a :attr:`ColumnFamily.section` is shown in that table of the
study summary without further code.

The study owns its row: the core returns typed values (a comparison's
:class:`~nlid.identified.compared.CoefficientComparison` and
:class:`~nlid.identified.compared.EquilibriumComparison`, the posterior's
:class:`~nlid.bayes.PosteriorMetrics`, the :class:`~nlid.scoring.Scores`) and
:mod:`nlid.study.metrics` flattens them into these columns; no package below
the study knows a column key. Equilibria are labelled as the core labels them
(:func:`nlid.identified.compared.equilibrium_label`: ``s1``, ``s2``...).

Errors are relative, in percent of ``|reference|``: ``"signed"``
(``100 (x - x_ref) / |x_ref|``) or ``"absolute"`` (its magnitude, as the
paper's Table 7 gives the equilibria); the summary tables show every error
as its magnitude.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

__all__ = [
    "ColumnFamily",
    "SliceArrays",
    "FAMILIES",
    "SLICES",
    "SECTION_RESIDUALS",
    "SECTION_RESPONSE",
    "COST_DIGITS",
    "declared",
    "family_of",
    "section_families",
    "label_order",
    "RUN_ID",
    "DATASET",
    "MODEL",
    "METHOD",
    "REPETITION",
    "SEED",
    "STATUS",
    "ERROR",
    "WARNINGS",
    "SAMPLES",
    "Z_MIN",
    "Z_MAX",
    "METHOD_SECONDS",
    "EPS",
    "FORCE_RESIDUAL",
    "EPS_HOLDOUT",
    "FREERUN_NRMSE",
    "FREERUN_FIT",
    "FREERUN_RMSE",
    "FREERUN_NOTE",
    "FREERUN_RULE",
    "FREERUN_SCORED",
    "SECONDS",
    "PEAK_MEMORY",
    "COEF",
    "COEF_ERROR",
    "MASS",
    "MASS_ERROR",
    "EQ_FOUND",
    "EQ_EXPECTED",
    "EQ_MISSING",
    "EQ",
    "EQ_ERROR",
    "EQ_ERROR_MAX",
    "FN",
    "FN_ERROR",
    "ZETA",
    "ZETA_ERROR",
    "RMS",
    "QUALITY",
    "CI_LO",
    "CI_HI",
    "CI_WIDTH",
    "CI_COVERS",
    "POSTERIOR_LEVEL",
    "POSTERIOR_TAU",
    "POSTERIOR_SECONDS",
    "POSTERIOR_BIAS_SHIFT",
    "RESPONSE_PEAK_HZ",
    "RESPONSE_PEAK_M",
    "RESPONSE_PEAK_HZ_ERROR",
    "RESPONSE_PEAK_M_ERROR",
    "RESPONSE_FOLDS",
    "RESPONSE_SECONDS",
    "LINEAR_FN",
    "LINEAR_FN_ERROR",
    "LINEAR_ZETA",
    "LINEAR_ZETA_ERROR",
    "LINEAR_FN_ERROR_MAX",
    "LINEAR_ZETA_ERROR_MAX",
    "WELL_FN_ERROR",
    "WELL_ZETA_ERROR",
]

#: What a family's label is: none (one scalar column), a term, a matched stable equilibrium (``s1``...).
PER = ("run", "term", "equilibrium")
#: How an error column is stored.
ERRORS = ("", "signed", "absolute")
#: Significant digits of time and memory (machine measurements: their spread is the machine's load).
COST_DIGITS = 3
#: The summary table "Residuals (eps: Eq. 26), simulation error and cost".
SECTION_RESIDUALS = "residuals"
#: The summary table of a study's ``[response]``: each fit's frequency response against the reference's.
SECTION_RESPONSE = "response"


@dataclass(frozen=True)
class ColumnFamily:
    """One declared family of study-row columns.

    Attributes
    ----------
    name
        The key of a scalar column, or the part before ``":"`` of a labelled one.
    per
        ``"run"`` (one scalar column), ``"term"`` (``<name>:<term>``) or
        ``"equilibrium"`` (``<name>:sK``, the K-th reference stable equilibrium).
    unit
        SI unit of the values (``"%"`` for percentages, ``"1"`` dimensionless,
        ``""`` for text, flags and counts); ``"coefficient"``: the unit of the
        term's coefficient (given by the caller).
    error
        ``""`` (a value), ``"signed"`` or ``"absolute"`` relative error in %.
    title
        Short name, ``{label}`` standing for the term or equilibrium
        (``"fn {label}"``); figure ticks and table headers are made of it.
    digits
        Fixed significant digits in tables (``None``: chosen from the spread).
    section
        The summary table a scalar family is shown in (``""``: recorded only,
        or shown by a table built for its family).
    lower_better
        True when a lower value is better (the best cell is marked).
    always
        Shown in its section's table even when no run has a value.
    aggregate
        For a family that aggregates another one (``eq_error_max_pct``: ``"largest"``).
    """

    name: str
    per: str = "run"
    unit: str = ""
    error: str = ""
    title: str = ""
    digits: int | None = None
    section: str = ""
    lower_better: bool = False
    always: bool = False
    aggregate: str = ""

    def __post_init__(self) -> None:
        if self.per not in PER:
            raise ValueError(f"column family {self.name!r}: per must be one of {PER}, got {self.per!r}")
        if self.error not in ERRORS:
            raise ValueError(f"column family {self.name!r}: error must be one of {ERRORS}, got {self.error!r}")

    @property
    def labelled(self) -> bool:
        """True for a family of one column per term or per equilibrium."""
        return self.per != "run"

    def key(self, label: str | None = None) -> str:
        """The row key: ``name`` (scalar) or ``name:label``."""
        if self.labelled:
            if not label:
                raise ValueError(f"column family {self.name!r} needs a {self.per} label")
            return f"{self.name}:{label}"
        if label:
            raise ValueError(f"column {self.name!r} takes no label")
        return self.name

    def label_of(self, key: str) -> str | None:
        """The label of ``key`` when it belongs to this family (``""`` for the scalar column), else ``None``."""
        if not self.labelled:
            return "" if key == self.name else None
        prefix = f"{self.name}:"
        return key[len(prefix) :] if key.startswith(prefix) and len(key) > len(prefix) else None

    def matches(self, key: str) -> bool:
        """True when ``key`` is a column of this family."""
        return self.label_of(key) is not None

    def labels(self, columns: Iterable[str]) -> list[str]:
        """The labels of this family's columns among ``columns``, in their order."""
        return [label for c in columns if (label := self.label_of(str(c)))]

    def short(self, label: str | None = None) -> str:
        """The title with the label put in (figure ticks)."""
        return (self.title or self.name).format(label=label or "")

    def header(self, label: str | None = None, unit: str | None = None) -> str:
        """Table header: the title and the unit (``"fn s1 (Hz)"``, ``"zeta s1"``; errors: ``"(%)"``).

        ``unit`` overrides the declared unit (a term's coefficient unit), and is then always shown.
        """
        if unit is not None:
            return f"{self.short(label)} ({unit})"
        shown = "%" if self.error else self.unit
        return self.short(label) if shown in ("", "1") else f"{self.short(label)} ({shown})"

    def verdict_title(self, label: str | None = None) -> str:
        """The verdict's name of the metric: ``"fn s1 (|error| %)"`` for errors, else the header."""
        if not self.error:
            return self.header(label)
        return f"{self.short(label)} ({self.aggregate + ' ' if self.aggregate else ''}|error| %)"


def _scalar(name: str, **kwargs: object) -> ColumnFamily:
    return ColumnFamily(name, "run", **kwargs)  # type: ignore[arg-type]


# ----------------------------------------------------------------------------- the run (worker)
RUN_ID = _scalar("run_id")
DATASET = _scalar("dataset")
MODEL = _scalar("model")
METHOD = _scalar("method")
REPETITION = _scalar("repetition")
SEED = _scalar("seed")
STATUS = _scalar("status")
ERROR = _scalar("error")
WARNINGS = _scalar("warnings")
SAMPLES = _scalar("samples", title="samples")
Z_MIN = _scalar("z_min", unit="m")
Z_MAX = _scalar("z_max", unit="m")
METHOD_SECONDS = _scalar("method_seconds", unit="s", title="method time")

# ----------------------------------------------------------------------------- residuals, free run, cost
EPS = _scalar("eps_percent", unit="%", title="eps", section=SECTION_RESIDUALS, lower_better=True, always=True)
FORCE_RESIDUAL = _scalar("force_residual_percent", unit="%", title="force residual")
EPS_HOLDOUT = _scalar(
    "eps_holdout_percent", unit="%", title="eps held-out", section=SECTION_RESIDUALS, lower_better=True
)
FREERUN_NRMSE = _scalar(
    "freerun_nrmse_pct", unit="%", title="free-run NRMSE", section=SECTION_RESIDUALS, lower_better=True
)
#: MATLAB ``compare``'s fit of the held-out free run, ``100 (1 - |z - z_sim| / |z - mean(z)|)`` (higher is better).
FREERUN_FIT = _scalar("freerun_fit_pct", unit="%", title="free-run fit", section=SECTION_RESIDUALS)
FREERUN_RMSE = _scalar("freerun_rmse", unit="m", title="free-run RMSE")
FREERUN_NOTE = _scalar("freerun_note")
#: The transient rule the held-out free run was scored under, as applied (:attr:`nlid.scoring.Scores.freerun_rule`).
FREERUN_RULE = _scalar("freerun_rule")
#: Samples the held-out free run is scored over (an initialisation window is not).
FREERUN_SCORED = _scalar("freerun_scored_samples", title="free-run samples scored")
SECONDS = _scalar(
    "seconds", unit="s", title="time", digits=COST_DIGITS, section=SECTION_RESIDUALS, lower_better=True, always=True
)
PEAK_MEMORY = _scalar(
    "peak_memory_mb",
    unit="MB",
    title="memory",
    digits=COST_DIGITS,
    section=SECTION_RESIDUALS,
    lower_better=True,
    always=True,
)

# ----------------------------------------------------------------------------- coefficients and mass
COEF = ColumnFamily("coef", "term", unit="coefficient", title="{label}")
COEF_ERROR = ColumnFamily("coef_error_pct", "term", error="signed", title="{label}", lower_better=True)
MASS = _scalar("mass", unit="kg", title="mass")
MASS_ERROR = _scalar("mass_error_pct", error="signed", title="mass", lower_better=True)

# ----------------------------------------------------------------------------- equilibria and modes
EQ_FOUND = _scalar("eq_found", title="wells found")
EQ_EXPECTED = _scalar("eq_expected", title="wells expected")
EQ_MISSING = _scalar("eq_missing", title="wells missing")
EQ = ColumnFamily("eq", "equilibrium", unit="m", title="z* {label}")
EQ_ERROR = ColumnFamily("eq_error_pct", "equilibrium", error="absolute", title="z* {label}", lower_better=True)
EQ_ERROR_MAX = _scalar("eq_error_max_pct", error="absolute", title="equilibria", lower_better=True, aggregate="largest")
FN = ColumnFamily("fn_hz", "equilibrium", unit="Hz", title="fn {label}")
FN_ERROR = ColumnFamily("fn_error_pct", "equilibrium", error="signed", title="fn {label}", lower_better=True)
ZETA = ColumnFamily("zeta", "equilibrium", unit="1", title="zeta {label}")
ZETA_ERROR = ColumnFamily("zeta_error_pct", "equilibrium", error="signed", title="zeta {label}", lower_better=True)

# ----------------------------------------------------------------------------- the identified surface
RMS = ColumnFamily("rms", "term", unit="N", title="{label}")
QUALITY = ColumnFamily("quality", "term", unit="1", title="{label}")

# ----------------------------------------------------------------------------- the posterior (nlid.bayes)
CI_LO = ColumnFamily("ci_lo", "term", unit="coefficient", title="{label}")
CI_HI = ColumnFamily("ci_hi", "term", unit="coefficient", title="{label}")
CI_WIDTH = ColumnFamily("ci_width", "term", unit="coefficient", title="{label}")
CI_COVERS = ColumnFamily("ci_covers", "term", title="{label}")
POSTERIOR_LEVEL = _scalar("posterior:level", unit="1", title="credible level")
POSTERIOR_TAU = _scalar("posterior:tau", unit="steps", title="tau")
POSTERIOR_SECONDS = _scalar("posterior:seconds", unit="s", title="time")
POSTERIOR_BIAS_SHIFT = _scalar("posterior:max_bias_shift_sd", unit="sd", title="largest bias shift")

# ----------------------------------------------------------------------------- the frequency response ([response])
# at the largest force amplitude: the resonance peak of the forced DOF's first harmonic over the stable points; the
# errors are the largest over the force amplitudes, against the reference's true model (nlid.study.metrics)
RESPONSE_PEAK_HZ = _scalar("response:peak_hz", unit="Hz", title="peak f", section=SECTION_RESPONSE)
RESPONSE_PEAK_M = _scalar("response:peak_m", unit="m", title="peak amplitude", section=SECTION_RESPONSE)
RESPONSE_PEAK_HZ_ERROR = _scalar(
    "response:peak_hz_error_pct",
    error="absolute",
    title="peak f error",
    section=SECTION_RESPONSE,
    lower_better=True,
    aggregate="largest",
)
RESPONSE_PEAK_M_ERROR = _scalar(
    "response:peak_m_error_pct",
    error="absolute",
    title="peak amplitude error",
    section=SECTION_RESPONSE,
    lower_better=True,
    aggregate="largest",
)
RESPONSE_FOLDS = _scalar("response:folds", title="turning points", section=SECTION_RESPONSE)
RESPONSE_SECONDS = _scalar(
    "response:seconds", unit="s", title="response time", digits=COST_DIGITS, section=SECTION_RESPONSE
)

# structures of several DOFs (nlid.study.structures): the elements use COEF / COEF_ERROR, the wells EQ_ERROR;
# the modes are labelled mK (the K-th mode by frequency) and sJ.mK (mode K linearised at well sJ)
LINEAR_FN = ColumnFamily("linear_fn_hz", "term", unit="Hz", title="linear fn {label}")
LINEAR_FN_ERROR = ColumnFamily(
    "linear_fn_error_pct", "term", error="signed", title="linear fn {label}", lower_better=True
)
LINEAR_ZETA = ColumnFamily("linear_zeta", "term", unit="1", title="linear zeta {label}")
LINEAR_ZETA_ERROR = ColumnFamily(
    "linear_zeta_error_pct", "term", error="signed", title="linear zeta {label}", lower_better=True
)
LINEAR_FN_ERROR_MAX = _scalar(
    "linear_fn_error_max_pct", error="absolute", title="linear fn", lower_better=True, aggregate="largest"
)
LINEAR_ZETA_ERROR_MAX = _scalar(
    "linear_zeta_error_max_pct", error="absolute", title="linear zeta", lower_better=True, aggregate="largest"
)
WELL_FN_ERROR = ColumnFamily("well_fn_error_pct", "term", error="signed", title="fn {label}", lower_better=True)
WELL_ZETA_ERROR = ColumnFamily("well_zeta_error_pct", "term", error="signed", title="zeta {label}", lower_better=True)

#: Every declared family, in the order of a row.
FAMILIES: tuple[ColumnFamily, ...] = tuple(v for v in list(globals().values()) if isinstance(v, ColumnFamily))


def family_of(key: str) -> ColumnFamily | None:
    """The declared family of a row key (``None`` for an undeclared column)."""
    return next((f for f in FAMILIES if f.matches(str(key))), None)


def declared(key: str) -> bool:
    """True for a column of a declared family."""
    return family_of(key) is not None


def section_families(section: str) -> list[ColumnFamily]:
    """The scalar families shown in one summary table, in declaration order."""
    return [f for f in FAMILIES if f.section == section]


def label_order(label: str) -> int:
    """Sort key of an equilibrium label (``s10`` after ``s9``)."""
    return int(label[1:])


@dataclass(frozen=True)
class SliceArrays:
    """The arrays of the damping-force slices a study run stores (paper Fig. 21 b-d), per slice ``k``.

    ``z0`` the position, ``v`` and ``measured`` the measured damping force near it against velocity,
    ``v_grid`` and ``model`` the identified ``D(z0, v)``.
    """

    parts: tuple[str, ...] = ("z0", "v", "measured", "v_grid", "model")

    def key(self, k: int, part: str) -> str:
        """The array key of one part of slice ``k``."""
        if part not in self.parts:
            raise ValueError(f"slice arrays have no part {part!r}; parts: {', '.join(self.parts)}")
        return f"slice{k}:{part}"

    def count(self, arrays: Iterable[str]) -> int:
        """How many consecutive slices (from 0) ``arrays`` holds."""
        keys = set(arrays)
        k = 0
        while self.key(k, "z0") in keys:
            k += 1
        return k


#: The slice arrays' keys.
SLICES = SliceArrays()
