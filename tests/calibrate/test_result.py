"""Writing vehicle files: every preset round-trips; a calibration's file loads and says why."""

from __future__ import annotations

import math

import pytest

from sideslip.calibrate import calibrate, calibration_toml
from sideslip.errors import InputError
from sideslip.vehicle import load_vehicle, preset_names, save_vehicle, save_vehicle_text, vehicle_to_toml
from tests.conftest import sim_drive


@pytest.mark.parametrize("name", preset_names())
def test_every_preset_round_trips_through_the_writer(tmp_path, name):
    vehicle = load_vehicle(name)
    path = tmp_path / f"{name}.toml"
    save_vehicle(vehicle, path, notes={"cf": "a comment\non two lines"})
    back = load_vehicle(path)
    for field in ("mass", "cf", "cr", "steering_ratio", "roll_stiffness", "understeer_gradient_given"):
        a, b = getattr(vehicle, field), getattr(back, field)
        assert (math.isnan(a) and math.isnan(b)) or a == b, field
    assert back.gnss_xyz == vehicle.gnss_xyz and back.name == vehicle.name


def test_a_missing_key_stays_missing_and_is_named_in_its_note(tmp_path):
    vehicle = load_vehicle("midsize_sedan").with_changes(steering_ratio=math.nan)
    text = vehicle_to_toml(vehicle, {"steering_ratio": "left as it was"})
    assert "# steering_ratio not given" in text
    p = tmp_path / "v.toml"
    save_vehicle_text(text, p)
    assert math.isnan(load_vehicle(p).steering_ratio)


def test_writer_refuses_a_path_that_is_not_toml(tmp_path):
    with pytest.raises(InputError, match=r"expected an output path ending in \.toml"):
        save_vehicle(load_vehicle("midsize_sedan"), tmp_path / "v.json")
    assert list(tmp_path.iterdir()) == []


def test_calibration_file_loads_and_lists_what_was_left(tmp_path):
    drive = sim_drive("demo", 0)
    right = load_vehicle(drive.meta["vehicle"])
    cal = calibrate(drive, right.with_changes(cf=0.7 * right.cf, cr=0.7 * right.cr))
    text = calibration_toml(cal, "demo.parquet", "rough.toml")
    p = tmp_path / "fitted.toml"
    save_vehicle_text(text, p)
    back = load_vehicle(p)
    assert back.cf == pytest.approx(cal.get("cf").value)
    left = [f for f in cal.fitted if not f.informed]
    assert left and all(f.name in text for f in left)
    assert "left as it was" in text
