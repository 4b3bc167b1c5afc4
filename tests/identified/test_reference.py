"""The Reference (one object whatever it came from) and the Comparison of a fit against it (two views)."""

from __future__ import annotations

import math
import pickle

import numpy as np
import pandas as pd
import pytest

import nlid
from nlid import IdentifiedModel, Model
from nlid.data.io import read_record, write_npz
from nlid.data.record import Record
from nlid.errors import InputError
from nlid.identified.reference import FRAME_COLUMNS, Comparison, Reference, compare
from nlid.model import physics
from nlid.model.physics import Equilibria
from nlid.study import columns as col
from nlid.study.metrics import coefficient_metrics, comparison_columns, equilibrium_metrics

TERMS = "z^3, z^2, v*|v|"


@pytest.fixture(scope="module")
def record():
    return nlid.simulate("paper-numerical", seed=2, noise=0.02, channels="z,a", duration=8)


@pytest.fixture(scope="module")
def fit(record):
    return nlid.identify(record, TERMS, "rfs", mass=0.2)


# ----------------------------------------------------------------------------- building a reference
def test_a_mapping_bare_or_structured_with_canonical_names():
    bare = Reference.from_mapping({"z*z*z": 1e6, "v*abs(v)": 5})
    assert dict(bare.coefficients) == {"z^3": 1e6, "v*|v|": 5.0} and bare.mass is None
    full = Reference.from_mapping({"coefficients": {"z^3": 1e6}, "mass": 0.2, "equilibria": [-0.02, 0.01], "g": 9.81})
    assert full.mass == 0.2 and full.equilibria == (-0.02, 0.01) and full.modes is None
    # the plain-data name of the modes is "modal" (study configs, stored runs); "modes" reads too
    assert Reference.from_mapping({"modal": [{"fn_hz": 1.0, "zeta": 0.1}]}).modes[0]["fn_hz"] == 1.0
    assert Reference.from_mapping({"modes": [{"fn_hz": 2.0, "zeta": 0.1}]}).modes[0]["fn_hz"] == 2.0
    # a name that is no term is dropped (a benchmark's published score beside its coefficients)
    assert dict(Reference.from_mapping({"coefficients": {"z": 1.0, "not a term (": 2.0}}).coefficients) == {"z": 1.0}
    with pytest.raises(TypeError):
        full.coefficients["z"] = 0.0  # type: ignore[index]


@pytest.mark.parametrize(
    ("mapping", "message"),
    [
        ({"coefficients": 5}, "must map term names"),
        ({"coefficients": {"z": "x"}}, "must be a number"),
        ({"mass": "heavy"}, "number of kg"),
        ({"equilibria": ["a"]}, "list of numbers"),
        ({"modal": {"fn_hz": 1}}, "list of"),
    ],
)
def test_a_bad_mapping_is_an_input_error(mapping, message):
    with pytest.raises(InputError, match=message):
        Reference.from_mapping(mapping)


def test_of_dispatches_on_what_it_is_given(record, fit):
    assert Reference.of(record) == Reference.from_meta(record.meta)
    assert Reference.of(record).coefficients["z^3"] == 1e6 and Reference.of(record).mass == 0.2
    assert Reference.of(record, fit) == Reference.from_fit(fit)
    assert Reference.of(record, {"z^3": 1.0}).coefficients == {"z^3": 1.0}
    ref = Reference(mass=1.0)
    assert Reference.of(record, ref) is ref
    assert Reference.of(None).empty
    with pytest.raises(InputError, match="reference must be a dict, a Reference, an IdentifiedModel or None, got int"):
        Reference.of(record, 3)


def test_from_fit_takes_its_equilibria_modes_and_model(fit):
    ref = Reference.from_fit(fit)
    assert ref.equilibria == fit.equilibria.stable and ref.terms == fit.terms
    assert [m["fn_hz"] for m in ref.modes] == [m.fn_hz for m in fit.modal]


