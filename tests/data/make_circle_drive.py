"""Write tests/data/circle_drive.csv: an analytic steady circle, exact kinematics, no noise.

Why this source: every number in it follows from closed-form circular motion, so pipeline
tests know the right answer without the simulator.  V = 15 m/s on a left circle of radius
R = 60 m: r = V/R = 0.25 rad/s, a_y = V^2/R = 3.75 m/s^2, constant sideslip beta = 0.02 rad at
the CG, flat road, IMU 50 Hz, wheel speeds 25 Hz, GNSS 10 Hz.  20 s, 1000 rows.

Run: .venv/bin/python tests/data/make_circle_drive.py
"""

from pathlib import Path

import numpy as np
import pandas as pd

V, R, BETA, G = 15.0, 60.0, 0.02, 9.80665
L, LR, TRACK = 2.8, 1.6, 1.58


def circle_columns() -> dict[str, np.ndarray]:
    t = np.arange(1000) * 0.02
    r = V / R
    yaw = r * t
    course = yaw + BETA
    # CG on a circle of radius R: centre to the left of the velocity.
    ang = course - np.pi / 2
    e, n = R * np.cos(ang), R * np.sin(ang)
    ve, vn = V * np.cos(course), V * np.sin(course)
    vx, vy = V * np.cos(BETA), V * np.sin(BETA)
    nan = np.full(t.size, np.nan)
    every = lambda k, x: np.where(np.arange(t.size) % k == 0, x, np.nan)  # noqa: E731
    v_rear_centre = vx  # rear-axle centre speed along x equals the CG's vx
    cols = {
        "t": t,
        "ax": -r * vy * np.ones_like(t),
        "ay": r * vx * np.ones_like(t),
        "az": G * np.ones_like(t),
        "wx": 0.0 * t, "wy": 0.0 * t, "wz": r * np.ones_like(t),
        "v_rl": every(2, (v_rear_centre - r * TRACK / 2) * np.ones_like(t)),
        "v_rr": every(2, (v_rear_centre + r * TRACK / 2) * np.ones_like(t)),
        "v_can": every(2, V * np.ones_like(t)),
        "steer": every(2, (L / R) * np.ones_like(t)),
        "gnss_e": every(5, e), "gnss_n": every(5, n), "gnss_u": every(5, 0 * t),
        "gnss_ve": every(5, ve), "gnss_vn": every(5, vn), "gnss_vu": every(5, 0 * t),
        "ref_beta": BETA * np.ones_like(t), "ref_yaw": yaw, "ref_roll": 0 * t, "ref_pitch": 0 * t,
        "ref_bank": 0 * t, "ref_e": e, "ref_n": n, "ref_u": 0 * t,
        "ref_vx": vx * np.ones_like(t), "ref_vy": vy * np.ones_like(t), "ref_r": r * np.ones_like(t),
        "ref_ay": r * vx * np.ones_like(t),
        "driver_note": np.where(t < 10, "first half", "second half"),
    }  # fmt: skip
    del nan
    return cols


if __name__ == "__main__":
    out = Path(__file__).with_name("circle_drive.csv")
    pd.DataFrame(circle_columns()).to_csv(out, index=False, float_format="%.12g")
    print(f"wrote {out}")
