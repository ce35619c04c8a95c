"""Smoothing of a planar map: each vertex's uv replaced by a local polynomial fit of its neighbours'.

    uv2, info = smooth_uv(V, F, uv, loops)     # (nv, 2) fold-free; info: counts of what moved

Why: a discrete map such as LSCM is the exact optimum of a discrete energy, not a sample
of a smooth map. Its uv sits 0.05-0.2% of an edge off a smooth local fit, irregularly from
vertex to vertex and shrinking only like the edge length; a spline that interpolates the
mesh over such a domain bends to follow the irregularity, which costs accuracy (issue 17).
The smooth map under it is recovered by local regression:

* an **interior vertex** takes the value, at its own position, of the weighted least-squares
  polynomial (degree :data:`DEGREE`, lower where the neighbourhood cannot support it) of uv
  as a function of position on the surface over its :data:`RINGS`-ring, in the principal
  plane of the neighbourhood (coordinates in units of the vertex's mean edge length,
  Gaussian weights of width :data:`WIDTH`);
* a **boundary vertex** stays on the outline: it takes the value of the same kind of fit
  along its boundary loop (uv as a function of 3D arc length over :data:`BOUNDARY_REACH`
  vertices each side), which never reaches across a corner of the outline (a turn of more
  than :data:`~trispline.spline.tolerances.SMOOTH_CORNER_DEGREES`); corners keep their uv.

Each fit is a fixed linear combination of the neighbours' old uv, so a map that is a
polynomial of the fit's degree in the local coordinates (a similarity, an affine map) is
reproduced exactly. All vertices are fitted together, in chunks of batched small solves.

One such pass keeps about half of a vertex-to-vertex jitter. By default (``method="global"``,
:data:`METHOD`) the pass is followed by sparse solves for the map nearest it whose fits'
residuals ``(I - S) uv`` are small (``S``: the fits as a matrix): each boundary loop alone
along itself (corners held; a vertex it would move too far keeps the pass's uv), then the
interior with the outline held. A map the fits reproduce has no residual and comes back as it
was. Where the solved map folds a face, the pass's map is used instead.

The result is checked with :func:`~trispline.param.distortion.fold_mask`: the vertices of a
folded face take back their old uv (a few rounds); if folds remain, the map is returned
unchanged.
"""
from __future__ import annotations


import numpy as np
import scipy.sparse as sp

from trispline.spline.tolerances import SMOOTH_CORNER_DEGREES, SMOOTH_RCOND
from trispline.spline.util import gather
from trispline.spline.util.parallel import Workers, ranges
from trispline.spline.util.spd import solve_spd

from .distortion import fold_mask
from .tables import ring_step, undirected_edges

__all__ = ["DEGREE", "RINGS", "WIDTH", "BOUNDARY_REACH", "BOUNDARY_MAX_MOVE", "METHOD", "GLOBAL_WEIGHT",
           "GLOBAL_MAX_VERTICES", "fit_weights", "loop_corners", "smooth_uv"]

