"""The bend's trust in the local fits (fit.boundary.trust): coarse sampling is not noise (issue 17).

A local fit's leave-one-out error over its edges is large in two cases: the data are noisy (the fit
interpolates the noise, and the bend measured from it would stop fairing it) or the data are coarse
for their shape (a few points a feature: the sparse 2D node sets, the monkey saddle at 200
vertices). A fit with skill (its error small against its points' relief about its plane) is the
second case and stays the bend's reference."""
from __future__ import annotations

import jax
import numpy as np

jax.config.update("jax_enable_x64", True)

from trispline.fit import FitWeights, boundary  # noqa: E402
from trispline.fit.agreement import fit_skill  # noqa: E402
from trispline.fit.energy import term_context  # noqa: E402
from trispline.spline.propagation import build_space  # noqa: E402
from trispline.spline.testing.domains import orient_ccw  # noqa: E402
from trispline.spline.topology import Triangulation, mean_edge_lengths  # noqa: E402


def _coarse_grid(z) -> tuple[np.ndarray, np.ndarray]:
    """A jittered 7 x 7 grid of the unit square (49 points) and its Delaunay faces."""
    from scipy.spatial import Delaunay

    t = np.linspace(0.0, 1.0, 7)
    X, Y = np.meshgrid(t, t)
    p = np.column_stack([X.ravel(), Y.ravel()])
    inner = (p > 0).all(1) & (p < 1).all(1)
    p[inner] += np.random.default_rng(1).uniform(-0.03, 0.03, (inner.sum(), 2))
    return np.column_stack([p, z(p[:, 0], p[:, 1])]), orient_ccw(p, Delaunay(p).simplices)


def _context(V: np.ndarray, F: np.ndarray):
    return term_context(build_space(Triangulation(V[:, :2], F)), V, FitWeights())


def test_a_skilled_fit_of_coarse_clean_data_stays_the_bends_reference(monkeypatch):
    """Two bumps over 49 points: the fits miss their neighbours by 1-5% of an edge (untrusted by the
    error alone, below SKILL_LOO_RANGE) but predict 10x better than the points' relief about the plane: trusted."""
    V, F = _coarse_grid(lambda x, y: 0.12 * np.sin(2.5 * np.pi * x) * np.cos(2 * np.pi * y))
    ctx = _context(V, F)
    loo_h = ctx.fit.loo / mean_edge_lengths(ctx.V, ctx.halo_faces)
    skill = fit_skill(ctx.fit)
    assert np.median(loo_h) > boundary.TRUSTED_LOO * 3 and np.median(skill) < boundary.SKILLED_LOO
    monkeypatch.setattr(boundary, "SKILLED_LOO", 0.0)  # the error alone
    old = boundary.trust(_context(V, F))
    monkeypatch.undo()
    new = boundary.trust(ctx)
    assert np.median(old) < 0.6 and np.median(new) == 1.0
    assert (new >= old).all()  # the skill only ever adds trust
    np.testing.assert_array_equal(new[old == 1.0], 1.0)


def test_noise_is_still_no_reference():
    """Pure noise of 5% of an edge over the same points: no skill (ratio about 1), no trust."""
    rng = np.random.default_rng(0)
    V, F = _coarse_grid(lambda x, y: 0.05 * (1.0 / 6) * rng.standard_normal(x.shape))
    ctx = _context(V, F)
    assert np.median(fit_skill(ctx.fit)) > boundary.UNSKILLED_LOO
    assert np.median(boundary.trust(ctx)) == 0.0
