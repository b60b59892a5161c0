"""Vehicle loading, errors, presets and derived quantities against hand calculations."""

from __future__ import annotations

import math

import pytest

from sideslip.errors import InputError
from sideslip.vehicle import G, load_vehicle, preset_names


def test_presets_load_and_are_complete():
    names = preset_names()
    for required in ("seed003_sedan", "blazer_suv", "alphard_minivan", "ferrari_250lm", "midsize_sedan"):
        assert required in names
    for name in names:
        v = load_vehicle(name)
        # revs_250lm holds only what seed 002's authors published (its steer is road-wheel angle)
        need = ["mass", "yaw_inertia", "lf", "lr", "cf", "cr"]
        assert v.missing(need + ([] if name == "revs_250lm" else ["steering_ratio"])) == []


def test_seed003_table1_per_tyre_stiffness_is_converted_to_per_axle():
    v = load_vehicle("seed003_sedan")
    # Table 1: Cf = 2000 N/deg per tyre -> per axle 2 * 2000 * 180/pi N/rad
    assert v.cf == pytest.approx(2 * 2000 * 180 / math.pi, rel=1e-5)
    assert v.cr == pytest.approx(2 * 1600 * 180 / math.pi, rel=1e-5)
    assert v.cg_height - v.roll_axis_height == pytest.approx(0.54)


def test_blazer_understeer_matches_paper_4_deg_per_g():
    v = load_vehicle("blazer_suv")
    assert v.wheelbase == pytest.approx(2.591)
    assert math.degrees(v.understeer_gradient) * G == pytest.approx(4.0, abs=0.01)
    # the tyre stiffnesses reproduce the same gradient (hand: 1850/2.591*(1.451/77400-1.14/130000))
    hand = 1850 / 2.591 * (1.451 / 77400 - 1.14 / 130000)
    assert v.understeer_gradient_tyres == pytest.approx(hand, rel=1e-12)
    assert math.degrees(v.understeer_gradient_tyres) * G == pytest.approx(4.0, abs=0.05)


def test_derived_quantities_by_hand():
    v = load_vehicle("alphard_minivan")
    # K = m lf / (2 L K_r), K_r per tyre = cr/2: 2000*1.3/(2*3.0*57500) = 0.0075362
    assert v.slip_gain_k == pytest.approx(2000 * 1.3 / (2 * 3.0 * 57500), rel=1e-12)
    kus = 2000 / 3.0 * (1.7 / 107000 - 1.3 / 115000)
    assert v.understeer_gradient == pytest.approx(kus)
    assert v.characteristic_speed == pytest.approx(math.sqrt(3.0 / kus))
    assert v.static_roll_gain == pytest.approx(2000 * (0.72 - 0.15) / 110000)


def _toml(tmp_path, body: str):
    p = tmp_path / "car.toml"
    p.write_text(body)
    return p


def test_missing_essential_parameter_is_named(tmp_path):
    p = _toml(tmp_path, "[vehicle]\nmass = 1500\nlf = 1.2\n")
    with pytest.raises(InputError, match=r"car.toml: parameter 'lr' is missing"):
        load_vehicle(p)


def test_absurd_parameter_is_named(tmp_path):
    p = _toml(tmp_path, "[vehicle]\nmass = 1500\nlf = 1.2\nlr = 1.5\ncf = 80\n")
    with pytest.raises(InputError, match=r"parameter 'cf' = 80 N/rad is absurd: expected 1000 to 5e\+06"):
        load_vehicle(p)


def test_non_number_parameter(tmp_path):
    p = _toml(tmp_path, '[vehicle]\nmass = "heavy"\nlf = 1.2\nlr = 1.5\n')
    with pytest.raises(InputError, match=r"parameter 'mass' = 'heavy': expected a number in kg"):
        load_vehicle(p)


def test_unknown_keys_are_accepted_and_missing_optional_reported_on_need(tmp_path):
    p = _toml(tmp_path, "[vehicle]\nmass = 1500\nlf = 1.2\nlr = 1.5\nwheel_radius = 0.31\n[notes]\nx = 1\n")
    v = load_vehicle(p)
    assert v.missing(["cf", "mass"]) == ["cf"]
    with pytest.raises(InputError, match=r"parameter 'cf' is needed"):
        v.need("cf")


def test_bad_toml_and_unknown_preset(tmp_path):
    with pytest.raises(InputError, match="not valid TOML"):
        load_vehicle(_toml(tmp_path, "[vehicle\nmass=1"))
    with pytest.raises(InputError, match="no such vehicle file or preset"):
        load_vehicle("no_such_car")
