"""The fit near the outline (issue 17): the thin plate measured against the local fits' shape.

    T = bend_reference(ctx, blended_targets)   # (n, 21, 3): what the bend subtracts before its thin plate

(``blended_targets`` is :func:`trispline.fit.energy.local.blended_targets`, passed in by the
bend term so that this module imports no term.)

Why: the thin-plate energy ``int |F_uu|^2 + 2 |F_uv|^2 + |F_vv|^2`` of a free-boundary
surface has natural boundary conditions (the second normal derivative and the normal
flux of the Laplacian vanish at the outline). A curved surface violates them, so the bend
term pulls the patches along the outline flat: on the analytic surfaces of
``benchmarks/bench_accuracy3d.py`` the band of faces touching the outline carried 25-100x
the interior RMS error, in proportion to the bend weight, and exact local targets did not
help (the bend, not the targets, set the band's error). Lowering the bend in the band only
moved the error to the next ring (the same conditions hold at the edge of any region the
bend covers).

The cure keeps the bend as the fairing term but measures it on the surface's deviation
from the data's local shape: ``int |D^2 (F - beta T)|^2``, ``T`` per patch the mean of the
quintic nets of its three vertices' local fits (equal weights: the ``local`` term's
corner blend, whose weights vary over the patch, adds second derivatives of its own where
the fits disagree; as the reference it raised the snail's curvature p99.9 1.9 -> 11), and
``beta`` the patch's :func:`trust` in those fits (times their agreement on the patch,
:func:`trispline.fit.agreement.local_trust`). A surface that follows trusted local fits
costs no bending, whatever its curvature, so nothing pulls at the outline; deviations
(wiggles between the data vertices) are still faired. With ``local = 0`` (no local targets)
the bend is the plain thin plate.

Two more things shape the boundary patches' targets (both in the fits' evaluation, so the bend
reference and the local term's targets agree):

* the outline faired as a curve (:func:`outline_warp`, :mod:`trispline.fit.curves`): the fits are
  evaluated at domain points moved so that each boundary edge follows a smooth curve through the
  uv outline, where the fit made its domain itself (the context's ``target_shift``:
  :func:`outline_warp` of the whole mesh, so a local re-fair's halo sees the fit's own targets);
* ears (:func:`ear_substitutes`): a patch with all three vertices on the outline takes the fit of
  the nearest vertex off the outline (within :data:`EAR_RINGS` edges).

:func:`corner_gradients` makes the same substitution for the tilt targets of a corner whose only
face is an ear (:mod:`trispline.fit.energy.tilt`; measured in docs/fit.md, "Boundary curves faired
as curves, ear triangles").
"""
from __future__ import annotations

from collections.abc import Callable
from functools import partial
from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp
from trispline.param.tables import boundary_loops, undirected_edges
from trispline.spline.index import DEGREE, EXPONENTS
from trispline.spline.topology import mean_edge_lengths, outline_vertex_mask

from .agreement import fit_skill, local_trust, log_fade
from .curves import bump_shapes, loop_bulges
from .progress import Report
from .targets import rings_of

if TYPE_CHECKING:
    from .energy.context import TermContext

__all__ = ["CURVE_WARP", "EAR_TARGETS", "FD_STEP", "RAGGED_MISS", "RELATIVE_BEND", "SKILLED_LOO", "SKILL_LOO_RANGE", "SMOOTH_MISS", "TRUSTED_LOO", "WARP_MAX",
           "UNSKILLED_LOO", "UNTRUSTED_LOO", "bend_reference", "corner_gradients", "EAR_RINGS", "ear_substitutes", "outline_warp",
           "trust"]

