"""The public Python API: ``import sideslip as ss`` and five names do a whole evaluation."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

import sideslip as ss
from sideslip.estimate import Estimate
from sideslip.evaluate import SPEED_GATE, evaluate_all
from sideslip.methods.registry import get_method
from tests.helpers import CIRCLE


def test_import_is_light():
    code = "import sideslip, sys; print(sorted(m for m in ('numpy', 'pandas', 'scipy', 'numba', 'plotly') if m in sys.modules))"
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert res.stdout.strip() == "[]", res.stderr


def test_estimate_by_names_returns_a_table_and_evaluates():
    drive = ss.load_drive(CIRCLE)
    est = ss.estimate(drive, "midsize_sedan", methods=["fused", "fg_batch"])
    assert est.names == ["fused", "fg_batch"]
    frame = est.to_frame()
    assert {"t", "fused.beta", "fused.beta_std", "fg_batch.beta"} <= set(frame.columns)
    assert len(frame) == len(drive)
    one = est["fused"].to_frame()
    assert list(one.columns[:2]) == ["t", "beta"]
    metrics = ss.evaluate(drive, est)
    assert metrics == evaluate_all(drive, {m: dict(e.series) for m, e in zip(est.names, est, strict=True)})
    # the analytic circle's true sideslip is 0.02 rad; the fused smoother is within 0.7 deg of it
    # (measured 0.67 deg: the circle gives it no GNSS course change to learn the slip gain from)
    assert metrics["fused"]["beta_rmse_deg"] < 1.0


def test_methods_as_objects_or_functions_and_vehicles_as_names_paths_or_objects(tmp_path):
    drive = ss.load_drive(CIRCLE)
    by_name = ss.estimate(drive, "midsize_sedan", methods=["kkf"])["kkf"]
    vehicle = ss.load_vehicle("midsize_sedan")
    by_object = ss.estimate(drive, vehicle, methods=[get_method("kkf")])["kkf"]
    by_function = ss.estimate(CIRCLE, vehicle, methods=[get_method("kkf").func])["kkf"]
    car = tmp_path / "car.toml"
    car.write_text(vehicle_text())
    by_path = ss.estimate(drive, car, methods=["kkf"])["kkf"]
    for other in (by_object, by_function, by_path):
        assert np.array_equal(other["beta"], by_name["beta"])


def vehicle_text() -> str:
    from importlib import resources

    return (resources.files("sideslip") / "presets" / "midsize_sedan.toml").read_text()


def test_an_unregistered_function_is_a_method_too():
    drive = ss.load_drive(CIRCLE)

    def zero_slip(drive, vehicle):
        return Estimate("zero_slip", drive.t, {"beta": np.zeros(len(drive))})

    est = ss.estimate(drive, "midsize_sedan", methods=[zero_slip])
    gate = drive["ref_vx"] > SPEED_GATE
    expected = np.degrees(np.sqrt(np.mean(drive["ref_beta"][gate] ** 2)))
    assert ss.evaluate(drive, est)["zero_slip"]["beta_rmse_deg"] == pytest.approx(expected)


def test_all_methods_with_skipped_reasons(tmp_path):
    import pandas as pd

    p = tmp_path / "nosteer.csv"
    pd.read_csv(CIRCLE).drop(columns=["steer"]).to_csv(p, index=False)
    est = ss.estimate(p, "midsize_sedan")
    assert est.skipped["fg_batch"] == "drive lacks 'steer'"
    assert "fused" in est and "fg_batch" not in est.names
    with pytest.raises(ss.InputError, match="column 'steer': method 'fg_batch' needs this column"):
        ss.estimate(p, "midsize_sedan", methods=["fg_batch"])
    with pytest.raises(ss.InputError, match="unknown method 'magic'"):
        ss.estimate(p, "midsize_sedan", methods=["magic"])


def test_windows_restrict_the_evaluation():
    drive = ss.load_drive(CIRCLE)
    est = ss.estimate(drive, "midsize_sedan", methods=["kkf"])
    part = ss.evaluate(drive, est, windows=[(5.0, 10.0)])
    rows = (drive.t >= 5) & (drive.t <= 10)
    err = np.degrees(est["kkf"]["beta"][rows] - drive["ref_beta"][rows])
    assert part["kkf"]["beta_rmse_deg"] == pytest.approx(np.sqrt(np.mean(err**2)))


def test_module_names_stay_importable_beside_the_functions():
    import sideslip.estimate as estimate_module
    from sideslip.evaluate import metrics

    assert estimate_module.Estimate is Estimate and callable(metrics)
    assert callable(ss.estimate) and callable(ss.evaluate)
    assert ss.simulate_drive("step_steer").t.size == 1201


def test_a_bad_input_stops_the_run_before_any_method_runs():
    """The demo drive with steer as a steering-wheel angle (x15, inside the 1.2 range limit):
    the steering check of the methods that read it fails.  Every method the run will use is
    checked first, so the one-line error comes before the first method starts (before, the
    methods ahead of the first steering reader ran and their time was lost)."""
    from sideslip.drive import Drive
    from sideslip.errors import InputError
    from tests.conftest import sim_drive

    drive = sim_drive("demo")
    data = dict(drive.data)
    data["steer"] = np.asarray(drive["steer"]) * 15.0
    bad = Drive(drive.t, data, drive.meta, drive.path)
    events: list[tuple[str, str]] = []
    with pytest.raises(InputError, match="column 'steer'"):
        ss.estimate(bad, drive.meta["vehicle"], progress=lambda ev, name, *_: events.append((ev, name)))
    assert not [e for e in events if e[0] == "start"], events
