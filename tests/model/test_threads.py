"""The batched solver runs with one BLAS thread and leaves the caller's thread counts alone."""

import os

import numpy as np
import pytest
from threadpoolctl import threadpool_info, threadpool_limits

import rigval.model as rm
from rigval.acquisition.threads import single_blas_thread


def blas_threads():
    return {lib["filepath"]: lib["num_threads"] for lib in threadpool_info()
            if lib["user_api"] == "blas"}


@pytest.fixture
def two_threads():
    """Every BLAS library at 2 threads (the machine default here), restored afterwards."""
    with threadpool_limits(2, user_api="blas"):
        yield blas_threads()


def test_one_thread_inside_and_restored_after(two_threads):
    assert two_threads and all(n == 2 for n in two_threads.values())
    with single_blas_thread():
        assert set(blas_threads().values()) == {1}
    assert blas_threads() == two_threads


def test_restored_after_an_exception(two_threads):
    with pytest.raises(ZeroDivisionError), single_blas_thread():
        assert set(blas_threads().values()) == {1}
        _ = 1 / 0
    assert blas_threads() == two_threads


def test_solve_runs_with_one_thread_and_restores(two_threads, monkeypatch):
    import rigval.model.solver as solver

    seen = []
    original = solver._solve_chunk

    def spy(*args, **kwargs):
        seen.append(set(blas_threads().values()))
        return original(*args, **kwargs)

    monkeypatch.setattr(solver, "_solve_chunk", spy)
    mech = rm.load_mechanism(rm.builtin_mechanism("pendulum"))
    t = np.linspace(0.0, 0.1, 50)
    limited = rm.solve(mech, t, outputs=["driver_torque"])
    assert seen and all(s == {1} for s in seen)
    assert blas_threads() == two_threads
    # Same numbers whatever the thread count (one step-by-step solve as the reference).
    reference = rm.solve_stepwise(mech, t[[0, -1]])
    np.testing.assert_allclose(limited["driver_torque"].to_numpy()[[0, -1]],
                               reference["driver_torque"].to_numpy(), rtol=1e-10, atol=1e-9)


def test_solve_fills_its_arrays_without_huge_page_requests(monkeypatch):
    import rigval.model.solver as solver
    from rigval.acquisition.hugepages import _switch

    switch = _switch()
    if switch is None or "NUMPY_MADVISE_HUGEPAGE" in os.environ:
        pytest.skip("this numpy has no huge-page switch, or the user set it")
    seen = []
    original = solver._solve_chunk

    def spy(*args, **kwargs):
        state = switch(False)  # returns the state it replaces
        switch(state)
        seen.append(state)
        return original(*args, **kwargs)

    monkeypatch.setattr(solver, "_solve_chunk", spy)
    before = switch(True)
    try:
        mech = rm.load_mechanism(rm.builtin_mechanism("pendulum"))
        rm.solve(mech, np.linspace(0.0, 0.1, 50), outputs=["driver_torque"])
        after = switch(True)
    finally:
        switch(before)
    assert seen and not any(seen)
    assert after is True  # restored
