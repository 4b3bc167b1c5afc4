"""Units are declared, converted to SI on the way in, kept in the provenance, and never ignored (issue 23, item 1).

A record in mm, µm, g, kN, ms... gives the coefficients its SI twin gives (every unit of the vocabulary is
tried); a unit outside the vocabulary is one line naming the channel, the unit and the units accepted (exit
status 2 on the command line); coefficients can be shown in the units of the data.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

import nlid
from nlid import InputError, Record
from nlid.data.columnmap import column_units, parse_columns
from nlid.data.units import STANDARD_GRAVITY, VOCABULARY, coefficient_conversion, display_units, unit_of
from nlid.model.terms import parse_term

TERMS = "z^3, z^2, v*|v|"
REL = 1e-9  # the conversion and its inverse round at the last bits; the fit is linear in the data


@pytest.fixture(scope="module")
def si():
    """A noisy simulated record with every channel measured, in SI, and its fit."""
    simulated = nlid.simulate("paper-numerical", seed=1, channels="z,v,a", duration=4.0, noise=0.01)
    record = Record.from_time(simulated.t, simulated.f, simulated.z, v=simulated.v, a=simulated.a)
    return record, nlid.identify(record, TERMS, "rfs", mass=0.2)


def _every_unit():
    return [pytest.param(c, u.symbol, id=f"{c}[{u.symbol}]") for c, units in VOCABULARY.items() for u in units]


def _in_unit(record: Record, channel: str, symbol: str) -> Record:
    """``record`` with ``channel`` written in ``symbol`` and declared so."""
    factor = unit_of(channel, symbol).factor
    arrays = {c: getattr(record, c) for c in record.channels}
    if channel == "t":
        return Record.from_time(record.t / factor, units={"t": symbol}, **arrays)
    arrays[channel] = arrays[channel] / factor
    return Record.from_time(record.t, units={channel: symbol}, **arrays)


@pytest.mark.parametrize("channel, symbol", _every_unit())
def test_a_record_in_any_unit_of_the_vocabulary_gives_the_si_coefficients(si, channel, symbol):
    record, fit = si
    converted = _in_unit(record, channel, symbol)
    unit = unit_of(channel, symbol)
    assert converted.fs == pytest.approx(record.fs, rel=REL) and converted.t0 == pytest.approx(record.t0, abs=1e-12)
    for c in record.channels:
        np.testing.assert_allclose(getattr(converted, c), getattr(record, c), rtol=1e-12, atol=0)
    assert converted.units[channel] == unit.si
    if unit.is_si:
        assert "input_units" not in converted.meta
    else:
        assert converted.meta["input_units"] == {channel: {"unit": symbol, "si": unit.si, "factor": unit.factor}}
    again = nlid.identify(converted, TERMS, "rfs", mass=0.2)
    for term, value in fit.coefficients.items():
        assert again.coefficients[term] == pytest.approx(value, rel=REL), term


def test_the_issue_example_constant_term_is_right_in_mm():
    """``units={"z": "mm"}`` was accepted and ignored: the constant term came out 1962.75 N for 1.96 N."""
    simulated = nlid.simulate("paper-numerical", seed=0, channels="z,a", duration=4.0)
    in_mm = Record.from_time(simulated.t, simulated.f, 1000 * simulated.z, a=simulated.a, units={"z": "mm"})
    fit = nlid.identify(in_mm, TERMS, "rfs", mass=0.2)
    truth = simulated.meta["reference"]["coefficients"]
    assert fit.coefficient("1") == pytest.approx(truth["1"], rel=1e-3)
    assert fit.coefficient("z^3") == pytest.approx(truth["z^3"], rel=1e-3)


@pytest.mark.parametrize(
    "channel, spelling, symbol",
    [
        ("z", "um", "µm"),
        ("z", "μm", "µm"),  # the Greek mu
        ("z", "micron", "µm"),
        ("z", " mm ", "mm"),
        ("v", "um/s", "µm/s"),
        ("a", "m/s²", "m/s^2"),
        ("a", "m/s**2", "m/s^2"),
        ("a", "mm/s2", "mm/s^2"),
        ("a", "m / s^2", "m/s^2"),
        ("t", "us", "µs"),
    ],
)
def test_spellings_of_one_unit(channel, spelling, symbol):
    assert unit_of(channel, spelling) is unit_of(channel, symbol)


def test_g_is_standard_gravity_not_the_local_one():
    assert unit_of("a", "g").factor == STANDARD_GRAVITY == 9.80665
    record = nlid.simulate("paper-numerical", seed=0, channels="z,a", duration=1.0)
    in_g = Record(record.f, record.z, record.fs, a=record.a / 9.80665, units={"a": "g"}, meta={"g": 9.81})
    np.testing.assert_allclose(in_g.a, record.a, rtol=1e-13)
    assert in_g.meta["g"] == 9.81  # the model's own g is untouched


@pytest.mark.parametrize(
    "units, says",
    [
        (
            {"z": "furlong"},
            "unknown unit 'furlong' for channel 'z'; the displacement z accepts m, cm, mm, µm (or um), V",
        ),
        ({"z": "mmm"}, "(did you mean 'mm'?)"),
        ({"f": "kn"}, "(did you mean 'kN'?)"),
        ({"a": "G"}, "(did you mean 'g'?)"),
        ({"z": "N"}, "'N' is a unit of force, channel 'f'"),
        ({"x": "m"}, "unknown channel 'x'; channels are t, f, z, v, a"),
        ({"z": 0.001}, "the unit of 'z' must be a string"),
        ("z=mm,z=m", "channel 'z' is given twice"),
    ],
)
def test_a_unit_outside_the_vocabulary_is_refused_in_one_line(units, says):
    record = nlid.simulate("paper-numerical", seed=0, channels="z", duration=1.0)
    with pytest.raises(InputError) as caught:
        Record(record.f, record.z, record.fs, units=units)
    message = str(caught.value)
    assert says in message and "\n" not in message


def test_every_entry_point_refuses_an_unknown_unit(tmp_path):
    t = np.arange(200) / 100.0
    frame = pd.DataFrame({"t": t, "f": np.sin(3 * t), "z": np.cos(2 * t)})
    path = tmp_path / "rig.csv"
    frame.to_csv(path, index=False)
    calls = [
        lambda: Record.from_time(t, frame.f, frame.z, units={"z": "inch"}),
        lambda: Record.from_frame(frame, units={"z": "inch"}),
        lambda: nlid.load(frame, units={"z": "inch"}),
        lambda: nlid.load(path, units="z=inch"),
        lambda: nlid.load(path, columns="t=t,f=f,z[inch]=z"),
        lambda: nlid.load({"t": t, "f": frame.f.to_numpy(), "z": frame.z.to_numpy()}, units={"z": "inch"}),
        lambda: parse_columns("z[inch]=z"),
    ]
    for call in calls:
        with pytest.raises(InputError, match="unknown unit 'inch' for channel 'z'"):
            call()


def test_a_time_unit_needs_a_time_vector():
    record = nlid.simulate("paper-numerical", seed=0, channels="z", duration=1.0)
    with pytest.raises(InputError, match="applies to a time vector.*fs= is always in Hz"):
        Record(record.f, record.z, record.fs, units={"t": "ms"})
    in_ms = Record.from_time(1000 * record.t, record.f, record.z, units={"t": "ms"})
    assert in_ms.fs == pytest.approx(record.fs, rel=1e-12) and in_ms.units["t"] == "s"
    assert in_ms.meta["input_units"]["t"] == {"unit": "ms", "si": "s", "factor": 0.001}


def test_volts_are_kept_as_given_and_say_so():
    record = nlid.simulate("paper-numerical", seed=0, channels="z", duration=1.0)
    volts = Record(record.f, record.z, record.fs, units={"f": "V", "z": "V", "v": "V/s"})
    np.testing.assert_array_equal(volts.z, record.z)
    assert volts.units["z"] == "V" and volts.units["v"] == "V/s" and "input_units" not in volts.meta


def test_the_conversion_is_kept_through_slicing_and_applied_once():
    record = nlid.simulate("paper-numerical", seed=0, channels="z,a", duration=1.0)
    in_mm = Record(record.f, 1000 * record.z, record.fs, a=record.a, units={"z": "mm"})
    for derived in (in_mm[10:500], in_mm.decimate(2), in_mm.with_derivatives(), in_mm.with_meta(mass=0.2)):
        assert derived.units["z"] == "m"
        assert derived.meta["input_units"] == {"z": {"unit": "mm", "si": "m", "factor": 0.001}}
    np.testing.assert_allclose(in_mm[10:500].z, record.z[10:500], rtol=1e-13)


# --------------------------------------------------------------------------- column map and tables
def test_a_unit_in_the_column_map_equals_units_and_a_scale_factor(tmp_path):
    rng = np.random.default_rng(3)
    t = np.arange(400) / 200.0
    frame = pd.DataFrame(
        {"time_ms": 1000 * t, "load_kN": rng.standard_normal(400), "disp_mm": np.cos(9 * t), "acc_g": np.sin(5 * t)}
    )
    by_map = Record.from_frame(frame, "t[ms]=time_ms, f[kN]=load_kN, z[mm]=disp_mm, a[g]=acc_g")
    by_units = Record.from_frame(
        frame, "t=time_ms, f=load_kN, z=disp_mm, a=acc_g", units={"t": "ms", "f": "kN", "z": "mm", "a": "g"}
    )
    by_factors = Record.from_frame(frame, "t=time_ms/1000, f=load_kN*1000, z=disp_mm*0.001, a=acc_g*9.80665")
    by_dict = Record.from_frame(frame, {"t[ms]": "time_ms", "f[kN]": "load_kN", "z[mm]": "disp_mm", "a[g]": "acc_g"})
    for record in (by_units, by_factors, by_dict):
        for c in ("f", "z", "a"):
            np.testing.assert_allclose(getattr(record, c), getattr(by_map, c), rtol=1e-14)
        assert record.fs == pytest.approx(by_map.fs, rel=1e-12)
    assert by_map.meta["input_units"] == by_units.meta["input_units"]
    assert by_map.meta["input_units"]["a"] == {"unit": "g", "si": "m/s^2", "factor": 9.80665}
    assert "input_units" not in by_factors.meta  # scale factors are arithmetic, not a declared unit
    assert nlid.load(frame, columns="t=time_ms, f=load_kN, z=disp_mm, a=acc_g", units="t=ms,f=kN,z=mm,a=g").meta[
        "input_units"
    ] == dict(by_map.meta["input_units"])


def test_a_channel_given_two_different_units_is_refused():
    frame = pd.DataFrame({"t": np.arange(100) / 10.0, "f": np.sin(np.arange(100)), "d": np.cos(np.arange(100))})
    with pytest.raises(InputError, match="the unit of 'z' is given twice: 'm' in units= and 'mm' in the column map"):
        Record.from_frame(frame, "z[mm]=d", units={"z": "m"})
    same = Record.from_frame(frame, "z[mm]=d", units={"z": "mm"})  # the same unit twice is one declaration
    np.testing.assert_allclose(same.z, frame.d / 1000, rtol=1e-15)


@pytest.mark.parametrize(
    "header, written",
    [("weg_µm", "weg_µm"), ("変位", "変位"), ("Weg [µm]", '"Weg [µm]"'), ("disp, µm", "'disp, µm'"), ("0", '"0"')],
)
def test_column_names_of_any_script_or_quoted(tmp_path, header, written):
    """Issue 25, group 7: a unit suffix such as ``weg_µm`` was refused; any header text is a column name."""
    t = np.arange(300) / 100.0
    frame = pd.DataFrame({"t": t, "Kraft": np.sin(4 * t), header: 1e6 * 0.01 * np.cos(3 * t)})
    path = tmp_path / "messung.csv"
    frame.to_csv(path, index=False, encoding="utf-8")
    for record in (
        nlid.load(path, columns=f"f=Kraft, z[µm]={written}"),
        Record.from_frame(frame, f"f=Kraft,z[um]={written}"),
    ):
        np.testing.assert_allclose(record.z, 0.01 * np.cos(3 * t), rtol=1e-12)
    assert parse_columns(f"z={written}*2")["z"].column == header


@pytest.mark.parametrize(
    "spec, says",
    [
        (
            "z=Weg [mm]",
            '(a name with spaces or symbols goes in quotes, e.g. z="Weg [mm]")',
        ),
        ('z="Weg', 'a quote " is not closed'),
        ('z=""', "an empty name in quotes"),
        ("z[mm=d", "unknown channel 'z[mm'"),
    ],
)
def test_column_map_mistakes_are_named(spec, says):
    with pytest.raises(InputError) as caught:
        parse_columns(spec)
    assert says in str(caught.value)


def test_column_units_lists_the_declared_units():
    assert column_units("t[ms]=time, f=load, z [ µm ] = weg_µm") == {"t": "ms", "z": "µm"}
    assert column_units(None) == {}
    assert parse_columns('z="  Weg [mm] "')["z"].column == "Weg [mm]"  # as the table's names, stripped


# --------------------------------------------------------------------------- coefficients in other units
@pytest.mark.parametrize(
    "term",
    [
        "1",
        "z",
        "z^2",
        "z^3",
        "z*|z|",
        "v",
        "v*|v|",
        "sign(v)",
        "z*v",
        "z^2*v",
        "v^3",
        "tanh(v/0.01)",
        "gap(z, 0.001)",
        "sign(v)*|px(z)|",
        "v*|px(z)|",
        "bouc_wen(1, 0.5)",
    ],
)
def test_si_display_is_the_terms_own_unit(term):
    parsed = parse_term(term)
    assert coefficient_conversion(parsed, display_units(None)) == (1.0, parsed.coefficient_unit)
    assert coefficient_conversion(parsed, display_units("SI")) == (1.0, parsed.coefficient_unit)


@pytest.mark.parametrize(
    "term, units, factor, text",
    [
        ("z", {"z": "mm"}, 1e-3, "N/mm"),
        ("z^3", {"z": "mm"}, 1e-9, "N/mm^3"),
        ("v", {"z": "mm"}, 1e-3, "N*s/mm"),  # the velocity follows the displacement: mm/s
        ("v*|v|", {"z": "mm"}, 1e-6, "N*s^2/mm^2"),
        ("z*v", {"z": "mm", "v": "m/s"}, 1e-3, "N*s/(mm*m)"),
        ("1", {"f": "kN"}, 1e-3, "kN"),
        ("z", {"f": "kN", "z": "µm"}, 1e-9, "kN/µm"),
        ("sign(v)", {"z": "mm", "f": "mN"}, 1e3, "mN"),
    ],
)
def test_coefficients_convert_by_the_powers_of_their_term(term, units, factor, text):
    got_factor, got_text = coefficient_conversion(parse_term(term), display_units(units))
    assert got_factor == pytest.approx(factor, rel=1e-12) and got_text == text


def test_a_fit_shows_its_coefficients_in_the_units_of_its_data(si):
    record, fit_si = si
    in_mm = Record.from_time(
        record.t, record.f / 1000, record.z * 1000, v=record.v, a=record.a, units={"z": "mm", "f": "kN"}
    )
    fit = nlid.identify(in_mm, TERMS, "rfs", mass=0.2)
    frame = fit.to_frame(units="input")
    assert list(frame["unit"]) == ["kN", "kN/mm", "kN/mm^2", "kN/mm^3", "kN*s/mm", "kN*s^2/mm^2"]
    powers = {"1": 0, "z": 1, "z^2": 2, "z^3": 3, "v": 1, "v*|v|": 2}
    for term, power in powers.items():
        assert frame.loc[term, "coefficient"] == pytest.approx(fit_si.coefficient(term) * 1e-3**power / 1e3, rel=REL)
        assert frame.loc[term, "std_error"] == pytest.approx(fit_si.standard_errors[term] * 1e-3**power / 1e3, rel=1e-6)
    np.testing.assert_allclose(fit.to_frame()["coefficient"], fit_si.to_frame()["coefficient"], rtol=REL)
    assert list(fit.to_frame()["unit"]) == list(fit_si.to_frame()["unit"])
    text = str(fit.summary(units="input"))
    assert "units: f in kN, z in mm, v in mm/s" in text and "kN/mm^3" in text and "equilibria (mm)" in text
    stable_mm = [f"{z * 1000:.6g}" for z in fit.equilibria.stable]
    assert all(s in text for s in stable_mm)
    assert str(fit.summary()) == str(fit.summary(units="SI")) == str(fit.summary(units=None))


def test_input_units_need_a_provenance(si):
    _, fit = si
    bare = nlid.IdentifiedModel(fit.model, fit.coefficients, fit.mass, fit.method)
    with pytest.raises(InputError, match="does not record the units of its data"):
        bare.to_frame(units="input")
    with pytest.raises(InputError, match="units= must be 'SI', 'input' or a mapping"):
        fit.summary(units="mm")


# --------------------------------------------------------------------------- the command line
@pytest.fixture
def rig_csv(tmp_path, si):
    """The SI record written in mm, kN and g, as a rig's CSV would hold it."""
    record, _ = si
    frame = pd.DataFrame(
        {
            "t": record.t,
            "load": record.f / 1000,
            "disp": record.z * 1000,
            "vel": record.v * 1000,
            "acc": record.a / 9.80665,
        }
    )
    path = tmp_path / "rig.csv"
    frame.to_csv(path, index=False, float_format="%.17g")
    return path


