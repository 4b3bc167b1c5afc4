"""The public toolkit of identifier plugins: everything a plugin needs, from one module.

A plugin (nlid's own ``rfs``, ``sindy``, ``nsi-ip``, ``nsi-shift``, or a
third party's) imports from here and nowhere else in nlid, so the core can
reorganise its modules without breaking plugins::

    from nlid.plugin import Estimate, Identifier, Option, hookimpl, regression_data

The toolkit has four axes, which identifiers compose rather than re-implement:

* **the contract**: :class:`Identifier` (settings only in the constructor,
  work in ``identify(record, model, *, mass=None)``; class attributes that
  tell the core about it: ``preference``, ``advice``, ``advice_order``,
  ``docs``, ``refines``), declared :class:`Option`\\ s, the :class:`Estimate`
  an identifier returns, the :class:`FigureArray`\\ s it declares for reports
  (:meth:`Identifier.figure_arrays`), and the :data:`hookimpl` marker of the
  ``nlid_identifiers`` hook;
* **data and terms**: :class:`Record`, :class:`Model`, :class:`Term`,
  :func:`parse_term`; for structures of several degrees of freedom (an
  identifier declaring ``dofs = "multi"``) a :class:`Record` in its indexed
  form (:attr:`Record.indexed`; :class:`StructureRecord` is its deprecated
  alias until 0.9), :class:`ElementSet`, :class:`Element`, :class:`StructuralModel`,
  :class:`StructureModes`, :func:`linear_modes` and the
  :class:`StructureEstimate` it returns;
* **the force balance and derivatives**: :func:`regression_data` (the
  filtered design matrix of Eq. 25, shared by every method) and its default
  band :func:`suggested_cutoff` (computed once per record),
  :mod:`derivatives` (the zero-phase differentiating filter), how a channel was obtained as plain data
  (:class:`ChannelSource`, reported under the diagnostics key :data:`CHANNEL_SOURCES` with
  :func:`source_entries`; ``RegressionData.sources``), the least-squares
  helpers of :mod:`nlid.estimation.regression`;
* **physics and simulation**: equilibria and modal parameters
  (:func:`equilibria`, :func:`modal`, :func:`stiffness_roots`), the simulator
  (:func:`simulate`, :func:`free_run`, and :func:`simulate_segments`: free
  runs of segments with their sensitivities, for output-error methods) and
  the scores (:func:`score`, :func:`initial_state`,
  :func:`predictability_horizon`), and :func:`kernel_threads` (the shared
  pool of :mod:`nlid.runtime.parallel`: the compiled kernels on the pool's threads, BLAS
  on one);
* **other identifiers**: :func:`identify` (the core's :func:`nlid.identify`,
  e.g. for a method that starts from another method's estimate) and
  :func:`choose_method` (the installed identifier with the best ``preference``);
* **candidate effects** for ``nlid discover``: :class:`Candidate` and its shape
  grid :class:`Shape`, what the ``nlid_candidates`` hook returns.

Errors to raise: :class:`InputError` / :class:`DataError` for what the user
gave (wrong model for the method, unusable record), :class:`IdentificationError`
when the method ran but its answer cannot be trusted.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .base.jsonable import to_jsonable
from .contract.estimate import Estimate
from .contract.hookspecs import hookimpl
from .contract.identifier import FIGURE_KINDS, FigureArray, Identifier, Option, standard_figure_arrays
from .contract.structure_estimate import StructureEstimate
from .data.record import Record
from .data.structure_record import StructureRecord
from .errors import DataError, IdentificationError, InputError, NlidError, OptionError, TermError
from .estimation.balance import EDGE_PERIODS, REGRESSOR_BAND_FACTOR, RegressionData, regression_data, suggested_cutoff
from .estimation.joint import JointSolution, joint_least_squares
from .estimation.regression import (
    collinearity_warnings,
    column_scale,
    least_squares,
    nonsmooth_warnings,
    triangular_factor,
)
from .estimation.structure_regression import (
    StructureRegressionData,
    check_elements_nonlinear,
    dof_weights,
    structure_regression_data,
)
from .estimation.structure_regression import linear_design as structure_linear_design
from .model.elements import Element, ElementSet
from .model.modes import StructureModes, linear_modes
from .model.physics import Equilibria, Modal, equilibria, modal, stiffness_roots
from .model.structure import StructuralModel
from .model.terms import Model, Term, parse_term
from .runtime.parallel import kernel_threads
from .runtime.progress import ProgressLine, progress_line
from .signal import derivatives
from .signal.channelsource import CHANNEL_SOURCES, ChannelSource, source_entries

if TYPE_CHECKING:  # loaded on first use by __getattr__ below (the simulator compiles with numba)
    from .contract.methods import choose_method
    from .discovery.library import Candidate, Shape
    from .identification.pipeline import identify
    from .scoring import initial_state, predictability_horizon, score
    from .simulation import (
        FREE_RUN_OVERSAMPLE,
        SimulationError,
        fine_force,
        free_run,
        simulate,
        simulate_segments,
    )
    from .simulation.structure import free_run as structure_free_run
    from .simulation.structure import free_run_segments as structure_free_run_segments
    from .simulation.structure_sensitivity import structure_segments

__all__ = [
    "Identifier",
    "Option",
    "Estimate",
    "FigureArray",
    "FIGURE_KINDS",
    "standard_figure_arrays",
    "hookimpl",
    "Record",
    "Model",
    "Term",
    "parse_term",
    "StructureRecord",
    "Element",
    "ElementSet",
    "StructuralModel",
    "StructureModes",
    "linear_modes",
    "StructureEstimate",
    "StructureRegressionData",
    "structure_regression_data",
    "structure_linear_design",
    "joint_least_squares",
    "JointSolution",
    "check_elements_nonlinear",
    "dof_weights",
    "structure_free_run",
    "structure_free_run_segments",
    "structure_segments",
    "regression_data",
    "RegressionData",
    "suggested_cutoff",
    "EDGE_PERIODS",
    "REGRESSOR_BAND_FACTOR",
    "derivatives",
    "ChannelSource",
    "CHANNEL_SOURCES",
    "source_entries",
    "least_squares",
    "collinearity_warnings",
    "nonsmooth_warnings",
    "column_scale",
    "triangular_factor",
    "equilibria",
    "modal",
    "stiffness_roots",
    "Equilibria",
    "Modal",
    "simulate",
    "free_run",
    "simulate_segments",
    "fine_force",
    "FREE_RUN_OVERSAMPLE",
    "SimulationError",
    "score",
    "initial_state",
    "predictability_horizon",
    "kernel_threads",
    "identify",
    "choose_method",
    "Candidate",
    "Shape",
    "to_jsonable",
    "progress_line",
    "ProgressLine",
    "NlidError",
    "InputError",
    "DataError",
    "OptionError",
    "TermError",
    "IdentificationError",
]


def __getattr__(name: str):  # the simulator (numba) and the scores are loaded only when a plugin uses them
    if name in ("Candidate", "Shape"):  # what a candidate plugin returns from nlid_candidates (nlid discover)
        from .discovery import library

        return getattr(library, name)
    if name in ("simulate", "free_run", "simulate_segments", "fine_force", "FREE_RUN_OVERSAMPLE", "SimulationError"):
        from . import simulation

        return getattr(simulation, name)
    if name in ("score", "initial_state", "predictability_horizon"):
        from . import scoring

        return getattr(scoring, name)
    if name in ("structure_free_run", "structure_free_run_segments"):
        from .simulation import structure as structure_simulation

        if name == "structure_free_run":
            return structure_simulation.free_run
        return structure_simulation.free_run_segments
    if name == "structure_segments":
        from .simulation.structure_sensitivity import structure_segments

        return structure_segments
    if name == "identify":
        from .identification.pipeline import identify

        return identify
    if name == "choose_method":
        from .contract.methods import choose_method

        return choose_method
    raise AttributeError(f"module 'nlid.plugin' has no attribute {name!r}")
