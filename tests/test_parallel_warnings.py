"""Warnings raised in joblib worker processes reach the parent: shown one line each and recorded."""

from __future__ import annotations

import warnings

from joblib import Parallel, delayed

from tzsl._parallel import one_blas_thread, reissued, relayed
from tzsl._warnings import recorded_warnings
from tzsl.models import GridEdgeWarning


def test_warnings_of_process_workers_are_raised_again_in_the_parent():
    # the job is warnings.warn itself (importable in a worker; test modules are not)
    jobs = [delayed(relayed(warnings.warn))(f"job {i}", GridEdgeWarning) for i in range(3)]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with recorded_warnings() as log:
            out = [reissued(r) for r in Parallel(n_jobs=2, backend="loky")(jobs)]
    assert out == [None, None, None]
    assert sorted(str(w.message) for w in caught if w.category is GridEdgeWarning) == ["job 0", "job 1", "job 2"]
    assert sorted(log.lines) == [f"job {i} (GridEdgeWarning)" for i in range(3)]


def test_a_job_without_warnings_returns_its_result_unchanged():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert reissued(relayed(sorted)([3, 1, 2])) == [1, 2, 3]


def test_one_blas_thread_limits_blas_in_the_block_and_restores_it():
    import numpy  # noqa: F401 - its BLAS is loaded
    from threadpoolctl import threadpool_info

    def blas_threads() -> list[int]:
        return [lib["num_threads"] for lib in threadpool_info() if lib["user_api"] == "blas"]

    before = blas_threads()
    assert before  # a BLAS library is there to limit
    with one_blas_thread():
        assert set(blas_threads()) == {1}
        with one_blas_thread():  # nested, as a fit inside a limited block
            assert set(blas_threads()) == {1}
        assert set(blas_threads()) == {1}
    assert blas_threads() == before
