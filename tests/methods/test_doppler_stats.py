"""Honest 1-sigmas: Student-t factor, block jackknife (doppler_stats)."""

from __future__ import annotations

import numpy as np
import pytest

from sideslip.methods.doppler_stats import block_jackknife_std, honest_std, t_factor, time_blocks


def test_t_factor_matches_the_student_quantiles() -> None:
    # t_1(0.8413) = 1.8373, t_4 = 1.1417, large dof -> 1 (Gaussian)
    assert t_factor(1) == pytest.approx(1.8373, abs=1e-3)
    assert t_factor(4) == pytest.approx(1.1417, abs=1e-3)
    assert t_factor(10_000) == pytest.approx(1.0, abs=1e-3)


def test_block_jackknife_of_a_mean_is_the_standard_error_of_the_block_means() -> None:
    # 40 blocks of 50 samples sharing a block offset (correlated within a block): the
    # jackknife of the mean equals the standard error of the block means, which the naive
    # sigma / sqrt(n) underestimates by ~sqrt(50)
    rng = np.random.default_rng(1)
    t = np.arange(2000) * 0.2  # 10 s blocks of 50 samples
    x = np.repeat(rng.standard_normal(40), 50) + 0.01 * rng.standard_normal(2000)
    labels = time_blocks(t, 10.0)
    assert np.unique(labels).size == 40
    jack = block_jackknife_std(labels, lambda m: float(np.mean(x[m])))
    means = x.reshape(40, 50).mean(axis=1)
    assert jack == pytest.approx(np.std(means, ddof=1) / np.sqrt(40), rel=1e-6)
    assert jack > 5.0 * np.std(x) / np.sqrt(x.size)


def test_too_few_blocks_or_a_failed_fit_give_inf_and_honest_std_takes_the_larger() -> None:
    labels = np.array([0, 0, 1, 1, 2, 2])
    assert block_jackknife_std(labels, lambda m: 1.0) == np.inf
    assert block_jackknife_std(np.arange(6), lambda m: np.nan) == np.inf
    assert honest_std(0.1, 4, np.inf) == pytest.approx(0.1 * t_factor(4))
    assert honest_std(0.1, 1000, 0.5) == 0.5


def test_jackknife_from_block_sums_equals_refitting_without_each_block() -> None:
    """The O(n) form (leave-one-block-out sums) gives the generic jackknife's value, for a
    slope through the origin and a centred slope (same estimator, only round-off apart)."""
    from sideslip.methods.doppler_stats import block_jackknife_sums_std, ratio_of_sums

    rng = np.random.default_rng(4)
    t = np.sort(rng.uniform(0.0, 600.0, 3000))
    x = rng.normal(1.0, 2.0, t.size)
    y = 0.3 * x + 0.1 + rng.standard_normal(t.size) * (0.2 + 0.1 * np.sin(t / 30.0))
    labels = time_blocks(t, 20.0)

    def through_origin(mask: np.ndarray) -> float:
        return float(np.sum(x[mask] * y[mask]) / np.sum(x[mask] ** 2))

    def centred(mask: np.ndarray) -> float:
        xm, ym = x[mask], y[mask]
        return float(np.sum((xm - xm.mean()) * (ym - ym.mean())) / np.sum((xm - xm.mean()) ** 2))

    def centred_sums(loo: np.ndarray) -> np.ndarray:
        n, sx, sy, sxx, sxy = loo
        return (sxy - sx * sy / n) / (sxx - sx * sx / n)

    generic = block_jackknife_std(labels, through_origin)
    fast = block_jackknife_sums_std(labels, np.stack([x * y, x * x]), ratio_of_sums)
    assert fast == pytest.approx(generic, rel=1e-9)
    cols = np.stack([np.ones_like(x), x, y, x * x, x * y])
    assert block_jackknife_sums_std(labels, cols, centred_sums) == pytest.approx(
        block_jackknife_std(labels, centred), rel=1e-9)
    # too few blocks: inf, as the generic form
    assert block_jackknife_sums_std(np.zeros(t.size, dtype=np.intp), cols, centred_sums) == np.inf
