"""The fused smoother's velocity random walk from the drive's own GNSS Doppler innovations.

The process noise on the body velocity (``FusedSettings.accel_vrw_psd``, m/s/sqrt(s)) stands
for everything the planar kinematics ``v_y' = a_y - c_y - r v_x`` misses: accelerometer
noise and vibration, gravity through roll transients the suspension model does not carry,
pitch and heave.  How much of that a drive has depends on the car, the IMU and its mount, so
the smoother reads it from the drive: the forward filter is run at a few candidate values and
the one that predicts the Doppler velocities best is kept, i.e. the maximum of the
prediction-error decomposition of their likelihood (Schweppe 1965, IEEE Trans. Inf. Theory
11(1); the same criterion as Mehra 1970's adaptive filtering, IEEE Trans. Autom. Control
15(2), reached by direct search over one scale).  Doppler is the cue for it because it
measures the velocity itself, independently of the tyres; GNSS positions answer a velocity
error only through its integral, and without GNSS nothing independent of the model is left,
so those drives keep the prior.

The search walks a factor-of-two grid from the prior: down while the likelihood improves (to
``min_factor`` of the prior and never below the accelerometer's own white noise, the
smallest velocity random walk the drive can have), up (to ``max_factor``) where the first
step down is already worse.  Candidates are evaluated two at a time (the compiled forward
pass runs without the GIL).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

__all__ = ["NoiseChoice", "search_accel_vrw", "search_noise_scale"]


@dataclass(frozen=True)
class NoiseChoice:
    """A chosen noise density and the evidence for it."""

    value: float  # in the unit below
    prior: float  # the settings' value
    tried: tuple[tuple[float, float], ...]  # (value, -2 log L less the best's), in search order
    unit: str = "m/s/sqrt(s)"

    def note(self) -> str:
        """One line for the estimate's notes."""
        tried = ", ".join(f"{v:.3g}: {d:+.1f}" for v, d in sorted(self.tried, reverse=True))
        return (
            f"{self.value:.3g} {self.unit} (prior {self.prior:.3g}): the best predictor of the "
            f"Doppler velocities; -2 log L against the best: {tried}"
        )


def search_accel_vrw(
    neg2ll: Callable[[Sequence[float]], Sequence[float]],
    prior: float,
    floor: float,
    min_factor: float = 1.0 / 16.0,
    max_factor: float = 4.0,
) -> NoiseChoice:
    """Direct search of the velocity random walk (m/s/sqrt(s)); see :func:`search_noise_scale`."""
    if not (prior > 0.0 and math.isfinite(prior)):
        raise ValueError(f"prior velocity random walk must be positive and finite, got {prior!r}")
    return search_noise_scale(neg2ll, prior, floor, min_factor, max_factor)


def search_noise_scale(
    neg2ll: Callable[[Sequence[float]], Sequence[float]],
    prior: float,
    floor: float,
    min_factor: float = 1.0 / 16.0,
    max_factor: float = 4.0,
    unit: str = "m/s/sqrt(s)",
) -> NoiseChoice:
    """Direct search of a noise density over ``prior * 2**k``.

    ``neg2ll(values)`` returns ``-2 log L`` of the Doppler innovations for each value (any
    constant offset); it is called with at most two values at a time.  ``floor`` (the
    density's unit) bounds the search below together with ``prior * min_factor``; the prior
    itself is always a candidate.
    """
    if not (prior > 0.0 and math.isfinite(prior)):
        raise ValueError(f"prior noise density must be positive and finite, got {prior!r}")
    lowest = max(prior * min_factor, floor if math.isfinite(floor) else 0.0)
    highest = prior * max_factor
    seen: dict[float, float] = {}

    def evaluate(values: list[float]) -> None:
        values = [v for v in values if v not in seen]
        if values:
            for v, ll in zip(values, neg2ll(values), strict=True):
                seen[v] = ll if math.isfinite(ll) else math.inf

    def best() -> float:
        # ties: the value nearest the prior (no evidence, no move)
        return min(seen, key=lambda v: (seen[v], abs(math.log(v / prior))))

    down = prior / 2.0
    evaluate([prior] + ([down] if down >= lowest else []))
    if best() < prior:  # the drive's kinematics are cleaner than the prior says: walk down
        v = down
        while best() == v and v / 2.0 >= lowest:
            evaluate([c for c in (v / 2.0, v / 4.0) if c >= lowest])
            v = min(seen)
    else:  # the prior or more: walk up
        v = prior
        while best() == v and v * 2.0 <= highest:
            evaluate([c for c in (v * 2.0, v * 4.0) if c <= highest])
            v = max(seen)
    chosen = best()
    ref = seen[chosen]
    tried = tuple((v, seen[v] - ref) for v in seen)
    return NoiseChoice(value=chosen, prior=prior, tried=tried, unit=unit)