@pytest.mark.parametrize(
    "flags",
    [
        ["--columns", "f=load,z=disp,v=vel,a=acc", "--units", "f=kN,z=mm,v=mm/s,a=g"],
        ["--columns", "f[kN]=load,z[mm]=disp,v[mm/s]=vel,a[g]=acc"],
        ["--columns", "f[kN]=load,z=disp,v=vel,a[g]=acc", "--units", "z=mm,v=mm/s"],
    ],
)
def test_the_command_line_declares_units(si, rig_csv, flags, capsys):
    import json

    from nlid.cli.main import main

    _, fit = si
    status = main(["identify", str(rig_csv), *flags, "--terms", TERMS.replace(" ", ""), "--mass", "0.2", "--json"])
    out = json.loads(capsys.readouterr().out)
    assert status == 0
    for term, value in fit.coefficients.items():
        assert out["coefficients"][term] == pytest.approx(value, rel=REL), term


@pytest.mark.parametrize(
    "flags, says",
    [
        (["--columns", "f=load,z=disp", "--units", "z=furlong"], "unknown unit 'furlong' for channel 'z'"),
        (["--columns", "f=load,z[furlong]=disp"], "unknown unit 'furlong' for channel 'z'"),
        (["--columns", "f=load,z=disp", "--units", "z=mm,q=m"], "unknown channel 'q'"),
        (["--columns", "f=load,z=disp", "--units", "z"], "must look like channel=unit"),
        (["--units", "z=mm", "dataset:emps"], "do not apply to bundled datasets"),
    ],
)
def test_an_unknown_unit_exits_2_with_one_line(rig_csv, flags, says, capsys):
    from nlid.cli.main import main

    data = [] if "dataset:emps" in flags else [str(rig_csv)]
    status = main(["identify", *data, *flags, "--terms", "z^3"])
    err = capsys.readouterr().err
    assert status == 2, err
    assert err.count("\n") == 1 and "Traceback" not in err and says in err, err
    assert "--units" in err or "column map" in err or "units:" in err
