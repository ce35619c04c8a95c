"""How far the local targets of a patch can be trusted: do its three vertices' local fits agree on it?

    gamma = local_trust(ctx)        # (n,) in [0, 1], one per patch of the context

Why (issue 18): each vertex's local fit (:func:`~trispline.fit.targets.local_rbf_fit`) is an
interpolant of its rings, chosen by its leave-one-out error at the few points nearest the
vertex. Where the mesh is coarse for its curvature, irregular (valence-4 vertices between quad
strips, long thin triangles) or folded, that error stays small while the interpolant swings
between the data points; the ``local`` term then pulls the patch's control points onto the
swing and the bend (measured from the same fits, :mod:`trispline.fit.boundary`) stops fairing
it. On halftunnel the three fits of the patches that spiked (|H| 25-55x the data's largest)
differed by 0.6-1.2 of an edge on them; the median patch's fits agree to 0.3% of an edge, a
clean analytic mesh's to ~1e-5.

On a sliver the same disagreement costs more: the neighbours' targets differ by ``delta`` across a
width ``w`` much below the edge length, a bend of ``delta / w^2`` (beetle's two slivers of uv
aspect 220, fits agreeing to 1e-3 of an edge: |H| 34x the data's largest). So on a patch thinner
than :data:`THIN_OK` the disagreement counts ``(thinness / THIN_OK)**THIN_POWER`` times.

The test needs no new fit: the three fits are evaluated at :data:`PROBES` (the centroid and the
edge midpoints) of every patch, and ``d`` is their largest distance from their mean, over the
patch's mean 3D edge length. A patch is trusted fully up to :data:`AGREE_OK`, not at all from
:data:`AGREE_BAD` on, log-linear between; an untrusted patch is faired by the plain thin plate
and the ``tilt`` term alone (its local weight and its bend reference scaled by ``gamma``).

Where the data are rough at the scale of the edges (a registered scan whose neighbouring faces
differ by 60 degrees and more), the fits agree with each other and still cannot be trusted: each
interpolates the same noise. Such a fit has no skill: its leave-one-out error at the points
nearest its vertex is as large as those points' own departure from the fit's plane (the linear
trend it removes first), and large against the edges. :func:`fit_skill` is that ratio: the pelvis
scan's median 1.05, the 2D benchmark's 100-point sets 0.09-0.11, the shared meshes 0.00-0.26
(lilium). Spline patches next to the pelvis's outline reached 438x the data's largest curvature,
following the fits' tangent planes (``tilt``) and nets (``local``) between interpolated noise.
:func:`fit_trust` takes a vertex's tangent-frame target and the local targets of its patches
away as far as both its error over its mean edge length (:data:`ROUGH_OK` to :data:`ROUGH_BAD`)
and its skill ratio (:data:`SKILL_OK` to :data:`SKILL_BAD`) say so; the thin plate fairs them.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from trispline.param import face_aspects
from trispline.spline.topology import mean_edge_lengths

from .targets import RBF_LOO_POINTS

if TYPE_CHECKING:
    from .energy.context import TermContext

__all__ = ["AGREE_BAD", "AGREE_OK", "PROBES", "ROUGH_BAD", "ROUGH_OK", "SKILL_BAD", "SKILL_OK", "SLIVER_BEND_MAX", "THIN_OK", "THIN_POWER",
           "disagreement", "fit_skill", "fit_trust", "frame_trust", "local_trust", "log_fade", "sliver_bend"]

#: A patch's local fits agreeing to this fraction of its mean edge length are fully trusted.
AGREE_OK = 0.1
#: ... and not at all from this fraction on (measured in docs/fit.md, "Spikes").
AGREE_BAD = 0.5
#: Patches thinner than this in uv (longest edge over height, relative to an equilateral triangle's;
#: beetle's p99 10.9) count their disagreement times ``(thinness / THIN_OK)**THIN_POWER``.
THIN_OK = 10.0
THIN_POWER = 3
#: The largest factor :func:`sliver_bend` puts on a sliver's bend weights (the pelvis's slivers of
#: aspect 1e5 made the normal matrix indefinite in floating point; the camel head's and beetle's
#: spiking slivers need 4 and 9).
SLIVER_BEND_MAX = 10.0
#: A local fit whose leave-one-out error is this fraction of its vertex's mean edge length is fully
#: trusted, ... (see the module docstring; measured in docs/fit.md, "Spikes on real meshes")
ROUGH_OK = 0.05
#: ... and loses its targets from this fraction on, as far as its skill ratio allows:
ROUGH_BAD = 0.2
#: a fit whose :func:`fit_skill` ratio is at most this keeps its targets, one from :data:`SKILL_BAD`
#: on is trusted only as far as its error allows.
SKILL_OK = 0.3
SKILL_BAD = 0.6
#: (4, 3) barycentric points where the three fits are compared: the centroid and the edge midpoints.
PROBES = np.array([[1 / 3, 1 / 3, 1 / 3], [0.5, 0.5, 0.0], [0.0, 0.5, 0.5], [0.5, 0.0, 0.5]])

def _thinness(points: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """``(n,)`` >= 1: the aspect (:func:`trispline.param.face_aspects`) of each triangle ``faces (n, 3)``
    over ``points (nv, 2 or 3)`` relative to an equilateral triangle's (1 there, ~100 for a sliver of
    aspect 200)."""
    return np.maximum(np.sqrt(3.0) / 2.0 * face_aspects(points, faces), 1.0)


def disagreement(ctx: TermContext) -> np.ndarray:
    """``(n,)``: the largest distance of a patch's three local fits from their mean at :data:`PROBES`,
    over the mean 3D edge length of its vertices (0 when there are no fits)."""
    faces = ctx.faces
    if ctx.fit is None or not len(faces):
        return np.zeros(len(faces))
    pts = np.einsum("gk,fkc->fgc", PROBES, ctx.uv[faces])  # (n, 4, 2)
    N = np.stack([ctx.fit.evaluate(faces[:, k], pts) for k in range(3)], 1)  # (n, 3, 4, d)
    dev = np.linalg.norm(N - N.mean(1, keepdims=True), axis=-1).max(axis=(1, 2))
    h = mean_edge_lengths(ctx.V, ctx.halo_faces)[faces].mean(1)
    return dev / np.maximum(h, np.finfo(float).tiny)


def log_fade(x: np.ndarray, ok: float, bad: float) -> np.ndarray:
    """``(n,)`` trust in ``x (n,)``: 1 up to ``ok``, 0 from ``bad`` on, log-linear between."""
    lo, hi = np.log(ok), np.log(bad)
    return np.clip((hi - np.log(np.maximum(x, np.finfo(float).tiny))) / (hi - lo), 0.0, 1.0)


def fit_skill(fit, vertices: np.ndarray | None = None) -> np.ndarray:
    """``(m,)`` the leave-one-out error of the local fits of ``vertices (m,)`` (default: all) of
    ``fit`` (a :class:`~trispline.fit.targets.LocalRBFFit`) over the RMS departure of the same
    points (the :data:`~trispline.fit.targets.RBF_LOO_POINTS` nearest its vertex, the vertex
    included) from the fit's linear trend: about 1 or more where the fit interpolates noise, well
    below 1 where it predicts (see the module docstring)."""
    v = np.arange(len(fit.loo)) if vertices is None else np.asarray(vertices, np.int64)
    X = fit.centres[v, :RBF_LOO_POINTS]  # (m, k, 2) scaled uv offsets, the vertex first; padding at 0
    vals = fit.evaluate(v, fit.origin[v, None, :] + X * fit.scale[v, None, None])  # the data there
    Y = vals - fit.value[v, None, :] - np.einsum("vki,vid->vkd", X, fit.slope[v])
    real = np.abs(X).sum(-1) > 0
    real[:, 0] = True
    relief = np.sqrt(np.where(real[..., None], Y * Y, 0.0).sum((1, 2)) / (real.sum(1) * Y.shape[2]))
    return fit.loo[v] / np.maximum(relief, np.finfo(float).tiny)


def fit_trust(ctx: TermContext) -> np.ndarray:
    """``(h,)`` in [0, 1] per halo vertex: 1 minus how far its local fit both misses its neighbours
    against the edges (:data:`ROUGH_OK`, :data:`ROUGH_BAD`) and has no skill (:func:`fit_skill`,
    :data:`SKILL_OK`, :data:`SKILL_BAD`); 1 without local fits. Computed once per context."""
    if ctx.fit is None:
        return np.ones(len(ctx.V))
    if "fit_trust" not in ctx.memo:
        h = mean_edge_lengths(ctx.V, ctx.halo_faces)
        rough = 1.0 - log_fade(ctx.fit.loo / np.maximum(h, np.finfo(float).tiny), ROUGH_OK, ROUGH_BAD)
        some = np.flatnonzero(rough > 0)  # the skill only where the error counts (few vertices, if any)
        rough[some] *= 1.0 - log_fade(fit_skill(ctx.fit, some), SKILL_OK, SKILL_BAD)
        ctx.memo["fit_trust"] = 1.0 - rough
    return ctx.memo["fit_trust"]


def frame_trust(ctx: TermContext) -> np.ndarray:
    """``(m,)`` the :func:`fit_trust` of the context's frame vertices (the ``tilt`` term's factor)."""
    return fit_trust(ctx)[ctx.frame_vertices]


def local_trust(ctx: TermContext) -> np.ndarray:
    """``(n,)`` in [0, 1]: the weight of each patch's local targets (see the module docstring): their
    agreement, and the least :func:`fit_trust` of its three vertices; computed once per context."""
    if "trust" not in ctx.memo:  # the local and bend terms share it
        thin = np.maximum(_thinness(ctx.uv, ctx.faces) / THIN_OK, 1.0)
        agree = log_fade(disagreement(ctx) * thin ** THIN_POWER, AGREE_OK, AGREE_BAD)
        ctx.memo["trust"] = agree * fit_trust(ctx)[ctx.faces].min(1)
    return ctx.memo["trust"]


def sliver_bend(ctx: TermContext) -> np.ndarray:
    """``(n,)`` in [1, :data:`SLIVER_BEND_MAX`]: the factor on each patch's bend weights (its thin
    plate counts its square), the uv :func:`_thinness` over :data:`THIN_OK` on thinner patches; 1
    without local fits (the approximation's context).

    The thin plate is an integral over the patch's uv area, so a sliver's bend is cheap however
    sharp: where the guard above takes a sliver's local targets away, nothing else holds it (camel
    head: a sliver of aspect 100 at 3,200x the data's largest |H|; with this factor 8x).
    """
    if ctx.fit is None or not len(ctx.faces):
        return np.ones(len(ctx.faces))
    return np.clip(_thinness(ctx.uv, ctx.faces) / THIN_OK, 1.0, SLIVER_BEND_MAX)