#: Degree of the local polynomial fits (measured in docs/param.md: 3 removes the
#: irregularity without a bias of its own; 2 leaves an ``O(h^3)`` one).
DEGREE = 3
#: Neighbourhood of an interior vertex's fit, in rings of edges.
RINGS = 2
#: Width of the Gaussian weights, in the vertex's mean edge lengths.
WIDTH = 2.0
#: Boundary vertices each side in a boundary vertex's fit.
BOUNDARY_REACH = 3
#: Whether the fits along a boundary loop read its 3D arc length from circles through each vertex and its
#: neighbours (:func:`_arc_lengths`) rather than from the chords.
ARC_LENGTH = True
#: At most this many neighbours (the nearest) in an interior fit.
MAX_NEIGHBOURS = 40
#: A boundary vertex whose fit along its loop would move it by more than this fraction of its
#: mean uv edge keeps its uv: the map's irregularity is 0.05-0.2% of an edge (at most 2.9% on the
#: analytic surfaces' outlines), a larger move reshapes the outline (the bumps scan with a hole:
#: a few outline vertices moved 8-13% of an edge: error 5.0e-7 unsmoothed, 1.45e-6; capped 4.6e-7).
BOUNDARY_MAX_MOVE = 0.03
#: Rounds of interior fits, each from the last one's map (measured in docs/fit.md, "The boundary":
#: 3 were more accurate on 22 of 24 analytic cases, up to 1.9x, but gave the camel head 4 patches above
#: 20x the data's largest curvature; so one).
PASSES = 1
#: How :func:`smooth_uv` smooths by default: ``"global"``, the map nearest the one-pass map whose fits'
#: residuals ``(I - S) uv`` are :data:`GLOBAL_WEIGHT` (:data:`GLOBAL_OUTLINE_WEIGHT` along the loops)
#: times more costly (sparse solves: each loop alone, then the interior with the outline held), or
#: ``"local"``, :data:`PASSES` rounds of the fits. Measured in docs/param.md ("The global solve"): the
#: global map won 21 of the 24 analytic cases of ``bench_accuracy3d.py`` (torus 3,229 11x -> 2.5x its
#: true-uv fit's error, cap 3,205 1.9x -> 0.63x, Enneper 3,205 25x -> 7.9x).
METHOD = "global"
#: Weight of the interior fits' residuals against the distance to the one-pass map (100: torus 812
#: 2.15e-6 against 2.46e-6 at 10, 2.26e-6 at 1,000, 2.57e-6 at 1e6; Enneper 3,205 best at 100 too).
GLOBAL_WEIGHT = 100.0
#: The same weight for each boundary loop's fits along it, solved first (the loop alone; kept only where
#: it moves no vertex more than :data:`BOUNDARY_MAX_MOVE`: the monkey saddle's outline at 798 vertices
#: moved up to 8% of an edge, and capping vertex by vertex made the fit 5.9x worse).
GLOBAL_OUTLINE_WEIGHT = 100.0
#: Above this many vertices the default is ``"local"``: the solve's matrix couples 4-rings (60
#: entries a row), 4.9 s at 20k vertices under load 9 (PARDISO; CHOLMOD 18 s), against 1.5 s for a pass;
#: at 49k vertices (a 100k-face scan, load 5) 2.6 s, the harmonic map's parameterization 1.6 -> 6.4 s,
#: which would cost the interpolating fit's and the approximation's speed targets (issues 19, 15).
GLOBAL_MAX_VERTICES = 20_000
#: Unknowns from which the global solve takes PARDISO where installed (``spd_backend``'s
#: ``pardiso_min``): every size, as the matrix's fill makes CHOLMOD 3.6x slower at 20k vertices.
GLOBAL_PARDISO_MIN = 0
#: Rounds of reverting the vertices of folded faces before the map is returned unchanged.
REVERT_ROUNDS = 4
#: Vertices fitted together (about 50 kB each at the largest neighbourhood).
CHUNK = 1 << 13


def _monomials(x: np.ndarray, degree: int) -> np.ndarray:
    """``(..., p)`` monomials of ``x (..., k)`` (``k`` = 1 or 2) up to ``degree``, constant first,
    by degree (``1, x, y, x^2, x y, y^2, ...``)."""
    cols = [np.ones(x.shape[:-1])]
    last = cols
    for _ in range(degree):
        if x.shape[-1] == 1:
            last = [last[0] * x[..., 0]]
        else:  # x times every monomial of the last degree, then y times its last one
            last = [m * x[..., 0] for m in last] + [last[-1] * x[..., 1]]
        cols += last
    return np.stack(cols, -1)


def _n_coef(d: int, dim: int) -> int:
    return d + 1 if dim == 1 else (d + 1) * (d + 2) // 2


def _well_posed(G: np.ndarray) -> np.ndarray:
    """``(n,)`` bool: the normal matrices ``G (n, p, p)`` have ``rcond >= SMOOTH_RCOND``."""
    ev = np.linalg.eigvalsh(G)
    return ev[:, 0] >= SMOOTH_RCOND * np.maximum(ev[:, -1], np.finfo(float).tiny)


