"""The scale benchmark's growth exponent (the benchmark itself is run by `make bench-scale`, not by tests)."""

import numpy as np

from tzsl.benchmarks.bench_scale import growth_exponent


def test_growth_exponent_is_the_log_log_slope_above_4k():
    sizes = np.array([1_000, 4_000, 16_000, 64_000])
    assert abs(growth_exponent(sizes, 3.0 * sizes**1.1) - 1.1) < 1e-9
    assert abs(growth_exponent(sizes, np.where(sizes < 4_000, 1e6, sizes**2.0)) - 2.0) < 1e-9  # 1k is left out
    assert np.isnan(growth_exponent([1_000, 4_000], [1.0, 2.0]))