def test_from_truth_solves_the_true_model(record, numerical):
    z_range = (float(record.z.min()), float(record.z.max()))
    ref = Reference.from_truth(Reference.from_meta(record.meta), model=numerical.model(), z_range=z_range)
    model = numerical.model()
    truth = numerical.truth()
    assert ref.equilibria == physics.equilibria(model, truth["coefficients"], z_range).stable
    assert len(ref.equilibria) == 2 and ref.terms == model.names
    modal = physics.modal(model, truth["coefficients"], 0.2, z_range=z_range)
    assert [dict(m) for m in ref.modes] == [{"fn_hz": m.fn_hz, "zeta": m.zeta} for m in modal]
    # without the model, it is built from the coefficients' terms: the same numbers
    assert Reference.from_truth(truth, z_range=z_range) == ref
    assert ref.to_dict() == {
        "coefficients": dict(truth["coefficients"]),
        "mass": 0.2,
        "equilibria": list(ref.equilibria),
        "modal": [dict(m) for m in ref.modes],
        "terms": list(model.names),
        "px_roots": None,
    }
    with pytest.raises(InputError, match="needs its coefficients and mass"):
        Reference.from_truth({"coefficients": {"z": 1.0}})


def test_updated_replaces_the_entries_given():
    ref = Reference(coefficients={"z": 1.0}, mass=2.0)
    new = ref.updated({"mass": 3.0, "equilibria": [0.0]})
    assert new.mass == 3.0 and new.equilibria == (0.0,) and new.coefficients == {"z": 1.0}


# ----------------------------------------------------------------------------- the record's one name for it
def test_the_reference_is_meta_reference_and_truth_still_reads(record):
    assert "reference" in record.meta and "truth" not in record.meta
    assert record.meta["truth"] is record.meta["reference"] and record.meta.get("truth") is record.meta["reference"]
    assert record.meta.get("no such key", 5) == 5
    with pytest.raises(KeyError):
        record.meta["no such key"]
    # a record made with the earlier name carries it under the current one
    old = Record(f=record.f, z=record.z, fs=record.fs, meta={"truth": {"coefficients": {"z": 1.0}}})
    assert list(old.meta) == ["reference"] and old.meta["truth"]["coefficients"] == {"z": 1.0}
    assert Reference.from_meta({"truth": {"mass": 1.5}}).mass == 1.5  # a plain mapping with the old name
    assert pickle.loads(pickle.dumps(record)).meta["truth"] == record.meta["reference"]


def test_the_reference_survives_a_file(record, tmp_path):
    path = tmp_path / "sim.npz"
    write_npz(record, path)
    back = read_record(path)
    assert back.meta["reference"]["coefficients"]["v*|v|"] == 5.0
    assert Reference.of(back) == Reference.of(record)


# ----------------------------------------------------------------------------- the two views
def test_compare_frame_is_the_api_frame(record, fit):
    frame = nlid.compare(record, TERMS, ["rfs"], mass=0.2)
    own = compare(fit, Reference.of(record)).to_frame()
    assert list(own.columns) == FRAME_COLUMNS
    # nlid.compare adds the record's force-hold assumption to every row (issue 35)
    assert list(frame.columns) == [*FRAME_COLUMNS, "force_hold", "force_hold_source"]
    assert set(frame["force_hold_source"]) == {"simulation"}
    frame = frame[FRAME_COLUMNS]
    keep = frame["quantity"] != "seconds"
    pd.testing.assert_frame_equal(
        frame[keep].reset_index(drop=True), own[own["quantity"] != "seconds"].reset_index(drop=True)
    )
    eq = own[own["quantity"] == "equilibrium"]
    assert list(eq["name"]) == ["s1", "s2"] and eq["error_pct"].abs().max() < 5