#: Whether an ear's targets (a patch with all three vertices on the outline: its vertices' local fits
#: are all one-sided) come from the fit of the nearest vertex off the outline (:func:`ear_substitutes`).
#: Measured in docs/fit.md, "The boundary": the rectangular analytic domains' corners are ears.
EAR_TARGETS = True
#: Step of :func:`corner_gradients`' central differences, in the fit's local length (rounding 1e-12).
FD_STEP = 1e-4
#: Whether the boundary patches' targets follow the outline faired as a curve (:func:`outline_warp`)
#: where the fit made its domain itself (``fit_surface``'s ``curved_outline``).
CURVE_WARP = True
#: An edge's bulge counts fully when its curve passes within this fraction of the edge's length
#: from its two vertices, not at all from :data:`RAGGED_MISS` on (log-linear between): a ragged
#: outline is not bent toward a curve it does not follow. Measured (``miss`` of
#: :func:`~trispline.fit.curves.loop_bulges`): the analytic meshes' smoothed LSCM outlines 1e-5 to
#: 7e-4 at 800-3,200 vertices (at 200: up to 3.5%, the monkey saddle); the shared meshes median
#: 1.3e-4, p99 2.2%. 2e-2 (was 1e-2): the monkey saddle's outline at 200 vertices (miss median 0.8%,
#: up to 3.5%) keeps the bulge of its edges up to 2% (its boundary-curve distance 1.67e-3 -> 1.44e-3
#: with the skilled fits of :data:`SKILLED_LOO`).
SMOOTH_MISS = 2e-2
RAGGED_MISS = 1e-1
#: A face's outline warp moves its points by at most this fraction of its smallest uv height
#: (:func:`_warp_cap`). A smooth outline's bulge is about ``0.09 h / R`` of it (``R`` the outline's
#: radius of curvature): the analytic domains stay far below.
WARP_MAX = 0.1

#: Whether the bend term is measured from the local fits (see the module docstring; measured in
#: docs/fit.md, "The boundary").
RELATIVE_BEND = True

#: A vertex's local fit is trusted as the bend's reference when its leave-one-out error is at most
#: this fraction of its mean 3D edge length, not at all from :data:`UNTRUSTED_LOO` on (log-linear
#: between). Measured medians: clean analytic meshes 2e-5 to 2e-4, the smooth shared meshes
#: (snail, inspired_mesh) 1e-5 to 2e-5; the noisy generated scan 1.4e-2, halftunnel 1.1e-2.
TRUSTED_LOO = 1e-3
UNTRUSTED_LOO = 1e-2
#: ... unless the fit has skill (:func:`trispline.fit.agreement.fit_skill`: its leave-one-out error over
#: the relief of its nearest points about its plane): a fit whose ratio is at most :data:`SKILLED_LOO`
#: predicts the shape it was given, so its error is the sampling's (a few points a feature), not noise,
#: and it stays the reference; from :data:`UNSKILLED_LOO` on it is trusted only as far as its error
#: allows (log-linear between; 0 switches the skill off). Measured (fit_skill where the error is above
#: :data:`TRUSTED_LOO`, p10 / median / p90): the monkey saddle's outline at 200 vertices 0.04 / 0.10 /
#: 0.17 (error 1.2% of an edge: it lost the reference, and its boundary curves bent to the chords), the
#: sparse 2D sets 0.03-1.6; the noisy generated scan 0.17 / 0.5 / 1.2, lilium 0.11 / 0.27 / 0.5,
#: halftunnel 0.04 / 0.07 / 0.16. At 0.3 / 0.6 (the local targets' :data:`~trispline.fit.agreement.SKILL_OK`)
#: the camel head gained a patch above 20x the data's largest |H|; at 0.15 / 0.4 no real mesh lost a
#: target (docs in benchmarks/README.md, issue 17, helper H40).
SKILLED_LOO = 0.15
UNSKILLED_LOO = 0.4
#: The skill counts fully up to the first error (over the mean edge length), not at all from the second
#: on: noise of an edge length (``tests/fit/test_agreement_rough.py``) leaves a few fits of apparent skill
#: at 0.05-0.2 of an edge, and 11 of 863 at trust up to 0.3 made the fit 22x more curved.
SKILL_LOO_RANGE = (0.02, 0.05)


