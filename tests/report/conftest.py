"""Shared pieces of the report tests: a short simulated drive with a few estimates."""

from __future__ import annotations

import functools

import pytest

import sideslip as ss
from tests.conftest import sim_drive

METHODS = ("fused", "fg_batch", "kkf", "mkf", "kinematic_integration", "obs_bicycle")


@functools.lru_cache(maxsize=2)
def small_run(scenario: str = "step_steer") -> tuple[ss.Drive, ss.Estimates]:
    """A 12 s step steer with six methods (four with a sideslip sigma), run once per session."""
    drive = sim_drive(scenario, 0)
    return drive, ss.estimate(drive, drive.meta["vehicle"], methods=list(METHODS))


@pytest.fixture
def small() -> tuple[ss.Drive, ss.Estimates]:
    return small_run()


def synthetic_drive(hours: float, n_methods: int = 19, rate_hz: float = 100.0, seed: int = 0):
    """A long drive and ``n_methods`` noisy estimates built directly (no simulator, no methods),
    for the report's size and time axis: a 100 Hz table starting at t = 46410 s (a recorder's
    clock), GNSS at 10 Hz with a 30 s outage, every reference column the report draws."""
    import numpy as np

    from sideslip.drive import Drive

    rng = np.random.default_rng(seed)
    n = int(hours * 3600 * rate_hz)
    t = 46410.0 + np.arange(n) / rate_hz
    yaw = np.cumsum(rng.normal(0, 0.002, n))
    v = 20 + 5 * np.sin(t / 300)
    e = np.cumsum(v * np.cos(yaw) / rate_hz)
    north = np.cumsum(v * np.sin(yaw) / rate_hz)
    beta = 0.01 * np.sin(t / 7)
    gnss = np.where(np.arange(n) % 10 == 0, 1.0, np.nan)
    gnss[(t > t[0] + 60) & (t < t[0] + 90)] = np.nan
    data = {
        "wz": np.gradient(yaw) * rate_hz, "ay": rng.normal(0, 1, n), "v_can": v,
        "gnss_e": e * gnss, "gnss_n": north * gnss, "ref_beta": beta, "ref_roll": 0.01 * np.sin(t / 5),
        "ref_yaw": yaw, "ref_e": e, "ref_n": north, "ref_vx": v,
    }  # fmt: skip
    drive = Drive(t, data, {"vehicle": "midsize_sedan"}, "synthetic.parquet")
    est: dict[str, dict[str, np.ndarray]] = {"": {"t": t}}
    for k in range(n_methods):
        s = 0.001 * (k + 1)
        est[f"method_{k:02d}"] = {
            "beta": beta + rng.normal(0, s, n), "beta_std": np.full(n, s),
            "roll": data["ref_roll"] + rng.normal(0, s, n), "yaw": yaw + rng.normal(0, s, n),
            "e": e + rng.normal(0, 1, n), "n": north + rng.normal(0, 1, n),
        }  # fmt: skip
    return drive, est
