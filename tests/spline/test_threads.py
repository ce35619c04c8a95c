"""Helpers that split large arrays over threads: same results as the one-call numpy/scipy forms."""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
import scipy.sparse as sp

from trispline.spline.util import memory as _memory, parallel as _parallel, sparse as _sparse


@pytest.mark.parametrize("n, chunk", [(0, 3), (1, 3), (10, 3), (12, 4), (5, 100)])
def test_ranges_cover_once_in_order(n, chunk):
    r = _parallel.ranges(n, chunk)
    covered = [i for lo, hi in r for i in range(lo, hi)]
    assert covered == list(range(n))
    assert all(0 < hi - lo <= chunk for lo, hi in r)


def test_once_computes_one_value_for_all_threads_and_retries_after_an_error():
    import threading
    import time

    calls = []

    def make():
        calls.append(threading.get_ident())
        time.sleep(0.05)  # the other threads arrive meanwhile and must wait, not compute again
        return object()

    get = _parallel.once(make)
    got = []
    threads = [threading.Thread(target=lambda: got.append(get())) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert len(calls) == 1 and len(got) == 4 and all(g is got[0] for g in got) and get() is got[0]

    tries = []

    def flaky():
        tries.append(1)
        if len(tries) == 1:
            raise RuntimeError("first try")
        return 7

    get = _parallel.once(flaky)
    with pytest.raises(RuntimeError, match="first try"):
        get()
    assert get() == 7 and get() == 7 and len(tries) == 2


def test_workers_map_returns_in_order_and_raises(monkeypatch):
    monkeypatch.setattr(_parallel, "PARALLEL_MIN", 1)
    with _parallel.Workers(100) as work:
        assert work.map(lambda lo, hi: (lo, hi), 10, chunk=3) == [(0, 3), (3, 6), (6, 9), (9, 10)]
        assert work.submit(sum, [1, 2]).result() == 3

        def boom(lo, hi):
            raise RuntimeError(f"range {lo}")

        with pytest.raises(RuntimeError, match="range"):
            work.map(boom, 10, chunk=2)


@pytest.mark.parametrize("threaded", [False, True])
def test_workers_start_offsets_chunks_and_thresholds(threaded):
    """``start`` queues every range (shifted by ``offset``) and re-raises through ``result``;
    ``chunk`` gives at least two ranges per thread; ``parallel_min`` decides threading."""
    def boom(lo: int, hi: int) -> int:
        if lo == 2:
            raise RuntimeError(f"range {lo}")
        return lo

    with _parallel.Workers(10, parallel_min=1 if threaded else 11) as work:
        if not threaded:
            assert work.threads == 1
        jobs = work.start(lambda lo, hi: (lo, hi), 7, chunk=3, offset=100)
        assert [j.result() for j in jobs] == [(100, 103), (103, 106), (106, 107)]
        step = work.chunk(1000, 300)
        assert step <= 300 and len(_parallel.ranges(1000, step)) >= 2 * work.threads
        with pytest.raises(RuntimeError, match="range 2"):  # inline at the start, threaded at its result
            for job in work.start(boom, 4, chunk=2):
                job.result()


def test_serial_blas_holds_blas_to_one_thread_and_restores_it():
    from threadpoolctl import threadpool_info

    def blas_threads():
        return [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]

    before = blas_threads()
    with _parallel.Workers(10, parallel_min=1, serial_blas=True) as work:
        inside = blas_threads()
        if work.threads > 1:
            assert all(n == 1 for n in inside)
    assert blas_threads() == before


@pytest.mark.parametrize("value, dtype", [(0, np.float64), (-1, np.int32), (True, bool), (2.5, np.float32)])
def test_full_fills_large_and_small_arrays(monkeypatch, value, dtype):
    monkeypatch.setattr(_parallel, "PARALLEL_MIN", 1)
    for nbytes_limit in (_memory.PREFAULT_BYTES, 1):  # small path, then the threaded fill
        monkeypatch.setattr(_memory, "PREFAULT_BYTES", nbytes_limit)
        a = _memory.full((37, 5), value, dtype)
        assert a.dtype == dtype and a.shape == (37, 5)
        np.testing.assert_array_equal(a, np.full((37, 5), value, dtype))
    assert not _memory.empty(1000).any()


@pytest.mark.parametrize("d", [1, 3, 4])
def test_threaded_matmul_is_bit_identical_to_scipy(monkeypatch, d):
    rng = np.random.default_rng(d)
    M = sp.csr_array(sp.random(503, 211, density=0.03, format="csr", random_state=rng))
    x = rng.normal(size=(211, d))
    expected = M @ x
    monkeypatch.setattr(_parallel, "PARALLEL_MIN", 1)
    monkeypatch.setattr(_parallel, "CHUNK", 17)
    monkeypatch.setattr(_sparse, "THREADED_NNZ", 0)
    got = _sparse.matmul(M, x)
    assert got.shape == expected.shape
    np.testing.assert_array_equal(got, expected)
    np.testing.assert_array_equal(_sparse.matmul(M, x[:, 0]), M @ x[:, 0])  # 1-D: scipy's own path


@pytest.mark.parametrize("mode", ["scipy", "kernel inline", "kernel threaded"])
def test_row_range_products_equal_scipy_on_the_slice(monkeypatch, mode):
    rng = np.random.default_rng(7)
    M = sp.csr_array(sp.random(400, 150, density=0.05, format="csr", random_state=rng))
    x = rng.normal(size=(150, 3))
    if mode != "scipy":  # large-matrix path: ranges of rows through scipy's kernel, inline on one core
        monkeypatch.setattr(_parallel, "PARALLEL_MIN", 1 if mode == "kernel threaded" else 10**9)
        monkeypatch.setattr(_parallel, "CHUNK", 11)
        monkeypatch.setattr(_sparse, "THREADED_NNZ", 0)
    for lo, hi in [(0, 400), (0, 1), (37, 230), (399, 400), (5, 5)]:
        np.testing.assert_array_equal(_sparse.matmul(M, x, rows=(lo, hi)), M[lo:hi] @ x)
        out = np.full((hi - lo, 3), np.nan)  # overwritten, not accumulated into
        _sparse.rows_into(M, x.reshape(-1), lo, hi, out)
        np.testing.assert_array_equal(out, M[lo:hi] @ x)
    with pytest.raises(ValueError, match="contiguous"):
        _sparse.rows_into(M, x.reshape(-1), 0, 4, np.empty((3, 4)).T)


def test_threaded_sort_indices_equals_scipy(monkeypatch):
    rng = np.random.default_rng(5)
    n, per_row = 300, 6
    indptr = np.arange(0, n * per_row + 1, per_row, dtype=np.int32)
    indices = np.concatenate([rng.permutation(40)[:per_row] for _ in range(n)]).astype(np.int32)
    data = rng.normal(size=indices.size)
    expected = sp.csr_array((data.copy(), indices.copy(), indptr.copy()), shape=(n, 40))
    expected.sort_indices()
    monkeypatch.setattr(_parallel, "PARALLEL_MIN", 1)
    monkeypatch.setattr(_parallel, "CHUNK", 13)
    monkeypatch.setattr(_sparse, "THREADED_NNZ", 0)
    M = sp.csr_array((data, indices, indptr), shape=(n, 40))
    assert not M.has_sorted_indices
    with _parallel.Workers(n) as work:
        _sparse.sort_indices(M, work)
    assert M.has_sorted_indices
    np.testing.assert_array_equal(M.indices, expected.indices)
    np.testing.assert_array_equal(M.data, expected.data)


def test_gathers_equal_fancy_indexing():
    """``_gather.rows`` / ``at`` are numpy's fancy indexing, only faster: same values, shapes, dtypes."""
    from trispline.spline.util import gather as _gather

    rng = np.random.default_rng(3)
    for a in (rng.normal(size=(50, 2)), rng.integers(-9, 9, size=(50, 4)), rng.normal(size=(50, 21, 3))):
        for idx in (rng.integers(0, 50, 17), rng.integers(-50, 50, (4, 6)), np.zeros(0, np.int64)):
            got = _gather.rows(a, idx)
            assert got.dtype == a.dtype
            np.testing.assert_array_equal(got, a[idx])
    F = rng.integers(0, 100, size=(40, 3))
    i, j = rng.integers(0, 40, 25), rng.integers(0, 3, 25)
    np.testing.assert_array_equal(_gather.at(F, i, j), F[i, j])
    np.testing.assert_array_equal(_gather.at(F, i.reshape(5, 5), 2), F[i.reshape(5, 5), 2])
    with pytest.raises(IndexError):
        _gather.rows(F, np.array([40]))


def test_serial_blas_also_holds_a_blas_loaded_after_its_first_use():
    """MKL (through pypardiso) loads after the first tessellation in a fit: it must be held too."""
    pytest.importorskip("pypardiso")
    code = (
        "from threadpoolctl import threadpool_info\n"
        "from trispline.spline.util.parallel import single_threaded_blas\n"
        "with single_threaded_blas(): pass\n"
        "import pypardiso\n"
        "with single_threaded_blas():\n"
        "    print(max(i['num_threads'] for i in threadpool_info() if i['user_api'] == 'blas'))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True)
    assert out.stdout.split() == ["1"]