def bend_reference(ctx: TermContext, blended_targets: Callable) -> np.ndarray:
    """What the bend term's thin plate is measured from: ``(n, 21, d)`` per patch ``beta`` times the
    mean net of its three vertices' local fits (``blended_targets`` with blend power 0), when
    :data:`RELATIVE_BEND` and the local term has weight and fits (the approximation's context has
    none: its bend has a reference of its own); else ``(1, 1, 1)`` zeros (the plain thin plate)."""
    if not (RELATIVE_BEND and ctx.fit is not None and ctx.weights.local > 0 and ctx.weights.bend > 0):
        return np.zeros((1, 1, 1))
    # (n,) a patch trusts the least trusted of its vertices' fits, and only as far as they agree on it
    beta = trust(ctx)[ctx.faces].min(1) * local_trust(ctx)
    if not beta.any():
        return np.zeros((1, 1, 1))
    evaluate = ctx.fit.evaluate
    shift = ctx.target_shift
    if shift is not None and shift.any():  # the local term's targets come from the same evaluations (local.shared_targets)
        evaluate = partial(_shifted, evaluate, shift)
    if EAR_TARGETS:
        sub = ear_substitutes(ctx.uv, ctx.halo_faces, ctx.faces, _halo_edges(ctx))
        ears = sub >= 0
        if ears.any():  # an ear's three fits are all one-sided: its nets from the nearest inner vertex's fit
            beta = np.where(ears, trust(ctx)[np.maximum(sub, 0)] * local_trust(ctx), beta)
            evaluate = partial(_substituted, evaluate, sub)
    return blended_targets(ctx.uv, ctx.faces, evaluate, power=0.0) * beta[:, None, None]


