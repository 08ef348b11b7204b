"""The scale benchmark's growth exponent (the benchmark itself is run by `make bench-scale`, not by tests)."""

import numpy as np

from tzsl.benchmarks.bench_scale import growth_exponent


def test_growth_exponent_is_the_log_log_slope_above_4k():
    sizes = np.array([1_000, 4_000, 16_000, 64_000])
    assert abs(growth_exponent(sizes, 3.0 * sizes**1.1) - 1.1) < 1e-9
    assert abs(growth_exponent(sizes, np.where(sizes < 4_000, 1e6, sizes**2.0)) - 2.0) < 1e-9  # 1k is left out
    assert np.isnan(growth_exponent([1_000, 4_000], [1.0, 2.0]))


def test_goal_line_reads_each_worker_against_the_goals():
    from tzsl.benchmarks.bench_scale import WALL_GOAL_S, WORKER_MEMORY_GOAL_GB, goal_line

    low, high = WORKER_MEMORY_GOAL_GB / 2, WORKER_MEMORY_GOAL_GB * 2
    met = goal_line(1_000_000, WALL_GOAL_S / 2, [low, low])
    assert "NOT" not in met and "wall" in met and "SIMULATED" in met
    assert "memory per worker" in goal_line(1_000_000, WALL_GOAL_S * 2, [low, high]).split("NOT met")[0]
    assert goal_line(1_000_000, WALL_GOAL_S * 2, [low, low]).count("NOT met") == 1  # the wall only
    assert "wall" not in goal_line(100_000, WALL_GOAL_S * 2, [low, low])  # the wall goal is for a million trials


def test_benchmark_runs_dap_and_eszsl_unless_dap_only():
    """Issue 33's scale benchmark is DAP + ESZSL (the method comparison, with calibrated posteriors)."""
    import tomllib

    from tzsl.benchmarks.bench_scale import _TOML

    fields = dict(n=10, plain="p", seed=0, n_jobs=2, backend="loky", scheduler="", out="o")
    assert tomllib.loads(_TOML.format(**fields, eszsl="true"))["methods"]["eszsl"] is True
    assert tomllib.loads(_TOML.format(**fields, eszsl="false"))["methods"]["eszsl"] is False
