"""Progress inside one long library call: PARDISO's numerical factorisation reports the share of its factor
written (pages first touched by its threads), polled from the calling thread (issue 19's live progress)."""
from __future__ import annotations

import importlib.util
import mmap
import threading

import numpy as np
import pytest
import scipy.sparse as sp

from trispline.fit import progress
from trispline.fit.progress import watching
from trispline.fit.solve import SparseCholesky
from trispline.spline.util.memory import page_size, thread_page_faults

HAS_PARDISO = importlib.util.find_spec("pypardiso") is not None


def test_watching_reports_rising_fractions_below_one_from_the_calling_thread(monkeypatch):
    monkeypatch.setattr(progress, "WATCH_INTERVAL", 0.001)
    go = threading.Event()
    polls = iter(np.r_[0.1, 0.1, 0.05, np.linspace(0.2, 1.5, 30)])  # a fall and an overshoot
    seen, threads = [], set()

    def done() -> float:
        value = next(polls, 1.5)
        if value >= 1.5:
            go.set()
        return float(value)

    def report(fraction: float) -> None:
        seen.append(fraction)
        threads.add(threading.get_ident())

    assert watching(lambda: go.wait(10) and "result", done, report) == "result"
    assert len(seen) >= 3 and np.all(np.diff(seen) > 0) and max(seen) == 0.99
    assert threads == {threading.get_ident()}


def test_watching_reraises_the_work_s_error_and_runs_plainly_without_a_report():
    def fail() -> None:
        raise np.linalg.LinAlgError("not positive definite")

    with pytest.raises(np.linalg.LinAlgError, match="not positive definite"):
        watching(fail, lambda: 0.0, lambda f: None)
    caller = []
    watching(lambda: caller.append(threading.get_ident()), lambda: 0.0, None)
    assert caller == [threading.get_ident()]


def test_page_faults_count_the_named_thread_s_first_touches_only():
    size = 64 << 20
    tid: list[int] = []
    ready, go, done, leave = (threading.Event() for _ in range(4))

    def touch() -> None:
        tid.append(threading.get_native_id())
        ready.set()
        go.wait(10)
        buf = mmap.mmap(-1, size)  # mapped, not yet touched
        if hasattr(mmap, "MADV_NOHUGEPAGE"):  # one fault a page even where huge pages are "always"
            buf.madvise(mmap.MADV_NOHUGEPAGE)
        buf[:: page_size()] = b"\1" * (size // page_size())  # one write a page
        buf.close()
        done.set()
        leave.wait(10)  # a thread's count goes with it

    worker = threading.Thread(target=touch)
    worker.start()
    ready.wait(10)
    before, others = thread_page_faults(set(tid)), thread_page_faults({threading.get_native_id()})
    go.set()
    done.wait(10)
    touched = thread_page_faults(set(tid)) - before
    leave.set()
    worker.join()
    assert touched >= 0.9 * size / page_size()
    assert thread_page_faults({threading.get_native_id()}) - others < 0.1 * size / page_size()


@pytest.mark.skipif(not HAS_PARDISO, reason="pypardiso not installed")
def test_pardiso_factorisation_reports_the_share_of_its_factor_written(monkeypatch):
    monkeypatch.setattr(progress, "WATCH_INTERVAL", 0.002)
    m = 500  # a 2D Laplacian of 250k unknowns: ~0.5 s to factor
    T = sp.diags([-1.0, 2.0, -1.0], [-1, 0, 1], (m, m))
    H = (sp.kron(T, sp.eye(m)) + sp.kron(sp.eye(m), T) + 1e-3 * sp.eye(m * m)).tocsr()
    seen: list[float] = []
    factor = SparseCholesky(H, "pardiso", report=seen.append)
    assert seen[0] == 0.5  # the analysis
    during = np.array(seen[1:])
    assert during.size >= 3 and np.all(np.diff(during) > 0) and during.max() < 1.0
    assert during.max() >= 0.75  # the pages counted cover most of the factor's entries
    b = np.ones(m * m)
    np.testing.assert_allclose(H @ factor.solve(b), b, atol=1e-9)


@pytest.mark.skipif(not HAS_PARDISO, reason="pypardiso not installed")
def test_a_failed_factorisation_is_raised_through_the_watch():
    A = sp.csr_matrix(np.array([[1.0, 2.0], [2.0, 1.0]]))  # indefinite
    with pytest.raises(np.linalg.LinAlgError, match="not positive definite"):
        SparseCholesky(A, "pardiso", report=lambda fraction: None)
