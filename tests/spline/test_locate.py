"""Vectorised point location: inside, on edges and vertices, outside, holes, slivers."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from trispline.spline.testing import domains
from trispline.spline.errors import InputError
from trispline.spline.locate import Locator, OutsideDomainError, locate
from trispline.spline.topology import Triangulation

from triangulations import SMALL_DOMAINS as DOMAINS



def _brute_inside(uv, faces, pts, tol=1e-9):
    """(n,) bool: the point lies in some face (closed), by testing every face."""
    t = uv[faces]
    p = pts[:, None, :]
    a = t[None, :, [1, 2, 0]] - p[:, :, None, :]
    b = t[None, :, [2, 0, 1]] - p[:, :, None, :]
    cross = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    area2 = Triangulation(uv, faces).areas * 2
    return ((cross / area2[None, :, None]).min(2) >= -tol).any(1)


def _check_found(uv, faces, pts, fidx, bary):
    ok = fidx >= 0
    rec = np.einsum("nk,nkc->nc", bary[ok], uv[faces[fidx[ok]]])
    np.testing.assert_allclose(rec, pts[ok], atol=1e-12 * (1 + np.abs(uv).max()))
    np.testing.assert_allclose(bary[ok].sum(1), 1.0, atol=1e-12)
    assert (bary[ok] >= -1e-10).all()
    assert np.isnan(bary[~ok]).all()


@settings(max_examples=30, deadline=None)
@given(name=st.sampled_from(sorted(DOMAINS)), seed=st.integers(0, 1000))
def test_locate_random_points_matches_brute_force(name, seed):
    uv, faces = DOMAINS[name](seed)
    rng = np.random.default_rng(seed)
    lo, hi = uv.min(0), uv.max(0)
    pad = 0.1 * (hi - lo)
    pts = rng.uniform(lo - pad, hi + pad, (300, 2))
    fidx, bary = locate(uv, faces, pts)
    _check_found(uv, faces, pts, fidx, bary)
    inside = _brute_inside(uv, faces, pts)
    strictly_in = _brute_inside(uv, faces, pts, tol=-1e-9)  # robustly inside
    strictly_out = ~_brute_inside(uv, faces, pts, tol=1e-7)
    assert (fidx[strictly_in] >= 0).all()
    assert (fidx[strictly_out] < 0).all()
    assert ((fidx >= 0) <= inside).all()


@settings(max_examples=20, deadline=None)
@given(name=st.sampled_from(sorted(DOMAINS)), seed=st.integers(0, 1000))
def test_points_on_vertices_and_edges_are_found(name, seed):
    uv, faces = DOMAINS[name](seed)
    tri = Triangulation(uv, faces)
    t = np.random.default_rng(seed).uniform(0, 1, tri.n_edges)[:, None]
    a, b = uv[tri.edges[:, 0]], uv[tri.edges[:, 1]]
    pts = np.concatenate([uv, (1 - t) * a + t * b, 0.5 * (a + b)])
    fidx, bary = locate(uv, faces, pts)
    assert (fidx >= 0).all(), f"missed {np.flatnonzero(fidx < 0)[:5]}"
    _check_found(uv, faces, pts, fidx, bary)
    # a domain vertex is found in a face that uses it, with bary one-hot
    nv = uv.shape[0]
    assert (faces[fidx[:nv]] == np.arange(nv)[:, None]).any(1).all()


def test_points_in_holes_are_outside():
    uv, faces = domains.annulus(3, 24, r0=0.4, r1=1.0)
    pts = np.array([[0.0, 0.0], [0.1, 0.05], [0.7, 0.0], [2.0, 2.0]])
    fidx, _ = locate(uv, faces, pts)
    assert fidx[0] == -1 and fidx[1] == -1 and fidx[2] >= 0 and fidx[3] == -1


def test_strict_raises_with_indices():
    uv, faces = domains.grid(3)
    pts = np.array([[0.5, 0.5], [1.5, 0.5], [-1.0, 0.0]])
    with pytest.raises(OutsideDomainError, match=r"2 \(first: 1, 2\)"):
        locate(uv, faces, pts, strict=True)
    assert issubclass(OutsideDomainError, InputError)


def test_bad_queries_raise():
    uv, faces = domains.grid(2)
    with pytest.raises(InputError, match="points must have shape"):
        locate(uv, faces, np.zeros((3, 3)))
    with pytest.raises(InputError, match="non-finite"):
        locate(uv, faces, np.array([[0.1, np.nan]]))
    with pytest.raises(InputError, match="faces must have shape"):
        Locator(uv, np.zeros((0, 3), int))


def test_locator_reuse_and_chunks_agree():
    uv, faces = domains.random_delaunay(200, holes=1, seed=3)
    pts = np.random.default_rng(0).uniform(0, 1, (5000, 2))
    loc = Locator(uv, faces)
    f1, b1 = loc(pts)
    f2, b2 = loc(pts, chunk=777)
    np.testing.assert_array_equal(f1, f2)
    np.testing.assert_array_equal(b1, b2)


def test_one_huge_face_among_tiny_ones():
    """Cell size is capped: a big face must still be found everywhere it covers."""
    uv, faces = domains.grid(30)
    uv = uv.copy()
    far = np.array([[3.0, 0.0]])
    uv2 = np.concatenate([uv, far])
    big = np.array([[30, len(uv), 30 * 31 + 30]])  # (1,0) -> (3,0) -> (1,1)
    faces2 = np.concatenate([faces, big])
    pts = np.array([[2.0, 0.3], [1.5, 0.1], [2.9, 0.01]])
    fidx, bary = locate(uv2, faces2, pts)
    assert (fidx == faces.shape[0]).all()
    _check_found(uv2, faces2, pts, fidx, bary)
