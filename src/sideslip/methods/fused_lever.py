"""The GNSS antenna's longitudinal lever arm, checked tyre-free against the drive's Doppler.

The Doppler velocity is the antenna's: ``v + omega x l``, so an antenna ``dl_x`` ahead of where
the vehicle file says adds ``r dl_x`` to the lateral velocity it measures, which the fused
smoother reads as sideslip (0.5 m at 10 m/s and 0.3 rad/s: 0.9 deg).  As a state learned
together with the tyres it takes the tyres' errors too (a steady circle cannot tell ``r dl_x``
from ``v_y``; benchmarks/results/fused_accuracy.md: false offsets of 0.3-0.8 m on drives with
the right file).  Without the tyres the kinematics still separate them wherever the yaw rate
changes faster than the body velocity's random walk lets ``v_y`` wander: ``v_y`` follows the
accelerometers (``dv_y/dt = a_y - r v_x``), ``r dl_x`` follows the gyro.

:func:`check_lever` runs the smoother once more with the axle relations switched off
(:func:`without_tyres`) and the lever-arm states on, with the process noise read from the
drive for the estimate (:mod:`sideslip.methods.fused_vrw`), and reads ``dl_x`` with its
sigma.  The file's antenna is kept unless the drive contradicts it twice: where ``|dl_x|``
exceeds ``z_gate`` sigmas, and the forward filter with the tyres predicts the Doppler better
with the antenna moved by ``dl_x`` than with the file's, by more than ``z_gate^2`` in
``-2 log L`` (``LeverCheck.gain``, computed by the caller).
Before the first test the part of ``dl_x`` that is the node inputs' timing is taken out
where they have one (``lagged``; the smoother's default integrates with the trapezoidal rule
where Doppler is present, which has none): with the rectangle rule each node's inputs are
the mean of its rows, half a row behind the interval they propagate
over, so against the Doppler the kinematics run half a row late, which in turns reads as an
antenna ``v dt / 2`` ahead (the race lap with the antenna where the file says: +0.163 +-
0.023 m found, 0.108 m of it this; fused_accuracy.md session 8), and since an IMU sample may
stand for its instant or for the interval before it, the timing is uncertain by as much
again, which widens the gate's sigma (seed 1's race lap read +0.181 +- 0.024 m at a true 0:
3.4 sigma after the 0.11 m, 0.6 with the wider sigma).  The estimate, which has the same
timing, is moved by the whole ``dl_x``.  The second test is there because the tyre-free
kinematics have model errors beyond that which the first does not carry: on the 15-minute
endurance drive, antenna where the file says, the pass read +0.21 +- 0.05 m (0.05 m of it
the timing: 2.4 sigma with the timing's uncertainty, so the first test keeps the file's; at
a 2-sigma gate the second does, the likelihood with the tyres rising by 209 for the move,
which would have taken beta 0.015 -> 0.040 deg).  For antennas truly 0.5 m off it fell by 36
to 489 in six of seven cells printed.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from sideslip.methods import fused_engine as eng
from sideslip.models.fused_process import ILX, ILY, ITAU, IVX, NX_CORE, NX_GNSS_CAL, f_rows
from sideslip.vehicle import Vehicle

__all__ = [
    "ImuAlternative", "LeverCheck", "check_lever", "imu_moved", "likelihood_weights", "without_tyres",
]  # fmt: skip

# the axle relations' residual floor (m/s^2) that takes the tyres out of the pass: a million
# times any lateral acceleration, so they carry no information on v_y
NO_TYRES_FORCE_SIGMA = 1e6


@dataclass(frozen=True)
class LeverCheck:
    """The tyre-free longitudinal lever-arm error ``dl_x_m`` (antenna this far ahead of the
    file's, m) with its 1-sigma; where it is beyond ``z_gate`` sigmas, ``gain``: ``-2 log L``
    of the Doppler innovations with the tyres, the file's antenna less the moved one."""

    dl_x_m: float
    sigma_m: float
    z_gate: float
    gain: float = math.nan
    timing_m: float = 0.0  # the part of dl_x_m the node inputs' half-row lag accounts for
    timing_sigma_m: float | None = None  # the timing's uncertainty (m); None: timing_m
    # -2 log L of the Doppler with the tyres, the file's antenna and the moved one (where found)
    neg2ll: tuple[float, float] | None = None

    @property
    def z(self) -> float:
        """Sigmas between the antenna found and the file's, less what the timing accounts for;
        the timing is itself uncertain by as much again (an IMU sample may stand for its
        instant or for the interval before it), which widens the sigma."""
        off = abs(self.dl_x_m - self.timing_m)
        timing_sigma = self.timing_m if self.timing_sigma_m is None else self.timing_sigma_m
        sigma = math.hypot(self.sigma_m, timing_sigma)
        return off / sigma if sigma > 0.0 else math.inf

    @property
    def found(self) -> bool:
        """The tyre-free pass puts the antenna beyond the gate."""
        return bool(math.isfinite(self.dl_x_m) and self.z > self.z_gate)

    @property
    def applied(self) -> bool:
        """... and with the tyres the moved antenna predicts the Doppler better by more than
        the gate's chi^2 (one degree of freedom): the estimate moves the antenna."""
        return self.found and self.gain > self.z_gate**2

    def note(self) -> str:
        found = (
            f"tyre-free against the Doppler: antenna {self.dl_x_m:+.3f} +- {self.sigma_m:.3f} m "
            f"ahead of the file's, {self.timing_m:+.3f} m of it the inputs' timing "
            f"({self.z:.1f} sigma"
        )
        if not self.found:
            return f"{found}, within {self.z_gate:g}): the file's kept"
        with_tyres = f"with the tyres -2 log L of the Doppler {-self.gain:+.1f} moved"
        if self.applied:
            return f"{found}; {with_tyres}): moved by it"
        return f"{found}; but {with_tyres}, not below -{self.z_gate**2:g}): the file's kept"

    def params(self) -> dict[str, Any]:
        found = math.isfinite(self.dl_x_m) and math.isfinite(self.sigma_m)
        return {
            "gnss_lever_x_tyre_free_m": self.dl_x_m if found else None,
            "gnss_lever_x_tyre_free_m_sigma": self.sigma_m if found else None,
            "gnss_lever_x_timing_m": self.timing_m,
            "gnss_lever_x_neg2ll_gain": self.gain if math.isfinite(self.gain) else None,
            "gnss_lever_x_neg2ll": None if self.neg2ll is None else list(self.neg2ll),
            "gnss_lever_x_applied_m": self.dl_x_m if self.applied else 0.0,
        }


def imu_moved(vehicle: Vehicle, dx_m: float) -> Vehicle:
    """``vehicle`` with its IMU ``dx_m`` further ahead (the same where ``dx_m`` is 0)."""
    if dx_m == 0.0:
        return vehicle
    x, y, z = (float(c) for c in vehicle.imu_xyz)
    return dataclasses.replace(vehicle, imu_xyz=(x + dx_m, y, z))


@dataclass(frozen=True)
class ImuAlternative:
    """The tyre-free offset ``dl_x_m`` (antenna ahead of the file's, relative to the IMU) read
    the other way: the IMU ``dl_x_m`` behind the file's place.  Kinematically the two are
    one: an accelerometer at ``x_i`` integrates to the lateral velocity of its own point,
    ``v_y + r x_i`` (its x reading carries the same ``-x_i r^2``, so neither separates them),
    and the Doppler gives the antenna's, ``v_y + r x_a``; only ``x_a - x_i`` is seen.  The
    tyres place the CG, so the Doppler's ``-2 log L`` with the tyres (the forward filter's
    innovations, each installation with the noise it identifies itself) decides: the IMU is
    moved where it beats the file's installation by more than ``z_gate^2`` (the antenna's own
    rule) and the moved antenna too.  Otherwise the installation :class:`LeverCheck`
    settled on stays (the file's, or the antenna moved where ``antenna_applied``).

    The installations' likelihood weights (:meth:`weights`: ``exp(-n / 2)`` normalised, the
    file's left out where the antenna was moved, as it was there beaten beyond the gate)
    put the others' beta, weighted, into ``beta_std``: where the Doppler hardly tells them
    apart the sigma covers both.

    ``neg2ll_latency``: one more explanation, the installation as the file says with the
    Doppler late by the latency the tyres' profile found (:mod:`sideslip.methods.fused_latency`;
    tyre-free a Doppler ``tau`` late reads in turns as an antenna ``v tau`` behind).  Taken
    where it beats the file's by ``z_gate^2`` and every installation
    (:attr:`latency_applied`), which it must also be beaten by for the IMU to move."""

    dl_x_m: float
    neg2ll_file: float
    neg2ll_antenna: float
    neg2ll_imu: float
    antenna_applied: bool
    z_gate: float
    # the same with the installation the file's and the Doppler epochs taken at the latency
    # the tyres' profile found (sideslip.methods.fused_latency; inf: none found)
    neg2ll_latency: float = math.inf

    @property
    def applied(self) -> bool:
        """The IMU moved."""
        gain = self.neg2ll_file - self.neg2ll_imu
        best = min(self.neg2ll_antenna, self.neg2ll_latency)
        return bool(gain > self.z_gate**2 and self.neg2ll_imu < best)

    @property
    def latency_applied(self) -> bool:
        """The late Doppler explains the offset best: installation as the file says, the
        epochs taken at the tyres' latency."""
        gain = self.neg2ll_file - self.neg2ll_latency
        best = min(self.neg2ll_antenna, self.neg2ll_imu)
        return bool(gain > self.z_gate**2 and self.neg2ll_latency < best)

    @property
    def chosen(self) -> str:
        """``"latency"``, ``"imu"``, ``"antenna"`` or ``"file"``: the explanation the estimate
        takes."""
        if self.latency_applied:
            return "latency"
        return "imu" if self.applied else ("antenna" if self.antenna_applied else "file")

    def weights(self) -> dict[str, float]:
        """Each explanation's share of the likelihood (the file's not where the antenna moved)."""
        n = {"antenna": self.neg2ll_antenna, "imu": self.neg2ll_imu}
        if math.isfinite(self.neg2ll_latency):
            n["latency"] = self.neg2ll_latency
        if not self.antenna_applied:
            n["file"] = self.neg2ll_file
        return likelihood_weights(n)

    def note(self) -> str:
        others = ", ".join(f"{k} {v:.2f}" for k, v in self.weights().items() if k != self.chosen)
        late = ""
        if math.isfinite(self.neg2ll_latency):
            late = f", {self.neg2ll_imu - self.neg2ll_latency:+.1f} against the Doppler late"
        versus = (
            f"with the tyres -2 log L of the Doppler {self.neg2ll_imu - self.neg2ll_file:+.1f} against "
            f"the file's, {self.neg2ll_imu - self.neg2ll_antenna:+.1f} against the antenna moved{late}; "
            f"likelihood weights of the others: {others}"
        )
        if self.latency_applied:
            return f"the file's kept: the Doppler late explains the offset better ({versus})"
        if self.applied:
            return f"moved {-self.dl_x_m:+.3f} m (the tyre-free offset read as the IMU's; {versus})"
        return f"the file's kept (the IMU {-self.dl_x_m:+.3f} m: {versus})"

    def params(self) -> dict[str, Any]:
        return {
            "imu_lever_x_applied_m": -self.dl_x_m if self.applied else 0.0,
            "imu_lever_x_neg2ll": self.neg2ll_imu,
            "imu_lever_x_weights": self.weights(),
        }


def likelihood_weights(neg2ll: dict[str, float]) -> dict[str, float]:
    """Each explanation's share ``exp(-n / 2)`` (normalised) of the likelihood, from its
    ``-2 log L`` ``n``."""
    low = min(neg2ll.values())
    w = {k: math.exp(-(v - low) / 2.0) for k, v in neg2ll.items()}
    total = sum(w.values())
    return {k: v / total for k, v in w.items()}


def without_tyres(after: tuple[Any, ...]) -> tuple[Any, ...]:
    """``after`` (the trailing arguments of :func:`sideslip.methods.fused_engine.run_nodes`)
    with the axle relations switched off, on copies of its configuration and process noise
    (the caller's stay as they are); the lever arm is the caller's array."""
    *head, q, rows, axle, lever, cfg, smooth = after
    c = cfg.copy()
    c[eng.C_FORCE_SIGMA] = NO_TYRES_FORCE_SIGMA
    c[eng.C_LOW_SPEED_SIGMA] = 0.0
    return (*head, q.copy(), rows, axle, lever, c, smooth)


def check_lever(
    before: tuple[Any, ...],
    g_age: np.ndarray,
    free: tuple[Any, ...],
    lever_prior_sigma_m: float,
    lever_psd: float,
    latency_prior_sigma_s: float,
    latency_psd: float,
    z_gate: float,
    row_dt_s: float,
    lagged: bool = True,
) -> LeverCheck:
    """The smoother of :func:`sideslip.methods.fused_engine.run_nodes` (``before``, ``g_age``
    as its arguments; ``free`` its trailing arguments with the core states only, from
    :func:`without_tyres`) once more, with the antenna's lever-arm error (prior
    ``N(0, lever_prior_sigma_m)``, random walk ``lever_psd``) and the fixes' latency
    (likewise) as states; ``dl_x`` is the smoothed states' median, its sigma the last node's
    (a constant's smoothed sigma).

    ``row_dt_s`` (the drive's row interval) sizes the part of ``dl_x`` that is the node
    inputs' timing: with the rectangle rule (``lagged``) each node's inputs are the mean of
    its rows, centred half a row before the interval they propagate over, so against the
    Doppler the kinematics run ``row_dt_s / 2`` late, which in a turn reads as
    ``r v row_dt_s / 2``, an antenna ``v row_dt_s / 2`` ahead (v weighted by r^2, as the
    turns inform dl_x).  Either way that much is the timing's uncertainty (a sample may
    stand for its instant or for the interval before it)."""
    g_e, g_n, pstd, ve, vn, vstd, x0, P0, q, _, axle, lever, cfg, _ = free
    nx = NX_CORE + NX_GNSS_CAL
    x0c = np.zeros(nx)
    x0c[:NX_CORE] = x0
    P0c = np.zeros((nx, nx))
    P0c[:NX_CORE, :NX_CORE] = P0
    P0c[ILX, ILX] = P0c[ILY, ILY] = lever_prior_sigma_m**2
    # the fixes' latency beside it: on an arc the fixes see an antenna ahead as an along-track
    # offset, the same as a latency of -dl_x / v, so the fixes alone do not decide it
    P0c[ITAU, ITAU] = latency_prior_sigma_s**2
    qc = np.zeros(nx)
    qc[:NX_CORE] = q
    qc[ILX] = qc[ILY] = lever_psd**2
    qc[ITAU] = latency_psd**2
    run: Any = eng.run_nodes  # compiled
    xs, _, var_last, *_ = run(
        *before, g_age, g_e, g_n, pstd, ve, vn, vstd, x0c, P0c, qc, f_rows(nx), axle, lever, cfg, True
    )
    dl = float(np.median(xs[:, ILX]))
    sigma = float(math.sqrt(max(float(var_last[ILX]), 0.0)))
    if not (math.isfinite(dl) and math.isfinite(sigma)):
        return LeverCheck(math.nan, math.inf, z_gate)
    r2 = np.square(before[1][1, :, 0])  # the gyro's z rate at the nodes
    v_turns = float(np.sum(r2 * xs[:, IVX]) / np.sum(r2)) if np.sum(r2) > 0.0 else 0.0
    timing = v_turns * row_dt_s / 2.0 if math.isfinite(v_turns) else 0.0
    return LeverCheck(dl, sigma, z_gate, timing_m=timing if lagged else 0.0, timing_sigma_m=timing)
