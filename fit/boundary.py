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
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Callable

import numpy as np
from trispline.spline.topology import mean_edge_lengths

from .agreement import local_trust, log_fade

if TYPE_CHECKING:
    from .energy.context import TermContext

__all__ = ["RELATIVE_BEND", "TRUSTED_LOO", "UNTRUSTED_LOO", "bend_reference", "trust"]

#: Whether the bend term is measured from the local fits (see the module docstring; measured in
#: docs/fit.md, "The boundary").
RELATIVE_BEND = True

#: A vertex's local fit is trusted as the bend's reference when its leave-one-out error is at most
#: this fraction of its mean 3D edge length, not at all from :data:`UNTRUSTED_LOO` on (log-linear
#: between). Measured medians: clean analytic meshes 2e-5 to 2e-4, the smooth shared meshes
#: (snail, inspired_mesh) 1e-5 to 2e-5; the noisy generated scan 1.4e-2, halftunnel 1.1e-2.
TRUSTED_LOO = 1e-3
UNTRUSTED_LOO = 1e-2


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
    return blended_targets(ctx.uv, ctx.faces, ctx.fit.evaluate, power=0.0) * beta[:, None, None]


def trust(ctx: TermContext) -> np.ndarray:
    """``(h,)`` in [0, 1]: how far each halo vertex's local fit is the bend's reference, from its
    leave-one-out error over its mean 3D edge length (:data:`TRUSTED_LOO`, :data:`UNTRUSTED_LOO`).

    Where the data are noisy the local interpolants follow the noise; measured from them the
    bend would stop fairing it (on the shared scans: more patches of extreme curvature).
    """
    h = mean_edge_lengths(ctx.V, ctx.halo_faces)
    return log_fade(ctx.fit.loo / np.maximum(h, np.finfo(float).tiny), TRUSTED_LOO, UNTRUSTED_LOO)