def _first_columns(G: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(ok (n,), z (n, p))``: which normal matrices ``G (n, p, p)`` are well posed (:func:`_well_posed`),
    and the first columns of their inverses (zero where not).

    Most pass a cheaper sufficient test first: ``|G|_F |G^-1|_F``, at least the 2-norm condition number,
    at most ``1 / SMOOTH_RCOND`` (an inverse, 5 us a 10 x 10 matrix, against 8 us for its eigenvalues and
    2 us for the solve they guarded: the smoothing's local fits 1.43 -> 1.13 CPU s on 40k vertices of a
    100k-face scan); the rest are judged by their eigenvalues, as before."""
    n, p = G.shape[:2]
    z, ok = np.zeros((n, p)), np.zeros(n, bool)
    try:
        inv = np.linalg.inv(G)
    except np.linalg.LinAlgError:  # an exactly singular one (too few points): every row the exact way
        inv = None
    if inv is not None:
        kappa = np.linalg.norm(G, axis=(1, 2)) * np.linalg.norm(inv, axis=(1, 2))
        ok = np.isfinite(kappa) & (kappa * SMOOTH_RCOND <= 1.0)
        z[ok] = inv[ok, :, 0]
    rest = np.flatnonzero(~ok)
    good = rest[_well_posed(G[rest])] if rest.size else rest
    if good.size:
        e0 = np.zeros((good.size, p, 1))
        e0[:, 0] = 1.0
        z[good] = np.linalg.solve(G[good], e0)[..., 0]
        ok[good] = True
    return ok, z


def fit_weights(x: np.ndarray, w: np.ndarray, degree: int) -> np.ndarray:
    """Weights ``s (n, m)``: ``sum_j s_j y_j`` is the value at 0 of the weighted least-squares
    polynomial through values ``y_j`` at ``x (n, m, k)`` (``k`` = 1 or 2), weights ``w (n, m)``.

    Each row uses the largest degree ``<= degree`` whose normal matrix has a reciprocal
    condition number of at least ``SMOOTH_RCOND`` (its coordinates are O(1)); a row that
    supports not even degree 1 gets all its weight on its first point (the vertex itself).
    """
    dim = x.shape[-1]
    phi = _monomials(x, degree)  # (n, m, p)
    wphi = phi * w[..., None]
    G = np.matmul(wphi.transpose(0, 2, 1), phi)  # (n, p, p)
    out = np.zeros(w.shape)
    out[:, 0] = 1.0
    todo = np.arange(len(w))
    for d in range(degree, 0, -1):
        p = _n_coef(d, dim)
        ok, z = _first_columns(G[todo, :p, :p])
        rows, todo = todo[ok], todo[~ok]
        if rows.size:
            out[rows] = np.matmul(wphi[rows, :, :p], z[ok][..., None])[..., 0]
        if todo.size == 0:
            break
    return out


def _neighbourhoods(V: np.ndarray, F: np.ndarray, rings: int) -> tuple[np.ndarray, np.ndarray]:
    """``(nbr (nv, m), h (nv,))``: each vertex's ``rings``-ring (itself first, -1 padded) and mean edge length."""
    nv = len(V)
    _, edges, _, _ = undirected_edges(F, nv)
    length = np.linalg.norm(V[edges[:, 0]] - V[edges[:, 1]], axis=1)
    deg = np.bincount(edges.ravel(), minlength=nv)
    h = np.bincount(edges.ravel(), np.repeat(length, 2), minlength=nv) / np.maximum(deg, 1)
    step = ring_step(edges, nv)
    R = step
    for _ in range(rings - 1):
        R = R @ step
    R = R.tocsr()
    R.setdiag(0)
    R.eliminate_zeros()
    counts = np.diff(R.indptr)
    nbr = np.full((nv, int(counts.max(initial=0)) + 1), -1, np.int64)
    nbr[:, 0] = np.arange(nv)
    idx, owner = gather.segments(R.indptr[:-1], counts, owner=True)
    nbr[owner, 1 + idx - R.indptr[:-1][owner]] = R.indices
    return nbr, h


def _interior_fits(V: np.ndarray, nbr: np.ndarray, h: np.ndarray, degree: int):
    """Per chunk of :data:`CHUNK` vertices ``(sl, nb, s)``: the slice and :func:`_interior_weights`
    of its vertices (the weights depend on the surface alone, not on the uv they are applied to).

    The chunks run on a thread per core, a batch of two per thread at a time (numpy's batched
    eigen-solves and solves release the GIL; BLAS held to one thread each meanwhile), so at most
    that many chunks' weights are held at once."""
    parts = ranges(len(V), CHUNK)

    def weights(lo: int, hi: int) -> tuple:
        return (slice(lo, hi), *_interior_weights(V, nbr[lo:hi], h[lo:hi], degree))

    with Workers(len(V), parallel_min=2 * CHUNK, serial_blas=True) as work:
        batch = 2 * work.threads
        for i in range(0, len(parts), batch):
            lo, hi = parts[i][0], parts[min(i + batch, len(parts)) - 1][1]
            yield from [job.result() for job in work.start(weights, hi - lo, CHUNK, offset=lo)]


def _interior(uv: np.ndarray, nb: np.ndarray, s: np.ndarray) -> np.ndarray:
    """New uv ``(n, 2)`` of the vertices ``nb[:, 0]``: their fits' weights ``s (n, k)`` over ``uv``."""
    return np.matmul(s[:, None, :], gather.rows(uv, np.maximum(nb, 0)))[:, 0]


def _interior_weights(V: np.ndarray, nbr: np.ndarray, h: np.ndarray, degree: int) -> tuple[np.ndarray, np.ndarray]:
    """``(nbr (n, k), s (n, k))``: the fits' neighbours (-1 padded, at most :data:`MAX_NEIGHBOURS`)
    and weights for the vertices ``nbr[:, 0]`` (neighbourhoods ``nbr (n, m)``, mean edge lengths ``h (n,)``)."""
    valid = nbr >= 0
    X = gather.rows(V, np.maximum(nbr, 0)) - gather.rows(V, nbr[:, 0])[:, None, :]  # (n, m, 3)
    r2 = np.where(valid, (X * X).sum(2) / (h * h)[:, None], np.inf)
    if nbr.shape[1] > MAX_NEIGHBOURS:
        keep = np.argsort(r2, axis=1, kind="stable")[:, :MAX_NEIGHBOURS]
        nbr, X, r2 = (np.take_along_axis(a, keep if a.ndim == 2 else keep[..., None], 1) for a in (nbr, X, r2))
    w = np.exp(-r2 / (WIDTH * WIDTH))
    Y = X - np.matmul(w[:, None, :], X) / w.sum(1)[:, None, None]
    # eigenvectors ascending: the last two span the neighbourhood's principal plane
    _, axes = np.linalg.eigh(np.matmul((Y * w[..., None]).transpose(0, 2, 1), Y))
    x = np.matmul(X, axes[:, :, [2, 1]]) / h[:, None, None]
    return nbr, fit_weights(x, w, degree)


def loop_corners(P: np.ndarray) -> np.ndarray:
    """``(n,)`` bool: vertices of the closed polyline ``P (n, 3)`` where it turns by more than the corner angle."""
    a, b = P - np.roll(P, 1, 0), np.roll(P, -1, 0) - P
    cos = (a * b).sum(1) / np.maximum(np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1), np.finfo(float).tiny)
    return cos < np.cos(np.radians(SMOOTH_CORNER_DEGREES))