def test_compare_row_uses_the_declared_columns(fit, record, numerical):
    z_range = (float(record.z.min()), float(record.z.max()))
    ref = Reference.from_truth(Reference.of(record), model=numerical.model(), z_range=z_range)
    row = comparison_columns(compare(fit, ref))
    assert row[col.COEF.key("z^3")] == fit.coefficients["z^3"]
    assert row[col.COEF_ERROR.key("z^3")] == pytest.approx(100 * (fit.coefficients["z^3"] - 1e6) / 1e6)
    assert col.MASS_ERROR.key() not in row  # the mass was given
    assert row[col.EQ_EXPECTED.key()] == 2 and row[col.EQ_MISSING.key()] == 0
    assert all(col.declared(k) for k in row)
    # the study's metrics are the two halves of the row
    assert {**coefficient_metrics(fit, ref), **equilibrium_metrics(fit, ref)} == row


def test_the_two_views_pair_modes_differently_on_purpose():
    # nsi-shift reports each well's modes at its own reference point, a hair away from the
    # combined model's equilibrium: the row matches modes to the reference equilibria by position
    # (so both are scored); the frame reports, at each identified equilibrium, the mode nearest to it
    fit = IdentifiedModel(
        model=Model.from_spec("z^3", without="v"),
        coefficients={"1": 1.962, "z": -500.0, "z^3": 1e6},
        mass=0.2,
        method="m",
        equilibria=Equilibria(stable=(-0.0266, 0.0173), unstable=(0.0043,)),
        modal=[
            {"equilibrium": 0.01731, "fn_hz": 8.6, "zeta": 0.05},
            {"equilibrium": -0.02657, "fn_hz": 13.0, "zeta": 0.03},
        ],
    )
    ref = Reference(
        equilibria=(-0.0266, 0.0173), modes=({"fn_hz": 13.1, "zeta": 0.0304}, {"fn_hz": 8.52, "zeta": 0.0467})
    )
    comparison = compare(fit, ref)
    assert isinstance(comparison, Comparison)
    row = comparison_columns(comparison)
    wells = comparison.equilibria().wells  # the typed values the row is flattened from
    assert [w.mode.fn_hz for w in wells] == [13.0, 8.6] and comparison.equilibria().missing == 0
    assert row[col.FN.key("s1")] == 13.0 and row[col.FN.key("s2")] == 8.6
    assert row[col.FN_ERROR.key("s1")] == pytest.approx(100 * (13.0 - 13.1) / 13.1)
    frame = comparison.to_frame().set_index(["quantity", "name"])
    assert frame.loc[("fn_hz", "s1"), "value"] == 13.0 and frame.loc[("fn_hz", "s2"), "value"] == 8.6
    assert frame.loc[("equilibrium", "s2"), "reference"] == 0.0173


def test_the_frame_solves_a_reference_without_equilibria(fit):
    coefficients = {"1": 1.962, "z": -500.0, "z^2": 5e3, "z^3": 1e6, "v": 1.0, "v*|v|": 5.0}
    solved = Reference(coefficients=coefficients, mass=0.2).solved(fit.z_range)
    assert len(solved.equilibria) == 2 and len(solved.modes) == 2
    frame = compare(fit, {"coefficients": coefficients, "mass": 0.2}).to_frame()
    fn = frame[frame["quantity"] == "fn_hz"]
    assert list(fn["reference"]) == [m["fn_hz"] for m in solved.modes]
    # the row scores only what the reference gives: no equilibria, no equilibrium columns
    row = comparison_columns(compare(fit, {"coefficients": coefficients}))
    assert col.EQ_EXPECTED.key() not in row and row[col.FN.key("s1")] == fit.modal[0].fn_hz


def test_unknown_reference_gives_values_without_errors(fit):
    frame = compare(fit, None).to_frame()
    assert frame["reference"].isna().all() and frame["error_pct"].isna().all()
    row = comparison_columns(compare(fit, None))
    assert not any(col.COEF_ERROR.matches(k) for k in row) and not math.isnan(row[col.MASS.key()])
    with pytest.raises(InputError, match="needs an IdentifiedModel"):
        compare({"z": 1.0}, None)  # type: ignore[arg-type]
    assert np.isfinite(frame[frame["quantity"] == "coefficient"]["value"]).all()
