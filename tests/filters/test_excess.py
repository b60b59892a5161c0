"""The innovation power a filter's S does not explain (sideslip.filters.excess)."""

from __future__ import annotations

import numpy as np
import pytest

from sideslip.filters.excess import excess_innovation_variance


def _innovations(n: int, sigma: float, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """100 Hz rows, an innovation every tenth row (10 Hz, NaN between), variance sigma^2."""
    t = np.arange(n) * 0.01
    rng = np.random.default_rng(seed)
    nu = np.full(n, np.nan)
    nu[::10] = sigma * rng.standard_normal(nu[::10].size)
    return t, nu, np.full(n, sigma**2)


def test_a_bias_the_model_misses_comes_back_as_its_square() -> None:
    """White innovations of variance S plus a bias b: E[nu^2] - S = b^2.  A 2 s window holds
    20 innovations, so the windowed mean of nu^2 scatters by S sqrt(2 / 20) + 2 b sigma /
    sqrt(20) around it; the median over the drive is within 15 % of b^2 (b = 3 sigma)."""
    t, nu, s = _innovations(60_000, 0.01)
    b = 0.03
    excess = excess_innovation_variance(t, nu + b, s, np.ones(t.size, dtype=bool))
    assert np.median(excess) == pytest.approx(b**2, rel=0.15)


def test_rows_the_nis_test_passes_get_nothing_and_a_consistent_filter_little() -> None:
    """Unflagged rows: 0 whatever the innovations.  Flagged rows of a consistent filter: only
    the positive part of the mean's scatter, whose median is below S / 4 (the scatter's
    1-sigma is S sqrt(2 / 20) = 0.32 S; its positive half has median ~0.22 S)."""
    t, nu, s = _innovations(60_000, 0.01)
    flagged = np.zeros(t.size, dtype=bool)
    flagged[30_000:] = True
    excess = excess_innovation_variance(t, nu + 0.05, s, flagged)
    assert not excess[:30_000].any()
    consistent = excess_innovation_variance(t, nu, s, np.ones(t.size, dtype=bool))
    assert np.median(consistent) < 0.25 * s[0]
    assert np.all(consistent >= 0.0)


def test_the_causal_window_does_not_read_ahead() -> None:
    """A bias from 30 s on: the trailing window sees nothing before 30 s, the centred one
    sees it up to half a window (1 s) earlier: from 29.5 s on, at least a quarter of its
    innovations carry the bias (excess >= b^2 / 4 less the noise's scatter, S = b^2 / 25)."""
    t, nu, s = _innovations(6_000, 0.01)
    nu = np.where(t >= 30.0, nu + 0.05, nu)
    every = np.ones(t.size, dtype=bool)
    trailing = excess_innovation_variance(t, nu, s, every, causal=True)
    centred = excess_innovation_variance(t, nu, s, every)
    before = (t > 29.5) & (t < 29.95)
    assert trailing[before].max() < 0.1 * 0.05**2
    assert centred[before].min() > 0.2 * 0.05**2


def test_shape_and_window_errors_say_what_is_wrong() -> None:
    t, nu, s = _innovations(100, 0.01)
    with pytest.raises(ValueError, match="one shape"):
        excess_innovation_variance(t, nu[:-1], s, np.ones(100, dtype=bool))
    with pytest.raises(ValueError, match="window_s must be positive"):
        excess_innovation_variance(t, nu, s, np.ones(100, dtype=bool), window_s=0.0)