def _arc_lengths(P: np.ndarray, corner: np.ndarray) -> np.ndarray:
    """``(n,)`` arc length of the closed polyline ``P (n, 3)``'s segments ``i -> i + 1`` read as arcs of
    circles: each chord ``c`` lengthened to ``2 asin(c k / 2) / k``, ``k`` the mean curvature of the
    circles through its end vertices and their neighbours (none at a ``corner (n,)``). The chords
    alone are short by ``c^3 k^2 / 24``, which varies from edge to edge with the spacing: an
    irregularity of the loop's parameter that the fits along it copy into the uv. Exact on a circle."""
    a, b = P - np.roll(P, 1, 0), np.roll(P, -1, 0) - P
    la, lb, lab = (np.linalg.norm(x, axis=1) for x in (a, b, a + b))
    k = 2.0 * np.linalg.norm(np.cross(a, b), axis=1) / np.maximum(la * lb * lab, np.finfo(float).tiny)
    k = np.where(corner, np.nan, k)
    ends = np.stack([k, np.roll(k, -1)], 1)  # the segment's two end vertices
    n_ok = np.isfinite(ends).sum(1)
    kseg = np.where(n_ok > 0, np.nansum(ends, 1) / np.maximum(n_ok, 1), 0.0)
    x = np.clip(0.5 * lb * kseg, 0.0, 1.0)
    return np.where(x > 1e-8, np.arcsin(x) / np.maximum(x, 1e-300), 1.0 + x * x / 6.0) * lb


def _boundary(V: np.ndarray, uv: np.ndarray, loop: np.ndarray, degree: int) -> np.ndarray:
    """New uv ``(n, 2)`` of the vertices of ``loop (n,)``: fits along the loop, none across a corner."""
    nbr, weights = _boundary_weights(V, loop, degree)
    return np.matmul(weights[:, None, :], uv[nbr])[:, 0]


