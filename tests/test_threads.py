"""tzsl._parallel.one_blas_thread: one BLAS thread inside the block, the former counts restored after it."""

from __future__ import annotations

import numpy as np
from threadpoolctl import threadpool_info, threadpool_limits

from tzsl._parallel import one_blas_thread


def _blas_threads() -> list[int]:
    return [lib["num_threads"] for lib in threadpool_info() if lib["user_api"] == "blas"]


def test_one_blas_thread_limits_and_restores():
    np.ones((2, 2)) @ np.ones((2, 2))  # BLAS loaded
    assert _blas_threads(), "numpy's BLAS is not visible to threadpoolctl"
    with threadpool_limits(limits=2, user_api="blas"):  # a known count to come back to
        before = _blas_threads()
        with one_blas_thread():
            assert _blas_threads() == [1] * len(before)
            with one_blas_thread():  # nested: still one, and the outer block keeps its limit
                assert _blas_threads() == [1] * len(before)
            assert _blas_threads() == [1] * len(before)
        assert _blas_threads() == before


def test_one_blas_thread_keeps_results():
    rng = np.random.default_rng(0)
    X = rng.normal(size=(300, 20))
    expected = np.linalg.svd(X, compute_uv=False)
    with one_blas_thread():
        np.testing.assert_allclose(np.linalg.svd(X, compute_uv=False), expected, rtol=1e-12)
