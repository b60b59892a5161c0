"""Seed 001 sec. VI: ``mkf_adaptive``, the MKF rerun with cornering stiffness identified from
the KKF's sideslip (offline, two KKF passes and one MKF pass).

The paper's route back into the model: a KKF with a gyro scale-factor state identifies the scale
factor from the heading change over each turn; the gyro is corrected and a second KKF pass gives
sideslip in the turns; front and rear cornering stiffness are then identified by least squares
from the tyre slip angles and the quasi-static axle forces (:func:`identify_cornering_stiffness`)
and the MKF (:mod:`sideslip.methods.mkf`) is rerun with them.

Identified parameters (params["identification"]): ``cf``/``cr`` (N/rad per axle),
``gyro_scale`` (measured / true yaw rate, 1.0 = perfect) with ``gyro_scale_sigma``.
Settings: :class:`sideslip.methods.mkf.MkfSettings` (its preset also sets the KKF passes' gyro
noise).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sideslip.drive import Drive
from sideslip.estimate import Estimate
from sideslip.methods.kkf import KkfSettings, run_kkf
from sideslip.methods.mkf import GNSS_COLUMNS, MkfSettings, mkf_estimate
from sideslip.methods.registry import SPEED, register
from sideslip.signals import causal_mean, hold, vehicle_speed
from sideslip.vehicle import Vehicle

FloatArray = NDArray[np.float64]

ID_AY_MIN = 1.0  # m/s^2: enough excitation
ID_AY_MAX = 0.5 * 9.80665  # m/s^2: near-linear tyres (seed 001 test-track turn: 0.4 g)
ID_RDOT_MAX = 0.1  # rad/s^2: quasi-steady
ID_SPEED_MIN = 5.0  # m/s
ID_MIN_SAMPLES = 20
ID_CLAMP = (0.33, 3.0)  # identified / file value limits
ID_R2_MIN = 0.7  # share of the axle-force variance the fit must explain to be adopted
ID_BETA_STD_MAX = math.radians(0.5)  # rad: only KKF sideslip this certain is used
ID_SCALE_STD_MAX = 0.01  # the scale-factor estimate is used only when this certain


def identify_cornering_stiffness(
    t: FloatArray,
    beta: FloatArray,
    yaw_rate: FloatArray,
    steer: FloatArray,
    speed: FloatArray,
    vehicle: Vehicle,
    use: NDArray[np.bool_],
) -> dict[str, Any]:
    """Least-squares front/rear cornering stiffness (per axle, N/rad) from measured sideslip.

    Slip angles (seed 001 eq 1):  alpha_f = delta - beta - lf r / V,  alpha_r = -beta + lr r / V.
    Axle forces from the quasi-static balance with a_y = V r (steady state, bank ignored):
        F_yf = (m lr a_y + I_z r') / L,   F_yr = (m lf a_y - I_z r') / L.
    Then cf = sum(F_yf alpha_f) / sum(alpha_f^2) and likewise cr, over rows ``use`` with
    ID_AY_MIN <= |a_y| <= ID_AY_MAX, |r'| <= ID_RDOT_MAX and V >= ID_SPEED_MIN.  With fewer than
    ID_MIN_SAMPLES rows, or a fit explaining less than ID_R2_MIN of either axle force, the
    file's values are kept ("identified": False); results are clamped to ID_CLAMP times the
    file's values.
    """
    L = vehicle.wheelbase
    v = np.maximum(np.abs(speed), 1e-3)
    rdot = np.gradient(causal_mean(t, yaw_rate, 0.5), t) if t.size > 2 else np.zeros_like(t)
    ay = v * yaw_rate
    sel = (
        use
        & np.isfinite(beta)
        & (np.abs(ay) >= ID_AY_MIN)
        & (np.abs(ay) <= ID_AY_MAX)
        & (np.abs(rdot) <= ID_RDOT_MAX)
        & (v >= ID_SPEED_MIN)
    )
    n = int(sel.sum())
    out: dict[str, Any] = {"n_samples": n, "cf": vehicle.cf, "cr": vehicle.cr, "identified": False}
    if n < ID_MIN_SAMPLES:
        return out
    b, r, d, vv, a, rd = beta[sel], yaw_rate[sel], steer[sel], v[sel], ay[sel], rdot[sel]
    af = d - b - vehicle.lf * r / vv
    ar = -b + vehicle.lr * r / vv
    ff = (vehicle.mass * vehicle.lr * a + vehicle.yaw_inertia * rd) / L
    fr = (vehicle.mass * vehicle.lf * a - vehicle.yaw_inertia * rd) / L
    cf = float(ff @ af / (af @ af)) if af @ af > 0 else vehicle.cf
    cr = float(fr @ ar / (ar @ ar)) if ar @ ar > 0 else vehicle.cr
    r2f = 1.0 - float(np.sum((ff - cf * af) ** 2) / max(float(ff @ ff), 1e-12))
    r2r = 1.0 - float(np.sum((fr - cr * ar) ** 2) / max(float(fr @ fr), 1e-12))
    good = r2f >= ID_R2_MIN and r2r >= ID_R2_MIN and cf > 0 and cr > 0
    lo, hi = ID_CLAMP
    out.update(
        {
            "cf_raw": cf,
            "cr_raw": cr,
            "r2_front": r2f,
            "r2_rear": r2r,
            "identified": bool(good),
        }
    )
    if good:
        out["cf"] = float(np.clip(cf, lo * vehicle.cf, hi * vehicle.cf))
        out["cr"] = float(np.clip(cr, lo * vehicle.cr, hi * vehicle.cr))
    return out


def identify_from_kkf(
    drive: Drive, vehicle: Vehicle, kkf_settings: KkfSettings | None = None
) -> dict[str, Any]:
    """Seed 001 sec. VI route: scale factor from a KKF with a scale state (used when its
    1-sigma is below ID_SCALE_STD_MAX, i.e. a turn between two straights was seen), gyro
    corrected, KKF sideslip in the turns, then :func:`identify_cornering_stiffness` at
    fresh-course rows whose KKF beta_std is below ID_BETA_STD_MAX."""
    first = run_kkf(drive, vehicle, estimate_scale=True, settings=kkf_settings)
    scale_std = float(np.sqrt(max(first.var[-1, 2], 0.0)))
    scale = float(np.clip(first.x[-1, 2], -0.1, 0.1)) if scale_std < ID_SCALE_STD_MAX else 0.0
    del first  # only its scale factor is used: not held through the second pass (issue 17)
    res = run_kkf(drive, vehicle, scale=scale, settings=kkf_settings)
    t = drive.t
    wz, _ = hold(drive["wz"], t)
    r = (wz - res.x[:, 1]) / (1.0 + scale)
    steer, _ = hold(drive["steer"], t)
    speed = vehicle_speed(drive)
    # only fresh KKF sideslip whose heading is known well (after a straight, not too long ago)
    use = res.beta_fresh & (res.beta_std_filter < ID_BETA_STD_MAX)
    beta = np.where(use, res.beta, np.nan)
    ident = identify_cornering_stiffness(t, beta, r, steer, speed, vehicle, use)
    ident["gyro_scale"] = 1.0 + scale  # measured / true
    ident["gyro_scale_sigma"] = scale_std
    ident["gyro_scale_used"] = bool(scale_std < ID_SCALE_STD_MAX)
    return ident


@register(
    "mkf_adaptive",
    columns=("wz", "steer", SPEED, GNSS_COLUMNS),
    summary="MKF with cornering stiffness identified from KKF sideslip (offline, 2 passes)",
    paper="seed 001 sec. VI",
    vehicle_params=("mass", "yaw_inertia", "lf", "lr", "cf", "cr"),
    settings=MkfSettings,
    accelerometer="cg_causal",
)
def mkf_adaptive(drive: Drive, vehicle: Vehicle, settings: MkfSettings | None = None) -> Estimate:
    """MKF rerun with cornering stiffness identified from the KKF; see the module docstring."""
    st = settings if settings is not None else MkfSettings()
    # the KKF's own P (no scale-factor term) selects the sideslip used for the fit, as in the
    # paper: the scale factor is identified and removed by the first pass
    kst = KkfSettings(
        preset=st.preset, gyro_sigma_100hz_rad_s=st.gyro_sigma_100hz_rad_s,
        gyro_scale_rel_sigma=0.0,
    )  # fmt: skip
    ident = identify_from_kkf(drive, vehicle, kst)
    tuned = vehicle.with_changes(cf=ident["cf"], cr=ident["cr"])
    params = {"identification": ident, "cf_file": vehicle.cf, "cr_file": vehicle.cr}
    return mkf_estimate("mkf_adaptive", drive, tuned, params, None, st)