def _boundary_weights(V: np.ndarray, loop: np.ndarray, degree: int) -> tuple[np.ndarray, np.ndarray]:
    """``(nbr (n, 2 R + 1), s (n, 2 R + 1))``: the neighbours along ``loop (n,)`` and weights of each of
    its vertices' fits (``R`` = :data:`BOUNDARY_REACH`, none across a corner); a corner, and every
    vertex of a loop too short for the fits, weighs only itself."""
    n = len(loop)
    own = np.zeros((n, 2 * BOUNDARY_REACH + 1))
    own[:, BOUNDARY_REACH] = 1.0
    if n < 2 * BOUNDARY_REACH + 1:
        return np.repeat(loop[:, None], 2 * BOUNDARY_REACH + 1, 1), own
    P = V[loop]
    corner = loop_corners(P)
    seg = _arc_lengths(P, corner) if ARC_LENGTH else np.linalg.norm(np.roll(P, -1, 0) - P, axis=1)
    arc = np.concatenate([[0.0], np.cumsum(seg)])
    off = np.arange(-BOUNDARY_REACH, BOUNDARY_REACH + 1)
    i = np.arange(n)[:, None] + off  # (n, 2R+1), unwrapped
    s = arc[i % n] + np.floor_divide(i, n) * arc[-1] - arc[np.arange(n)][:, None]
    # a neighbour is cut off when a corner lies strictly between it and the vertex
    cc = np.concatenate([[0], np.cumsum(np.tile(corner, 3))])  # corners before unwrapped index + n
    lo, hi = np.minimum(i, np.arange(n)[:, None]), np.maximum(i, np.arange(n)[:, None])
    between = cc[hi + n] - cc[lo + n + 1]
    ok = between == 0
    h = 0.5 * (seg + np.roll(seg, 1))
    w = np.where(ok, np.exp(-(s / (h[:, None] * BOUNDARY_REACH)) ** 2), 0.0)
    weights = fit_weights((s / h[:, None])[..., None], w, degree)
    return loop[i % n], np.where(corner[:, None], own, weights)


def _operator(fits: list, nv: int) -> sp.csr_matrix:
    """``S (nv, nv)``: row ``v`` the weights of ``v``'s interior fit (``fits``: :func:`_interior_fits`),
    so that ``S @ uv`` is one pass of the interior fits (the outline's rows too: :func:`_global` uses
    only the rows of free vertices)."""
    rows, cols, vals = [], [], []
    for _, nb, s in fits:
        ok = nb >= 0
        rows.append(np.broadcast_to(nb[:, :1], nb.shape)[ok])
        cols.append(nb[ok])
        vals.append(s[ok])
    rows, cols, vals = (np.concatenate(a) for a in (rows, cols, vals))
    return sp.csr_matrix((vals, (rows, cols)), shape=(nv, nv))


def _global(S: sp.csr_matrix, uv: np.ndarray, fixed: np.ndarray, weight: float) -> np.ndarray:
    """The map ``(nv, 2)`` nearest ``uv (nv, 2)`` whose fits' residuals are small: ``x`` minimising
    ``weight |((I - S) x)_free|^2 + |x_free - uv_free|^2`` over the vertices not ``fixed (nv,)``
    (which stay at their ``uv``); one sparse SPD solve, both coordinates together."""
    nv = len(uv)
    free = ~fixed
    if not free.any():
        return uv.copy()
    D = (sp.identity(nv, format="csr") - S)[free]
    Df, Dc = D[:, free], D[:, fixed]
    A = weight * (Df.T @ Df) + sp.identity(int(free.sum()), format="csr")
    b = uv[free] - weight * (Df.T @ (Dc @ uv[fixed]))
    out = uv.copy()
    out[free] = solve_spd(A.tocsr(), b, pardiso_min=GLOBAL_PARDISO_MIN)
    return out


def _loop_operator(V: np.ndarray, loop: np.ndarray, degree: int) -> tuple[sp.csr_matrix, np.ndarray]:
    """``(S (n, n), corners (n,) bool)``: the fits along ``loop (n,)`` as a matrix over its vertices."""
    nbr, w = _boundary_weights(V, loop, degree)
    pos = np.empty(int(loop.max()) + 1, np.int64)
    pos[loop] = np.arange(len(loop))
    n = len(loop)
    S = sp.csr_matrix((w.ravel(), (np.repeat(np.arange(n), nbr.shape[1]), pos[nbr.ravel()])), shape=(n, n))
    return S, loop_corners(V[loop]) if n >= 2 * BOUNDARY_REACH + 1 else np.ones(n, bool)


