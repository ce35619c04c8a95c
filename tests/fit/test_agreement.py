"""The agreement guard of the local targets (issue 18, :mod:`trispline.fit.agreement`)."""
from __future__ import annotations

import dataclasses

import jax
import numpy as np

jax.config.update("jax_enable_x64", True)

from trispline.fit import agreement  # noqa: E402
from trispline.fit.energy.context import term_context  # noqa: E402
from trispline.fit.weights import FitWeights  # noqa: E402
from trispline.spline.propagation import build_space  # noqa: E402
from trispline.spline.testing.domains import random_delaunay  # noqa: E402
from trispline.spline.topology import Triangulation  # noqa: E402


def _context(n: int = 200):
    uv, f = random_delaunay(n, seed=3)
    V = np.column_stack([uv, 0.3 * np.sin(2 * uv[:, 0]) * np.cos(uv[:, 1])])
    return term_context(build_space(Triangulation(uv, f)), V, FitWeights())


@dataclasses.dataclass(frozen=True)
class _Shifted:
    """A local fit whose vertex ``v`` swings by ``shift`` (data units) away from its vertex."""

    fit: object
    v: int
    shift: float

    def evaluate(self, vertex, points, report=None):
        out = self.fit.evaluate(vertex, points, report)
        away = np.linalg.norm(points - self.fit.origin[vertex][:, None], axis=-1) > 0
        out[..., 2] += np.where((vertex == self.v)[:, None] & away, self.shift, 0.0)
        return out

    def __getattr__(self, name):  # the rest (loo, power, ...) is the fit's
        return getattr(self.fit, name)


def test_smooth_data_is_trusted_everywhere():
    ctx = _context()
    d = agreement.disagreement(ctx)
    assert d.max() < 0.1 * agreement.AGREE_OK, d.max()
    np.testing.assert_array_equal(agreement.local_trust(ctx), 1.0)


def test_a_swinging_fit_loses_the_patches_around_its_vertex():
    ctx = _context()
    v = int(np.argmin(np.linalg.norm(ctx.uv - 0.5, axis=1)))
    h = np.median(np.linalg.norm(ctx.V[ctx.halo_faces[:, 0]] - ctx.V[ctx.halo_faces[:, 1]], axis=1))
    around = (ctx.faces == v).any(1)
    for shift, lo, hi in ((0.3 * h, 0.05, 0.95), (3.0 * h, 0.0, 0.0)):
        bad = dataclasses.replace(ctx, fit=_Shifted(ctx.fit, v, shift))
        gamma = agreement.local_trust(bad)
        assert (gamma[~around] == 1.0).all()
        assert lo <= gamma[around].min() and gamma[around].max() <= max(hi, lo), (shift / h, gamma[around])


def test_the_trust_scales_the_local_weights():
    from trispline.fit.energy import local

    ctx = _context()
    v = int(np.argmin(np.linalg.norm(ctx.uv - 0.5, axis=1)))
    bad = dataclasses.replace(ctx, fit=_Shifted(ctx.fit, v, 10.0))
    a = local.setup(bad)
    face = a["index"] // 21
    around = (ctx.faces[face] == v).any(1)
    assert (a["scale"][around] == 0).all() and (a["scale"][~around] > 0).all()


def test_thinness_is_one_on_equilateral_triangles_and_grows_like_the_aspect():
    one = np.array([[0, 1, 2]])
    eq = np.array([[0, 0], [1, 0], [0.5, np.sqrt(3) / 2]])
    sliver = np.array([[0, 0], [1, 0], [0.5, 0.01]])
    np.testing.assert_allclose(agreement._thinness(eq, one), 1.0)
    np.testing.assert_allclose(agreement._thinness(sliver, one), np.sqrt(3) / 2 / 0.01)
    lifted = np.column_stack([sliver, np.zeros(3)])  # the same in 3D
    np.testing.assert_allclose(agreement._thinness(lifted, one), agreement._thinness(sliver, one))


def test_sliver_bend_is_capped_and_off_without_local_fits():
    ctx = _context()
    np.testing.assert_array_equal(agreement.sliver_bend(ctx), np.maximum(
        np.minimum(agreement._thinness(ctx.uv, ctx.faces) / agreement.THIN_OK, agreement.SLIVER_BEND_MAX), 1.0))
    thin = dataclasses.replace(ctx, uv=ctx.uv * np.array([1.0, 1e-4]))  # every patch a sliver
    np.testing.assert_array_equal(agreement.sliver_bend(thin), agreement.SLIVER_BEND_MAX)
    np.testing.assert_array_equal(agreement.sliver_bend(dataclasses.replace(ctx, fit=None)), 1.0)