def edge_tables(faces: np.ndarray, nv: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(he (3 nf, 2), he_edge (3 nf,), count (ne,))`` of ``faces (nf, 3)``
    (:func:`trispline.param.tables.undirected_edges`, in 64 bits)."""
    he, _, he_edge, count = undirected_edges(np.asarray(faces, np.int64), nv)
    return he, he_edge, count


def _halo_edges(ctx: TermContext) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`edge_tables` of the context's halo, computed once per context."""
    if "halo_edges" not in ctx.memo:
        ctx.memo["halo_edges"] = edge_tables(ctx.halo_faces, len(ctx.uv))
    return ctx.memo["halo_edges"]


#: An ear's substitute vertex is sought within this many edges of its corners (:func:`ear_substitutes`).
EAR_RINGS = 3


def ear_substitutes(uv: np.ndarray, halo_faces: np.ndarray, faces: np.ndarray, edges: tuple | None = None
                    ) -> np.ndarray:
    """``(n,)`` for each of the patches ``faces (n, 3)`` that is an ear (its three vertices on the
    outline of ``halo_faces``) the vertex off the outline nearest its uv centroid among those within
    :data:`EAR_RINGS` edges of its corners; -1 elsewhere (and where there is none). ``uv (h, 2)``;
    vertex ids index it; ``edges``: the :func:`edge_tables` of ``halo_faces``, when known. Near in the
    mesh, not only in uv: a map may cover the plane twice (LSCM of a helicoidal ramp of three turns),
    and the vertex nearest in uv was then a turn away (a spike of 7% of the diagonal at the ramp's end)."""
    on = outline_vertex_mask(halo_faces, len(uv), tables=edge_tables(halo_faces, len(uv)) if edges is None else edges)
    ear = np.flatnonzero(on[faces].all(1))
    out = np.full(len(faces), -1, np.int64)
    if not ear.size or on.all():
        return out
    corners = faces[ear].ravel()  # the rings of these alone (the whole mesh's took 0.26 s at 100k faces)
    R = rings_of(halo_faces, len(uv), corners, np.full(corners.size, EAR_RINGS))
    near = sp.csr_matrix((np.ones(corners.size), (np.repeat(np.arange(ear.size), 3), np.arange(corners.size))),
                         shape=(ear.size, corners.size)) @ R
    near = sp.csr_matrix(near.multiply((~on).astype(np.int8)[None, :]))
    near.eliminate_zeros()
    near.sort_indices()
    row = np.repeat(np.arange(ear.size), np.diff(near.indptr))
    d = np.linalg.norm(uv[near.indices] - uv[faces[ear]].mean(1)[row], axis=1)
    order = np.lexsort((d, row))  # per row, nearest first
    first = order[np.r_[0, np.flatnonzero(np.diff(row[order])) + 1]] if order.size else order
    out[ear[row[first]]] = near.indices[first]
    return out


def corner_gradients(ctx: TermContext) -> np.ndarray:
    """``(m, d, 2)`` the tilt targets' gradients at the context's frame vertices: the local fits' own
    (``ctx.fit.grad``), except at a corner whose only face is an ear (:func:`ear_substitutes`): there
    the gradient of the ear's substitute fit at the corner (central differences; its own fit is
    the most one-sided of all), as far as that fit is trusted (:func:`trust`). The targets of
    :mod:`trispline.fit.energy.tilt` (measured in docs/fit.md, "The boundary")."""
    fv = ctx.frame_vertices
    grad = ctx.fit.grad[fv].copy()
    if not EAR_TARGETS:
        return grad
    sub = ear_substitutes(ctx.uv, ctx.halo_faces, ctx.halo_faces, _halo_edges(ctx))
    lone = np.bincount(ctx.halo_faces.ravel(), minlength=len(ctx.uv)) == 1
    by_vertex = np.full(len(ctx.uv), -1, np.int64)
    ears = np.flatnonzero(sub >= 0)
    for k in range(3):  # a lone corner's one face
        by_vertex[ctx.halo_faces[ears, k]] = np.where(lone[ctx.halo_faces[ears, k]], sub[ears], -1)
    rows = np.flatnonzero(by_vertex[fv] >= 0)
    if rows.size:
        v = fv[rows]
        eps = FD_STEP * ctx.fit.scale[v]
        pts = ctx.uv[v][:, None, :] + eps[:, None, None] * np.array([[1, 0], [-1, 0], [0, 1], [0, -1]])
        val = ctx.fit.evaluate(by_vertex[v], pts)  # (k, 4, d)
        fd = np.stack([val[:, 0] - val[:, 1], val[:, 2] - val[:, 3]], -1) / (2 * eps)[:, None, None]
        t = trust(ctx)[by_vertex[v]][:, None, None]  # as far as the substitute's fit is trusted
        grad[rows] = t * fd + (1.0 - t) * grad[rows]
    return grad


def _shifted(evaluate: Callable, shift: np.ndarray, vertex: np.ndarray, points: np.ndarray,
             report: Report | None = None) -> np.ndarray:
    """``evaluate`` (as in :func:`_substituted`) at ``points + shift`` (both ``(n, 21, 2)``)."""
    return evaluate(vertex, points + shift, report)


def _substituted(evaluate: Callable, sub: np.ndarray, vertex: np.ndarray, points: np.ndarray,
                 report: Report | None = None) -> np.ndarray:
    """``evaluate`` (the grouped form of :meth:`~trispline.fit.targets.LocalRBFFit.evaluate`, one row per
    patch) with the fit of ``sub[f]`` instead of ``vertex[f]`` where ``sub >= 0``."""
    return evaluate(np.where(sub >= 0, sub, vertex), points, report)


def outline_warp(V: np.ndarray, uv: np.ndarray, faces: np.ndarray, edges: tuple | None = None) -> np.ndarray:
    """``(nf, 21, 2)`` uv shifts of every patch's domain points that bend its boundary edges onto the
    outline faired as a curve (:func:`trispline.fit.curves.loop_bulges`); zero off the outline.

    On a face whose half-edge ``p -> q`` (local ``i -> j``) lies on the outline the shift is
    ``n (s_1 a + s_2 b)``, ``s`` the :func:`~trispline.fit.curves.bump_shapes` (on the edge ``B_320 =
    10 l_i^3 l_j^2``, ``B_230 = 10 l_i^2 l_j^3``; quartic in the face where ``a = b``), ``n`` the
    edge's left normal: the warp vanishes with its first derivatives on the face's other two
    edges and at its corners, so the warped map is C1 with the unwarped one next to it and the
    corner frames keep their targets. ``V (nv, 3)``, ``uv (nv, 2)``, ``faces (nf, 3)``; ``edges``: their
    :func:`edge_tables`, when known. An edge bulges as far as its outline is smooth (:data:`SMOOTH_MISS`).
    """
    nv = len(uv)
    faces = np.asarray(faces, np.int64)
    he, he_edge, count = edge_tables(faces, nv) if edges is None else edges
    shift = np.zeros((len(faces), EXPONENTS.shape[0], 2))
    bnd = np.flatnonzero(count[he_edge] == 1)
    leaving = np.full(nv, -1, np.int64)
    leaving[he[bnd, 0]] = bnd  # the boundary half-edge leaving each outline vertex
    lam = EXPONENTS / DEGREE  # (21, 3)
    touched = [np.zeros(0, np.int64)]
    for loop in boundary_loops(V, faces, he_edge, count):
        a, b, miss = loop_bulges(V[loop], uv[loop])
        q = np.roll(loop, -1)
        w = log_fade(miss, SMOOTH_MISS, RAGGED_MISS)
        h = leaving[loop]  # the half-edge p -> q
        f, k = np.divmod(h, 3)  # half-edge 3 f + k runs local k + 1 -> k + 2
        i, j = (k + 1) % 3, (k + 2) % 3
        e = uv[q] - uv[loop]
        nrm = np.stack([-e[:, 1], e[:, 0]], 1) / np.linalg.norm(e, axis=1)[:, None]
        bump = bump_shapes(lam[:, i].T, lam[:, j].T) @ np.stack([a, b], 1)[:, :, None]  # (m, 21, 1)
        np.add.at(shift, f, (w[:, None, None] * bump) * nrm[:, None, :])
        touched.append(f)
    rows = np.unique(np.concatenate(touched))
    shift[rows] *= _warp_cap(uv, faces[rows], shift[rows])[:, None, None]
    return shift


def _warp_cap(uv: np.ndarray, faces: np.ndarray, shift: np.ndarray) -> np.ndarray:
    """``(m,)`` factors that keep each face's largest shift within :data:`WARP_MAX` of its smallest
    uv height: a curve fitted along a short, zigzag hole (many small holes, most vertices on an
    outline) bulges its edges across their faces, and the fits evaluated there spiked (|H| 6e5x the
    data's on a grid with 10% of its faces missing)."""
    mag = np.linalg.norm(shift, axis=2).max(1)
    p = uv[faces]  # (m, 3, 2)
    e = np.roll(p, -1, 1) - p
    area2 = np.abs(e[:, 0, 0] * e[:, 1, 1] - e[:, 0, 1] * e[:, 1, 0])
    height = area2 / np.linalg.norm(e, axis=2).max(1)
    return np.minimum(1.0, WARP_MAX * height / np.maximum(mag, np.finfo(float).tiny))


def trust(ctx: TermContext) -> np.ndarray:
    """``(h,)`` in [0, 1]: how far each halo vertex's local fit is the bend's reference, from its
    leave-one-out error over its mean 3D edge length (:data:`TRUSTED_LOO`, :data:`UNTRUSTED_LOO`).

    Where the data are noisy the local interpolants follow the noise; measured from them the
    bend would stop fairing it (on the shared scans: more patches of extreme curvature). A fit
    with skill (:data:`SKILLED_LOO`) keeps the trust its error takes: coarse sampling, not noise.
    Computed once per context.
    """
    if "bend_trust" not in ctx.memo:
        h = mean_edge_lengths(ctx.V, ctx.halo_faces)
        t = log_fade(ctx.fit.loo / np.maximum(h, np.finfo(float).tiny), TRUSTED_LOO, UNTRUSTED_LOO)
        some = np.flatnonzero(t < 1)  # the skill only where the error counts
        if SKILLED_LOO > 0 and some.size:
            # and only while the error is a few hundredths of an edge (SKILL_LOO_RANGE): noise of an edge has
            # some fits of apparent skill, and any share of their nets spikes
            skilled = np.minimum(log_fade(fit_skill(ctx.fit, some), SKILLED_LOO, UNSKILLED_LOO),
                                 log_fade(ctx.fit.loo[some] / np.maximum(h[some], np.finfo(float).tiny), *SKILL_LOO_RANGE))
            t[some] += (1.0 - t[some]) * skilled
        ctx.memo["bend_trust"] = t
    return ctx.memo["bend_trust"]