def _uv_edge_length(F: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """``(nv,)`` each vertex's mean uv edge length."""
    nv = len(uv)
    _, edges, _, _ = undirected_edges(F, nv)
    length = np.linalg.norm(uv[edges[:, 0]] - uv[edges[:, 1]], axis=1)
    return np.bincount(edges.ravel(), np.repeat(length, 2), minlength=nv) / np.maximum(
        np.bincount(edges.ravel(), minlength=nv), 1)


def smooth_uv(V: np.ndarray, F: np.ndarray, uv: np.ndarray, loops: list[np.ndarray], *,
              degree: int = DEGREE, rings: int = RINGS, keep: np.ndarray | None = None,
              passes: int | None = None, method: str | None = None) -> tuple[np.ndarray, dict]:
    """Smoothed, fold-free copy ``(nv, 2)`` of the map ``uv (nv, 2)`` of the mesh ``V (nv, 3)``, ``F (nf, 3)``.

    ``loops``: the mesh's boundary loops (e.g. :attr:`ValidatedMesh.boundary_loops`); ``keep``:
    vertex ids that keep their uv (e.g. the harmonic map's outline, on its circle); ``method``:
    ``"local"``, ``passes`` rounds of interior fits, each from the last one's map (the outline's
    in the first only; default :data:`PASSES`), or ``"global"``, one round, then the interior
    solved for the map nearest it whose fits' residuals are small (:data:`GLOBAL_WEIGHT`; the
    outline held; where that folds a face, the one round's map instead); default :data:`METHOD`,
    ``"local"`` above :data:`GLOBAL_MAX_VERTICES`. Returns the map and ``info``: ``moved_max``
    (largest move over the vertex's mean edge length in uv), ``reverted`` (vertices that kept their
    uv because of a fold), ``fallback`` (True when the unchanged map was returned), ``method``
    (the one used).
    """
    nv = len(V)
    if method is None:
        method = METHOD if nv <= GLOBAL_MAX_VERTICES else "local"
    if method not in ("global", "local"):
        raise ValueError(f"unknown smoothing method {method!r}; choose 'global' or 'local'")
    nbr, h = _neighbourhoods(V, F, rings)
    huv = _uv_edge_length(F, uv)
    # the global solve needs the fits again as a matrix: computed once then (<= GLOBAL_MAX_VERTICES
    # vertices by default); the local passes compute them chunk by chunk, without holding them
    fits = list(_interior_fits(V, nbr, h, degree)) if method == "global" else None
    new = uv
    for k in range(1 if method == "global" else PASSES if passes is None else passes):
        last, new = new, np.empty_like(uv)
        for sl, nb, s in fits or _interior_fits(V, nbr, h, degree):
            new[sl] = _interior(last, nb, s)
        for loop in loops:  # the outline in the first pass only; a vertex moved too far keeps its uv
            b = _boundary(V, last, loop, degree) if k == 0 else last[loop]
            far = np.linalg.norm(b - uv[loop], axis=1) > BOUNDARY_MAX_MOVE * huv[loop]
            new[loop] = np.where(far[:, None], uv[loop], b)
        if keep is not None:
            new[keep] = uv[keep]
    if method == "global":
        held = np.zeros(nv, bool)
        if keep is not None:
            held[keep] = True
        solved = new.copy()
        for loop in loops:  # each loop's own solve along it (corners held), kept only if it moves no
            S, corner = _loop_operator(V, loop, degree)  # vertex too far; then the loop held
            b = _global(S, new[loop], corner | held[loop], GLOBAL_OUTLINE_WEIGHT)
            if (np.linalg.norm(b - uv[loop], axis=1) <= BOUNDARY_MAX_MOVE * huv[loop]).all():
                solved[loop] = b
            held[loop] = True
        solved = _global(_operator(fits, nv), solved, held, GLOBAL_WEIGHT)
        if np.logical_or(*fold_mask(solved, F)).any():  # the one pass instead (reverted below as before)
            method = "local"
        else:
            new = solved
    new = new.copy()
    kept = np.zeros(nv, bool)
    for _ in range(REVERT_ROUNDS):
        flipped, degenerate = fold_mask(new, F)
        bad = flipped | degenerate
        if not bad.any():
            break
        v = np.unique(F[bad])
        new[v], kept[v] = uv[v], True
    fallback = bool((np.logical_or(*fold_mask(new, F))).any())
    if fallback:
        new = uv.copy()
    moved = np.linalg.norm(new - uv, axis=1) / np.maximum(huv, np.finfo(float).tiny)
    return new, dict(moved_max=float(moved.max(initial=0.0)), reverted=int(kept.sum()), fallback=fallback,
                     method=method)
