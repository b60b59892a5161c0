"""Property-based: vehicle files as rough as users' are, and broken ones.

Every case ends in a Vehicle whose given values are finite and inside the absurd-value bounds
(missing ones NaN), or in one InputError line naming the file; a command given such a file
exits 0 or 2 with one line and writes nothing.
"""

from __future__ import annotations

import math
import tempfile
from pathlib import Path

from hypothesis import given
from hypothesis import strategies as st

from sideslip.cli import app
from sideslip.errors import InputError
from sideslip.vehicle import OPTIONAL_PARAMETERS, PARAMETERS, load_vehicle
from tests.fuzz.common import RUNNER, check_cli_outcome, count, fuzz_settings
from tests.helpers import CIRCLE

GOOD = {
    "mass": 1550.0, "yaw_inertia": 2700.0, "lf": 1.2, "lr": 1.6, "cf": 120000.0,
    "cr": 130000.0, "track_front": 1.58, "track_rear": 1.58, "cg_height": 0.55,
    "roll_axis_height": 0.1, "roll_stiffness": 85000.0, "roll_damping": 6000.0,
    "roll_inertia": 700.0, "steering_ratio": 15.0,
}  # fmt: skip
BAD_VALUES = st.sampled_from(['"heavy"', "-1.0", "0", "1e30", "nan", "inf", "-inf", "true",
                              "[1, 2]", "{ a = 1 }", '"1550"', "1_550", "0x10"])


@st.composite
def vehicle_text(draw) -> str:
    lines = ["[vehicle]"]
    if draw(st.booleans()):
        lines.append('name = "fuzz"')
    for key, value in GOOD.items():
        action = draw(st.sampled_from(["keep"] * 6 + ["drop", "bad", "scale"]))
        if action == "drop":
            continue
        if action == "bad":
            lines.append(f"{key} = {draw(BAD_VALUES)}")
        elif action == "scale":  # a rough file: 20-35 % off, or a unit slip (x1000, /1000)
            lines.append(f"{key} = {value * draw(st.sampled_from([0.65, 0.8, 1.2, 1.35, 1e3, 1e-3]))!r}")
        else:
            lines.append(f"{key} = {value!r}")
    if draw(st.booleans()):
        lines.append(f"understeer_gradient = {draw(st.sampled_from(['0.002', '0.5', '-1', 'nan']))}")
    if draw(st.booleans()):
        lines.append("wheel_radius = 0.31")  # a user's own key: ignored
    if draw(st.booleans()):
        lines += ["[notes]", 'who = "me"']
    if draw(st.booleans()):
        arm = draw(st.sampled_from(["[0.0, 0.0, 1.3]", "[0.0, 1.3]", '"roof"', "[1e9, 0, 0]"]))
        lines += ["[sensors]", f"gnss_xyz = {arm}"]
    text = "\n".join(lines) + "\n"
    cut = draw(st.sampled_from([None] * 5 + ["cut"]))
    if cut:
        text = text[: draw(st.integers(0, len(text)))]
    return text


def _check(v) -> None:
    for key, (_, lo, hi) in {**PARAMETERS, **OPTIONAL_PARAMETERS}.items():
        attr = "understeer_gradient_given" if key == "understeer_gradient" else key
        value = getattr(v, attr)
        assert math.isnan(value) or (math.isfinite(value) and lo <= value <= hi), (key, value)


@given(text=vehicle_text())
@fuzz_settings(150)
def test_rough_and_broken_vehicle_files_load_or_fail_in_one_line(text):
    count("vehicle: TOML")
    with tempfile.TemporaryDirectory() as tmp:
        p = Path(tmp) / "car.toml"
        p.write_text(text)
        try:
            v = load_vehicle(str(p))
        except InputError as exc:
            msg = str(exc)
            assert msg.startswith(str(p)) and "\n" not in msg, msg
            return
        _check(v)


@given(raw=st.binary(max_size=500))
@fuzz_settings(40)
def test_binary_vehicle_files_fail_in_one_line(raw):
    count("vehicle: binary")
    with tempfile.TemporaryDirectory() as tmp:
        p = Path(tmp) / "car.toml"
        p.write_bytes(raw)
        try:
            _check(load_vehicle(str(p)))
        except InputError as exc:
            assert str(exc).startswith(str(p)) and "\n" not in str(exc)


@given(text=vehicle_text())
@fuzz_settings(25)
def test_estimate_with_a_rough_vehicle_file_runs_or_fails_in_one_line(text):
    count("vehicle: estimate CLI in-process")
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        p = d / "car.toml"
        p.write_text(text)
        before = {x.name for x in d.iterdir()}
        res = RUNNER.invoke(app, ["estimate", str(CIRCLE), "--vehicle", str(p), "--method",
                                  "kinematic_integration", "--out", str(d / "e.csv")])
        check_cli_outcome(res, d, before)
