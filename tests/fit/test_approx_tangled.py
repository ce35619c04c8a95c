"""Maps the coarse domain cannot use: the approximation takes the harmonic map instead of failing.

Where a repair split a bowtie vertex in two, the map's outline can touch or cross itself between two
of its edges; no coarse vertex can be put between them, so the coarse domain's boundary chords keep
crossing (:class:`~trispline.fit.approx.domain.TangledOutlineError`). The harmonic map's outline is a
circle: the approximation makes its domain over that one (the shared pelvis scan, repaired, is such a
case), unless the caller named the map. And LSCM takes an open tube's second end to a point: a hole
squeezed shut, which is spanned only where it is a crack, not an opening wide in space.
"""
from __future__ import annotations

import jax
import numpy as np
import pytest

jax.config.update("jax_enable_x64", True)

import trispline.fit.approx.pipeline as pipeline  # noqa: E402
from trispline.fit.approx import approximate_surface  # noqa: E402
from trispline.fit.approx.boundary import _arc_filter  # noqa: E402
from trispline.fit.approx.domain import TangledOutlineError  # noqa: E402
from trispline.fit.approx.holes import WIDE_HOLE, hole_width, wide_holes  # noqa: E402
from trispline.fit.datasets.cache import MISSING_DATA, find_data  # noqa: E402
from trispline.fit.datasets.truth import grid_with_hole  # noqa: E402
from trispline.fit.io import read_mesh  # noqa: E402
from trispline.fit.reach import surface_reach  # noqa: E402
from trispline.param import repair_mesh  # noqa: E402

PELVIS = "pelvis-registration-partial.obj"


def _scan() -> tuple[np.ndarray, np.ndarray]:
    st, F = grid_with_hole(900, seed=1)
    return np.column_stack([st, 0.2 * np.sin(2 * st[:, 0]) * np.cos(st[:, 1])]), F


def _tangled_once(monkeypatch) -> list[str]:
    """Make the first coarse domain fail as over a tangled outline; returns the maps the domains were made on."""
    real, maps = pipeline._budgeted_domain, []

    def domain(V, faces, uv, opt, max_rounds):
        maps.append(uv)
        if len(maps) == 1:
            raise TangledOutlineError("the coarse domain's boundary chords still cross")
        return real(V, faces, uv, opt, max_rounds)

    monkeypatch.setattr(pipeline, "_budgeted_domain", domain)
    return maps


def test_a_tangled_outline_gives_way_to_the_harmonic_map(monkeypatch):
    maps = _tangled_once(monkeypatch)
    V, F = _scan()
    res = approximate_surface(V, F, tolerance_rel=1e-2)
    assert len(maps) == 2
    assert "outline meets itself" in res.parameterization.messages[0]
    assert res.parameterization.method == "harmonic"
    p = maps[1][res.domain.loops[0]]  # the harmonic map's outline is a circle
    (a, b, c), *_ = np.linalg.lstsq(np.column_stack([2 * p, np.ones(len(p))]), (p * p).sum(1), rcond=None)
    np.testing.assert_allclose(np.linalg.norm(p - (a, b), axis=1), np.sqrt(c + a * a + b * b), rtol=1e-9)
    assert res.stats["met"] and res.c1_residual < 1e-12


@pytest.mark.parametrize("named", [dict(param="harmonic"), dict(param="uv")])
def test_a_map_the_caller_named_is_not_replaced(monkeypatch, named):
    _tangled_once(monkeypatch)
    V, F = _scan()
    with pytest.raises(TangledOutlineError, match="still cross"):
        approximate_surface(V, F, tolerance_rel=1e-2, **named)


def test_the_turn_filter_over_a_loop_of_no_length_is_the_loop_s_extreme():
    # a hole the map squeezed to a point: its window covers the whole loop (it ran out of memory before)
    rng = np.random.default_rng(0)
    t = rng.random(7)
    for span in (0.0, 1e-300, 1e-12):
        arc = np.linspace(0.0, span, 7, endpoint=False)
        np.testing.assert_array_equal(_arc_filter(t, arc, span, 1.0, np.maximum), t.max())
        np.testing.assert_array_equal(_arc_filter(t, arc, span, 1.0, np.minimum), t.min())
    local = _arc_filter(t, np.arange(7.0), 7.0, 0.4, np.maximum)  # a window shorter than the loop: local
    assert np.all(local >= t) and np.all(local <= t.max()) and local.min() < t.max()


@pytest.mark.slow
@pytest.mark.skipif(find_data(PELVIS) is None, reason=f"{PELVIS}: {MISSING_DATA}")
def test_the_repaired_pelvis_is_approximated_over_the_harmonic_map():
    m = read_mesh(find_data(PELVIS))
    r = repair_mesh(m.V, m.F)
    res = approximate_surface(r.V, r.F, n_vertices=700)
    assert any("outline meets itself" in s for s in res.parameterization.messages)
    assert res.stats["vertices"] <= 700 and res.c1_residual < 1e-12


def _tube(around: int = 60, along: int = 20) -> tuple[np.ndarray, np.ndarray]:
    """An open cylinder of radius 1 and height 1: two boundary loops of ``around`` vertices."""
    a, h = np.meshgrid(np.arange(around) * 2 * np.pi / around, np.linspace(0.0, 1.0, along))
    V = np.column_stack([np.cos(a.ravel()), np.sin(a.ravel()), h.ravel()])
    i, j = np.meshgrid(np.arange(along - 1), np.arange(around), indexing="ij")
    p, q = i * around + j, i * around + (j + 1) % around
    F = np.concatenate([np.column_stack([p.ravel(), q.ravel(), (q + around).ravel()]),
                        np.column_stack([p.ravel(), (q + around).ravel(), (p + around).ravel()])])
    return V, F


@pytest.mark.parametrize("along, height, used", [(20, 1.0, "spectral"), (30, 0.5, "harmonic")])
def test_an_open_tube_keeps_both_ends_open(along, height, used):
    """The spectral map takes the first tube to an annulus and folds the second, which gives way to the
    harmonic map (pinned LSCM overlapped the first and squeezed the second)."""
    V, F = _tube(along=along)
    V[:, 2] *= height
    res = approximate_surface(V, F, tolerance_rel=1e-3)
    assert used in (res.parameterization.method, res.parameterization.repaired)
    assert len(res.domain.loops) == 2 and not any("spanned" in m for m in res.parameterization.messages)
    assert surface_reach(np.asarray(res.surface.ctrl), V, 0.1) < 0.05  # no cap over an end (it stood 0.2 out)
    assert res.stats["met"]


def test_a_wide_hole_the_map_squeezes_shut_is_kept_by_the_harmonic_map(monkeypatch):
    V, F = _tube(along=12)
    top = np.arange(11 * 60, 12 * 60)[::-1]
    real, calls = pipeline.folded_holes, []

    def squeezed(uv, faces, loops):  # as LSCM leaves a tube's second end: a hole of (nearly) no area
        calls.append(1)
        return [top] if len(calls) == 1 else real(uv, faces, loops)

    monkeypatch.setattr(pipeline, "folded_holes", squeezed)
    uv, faces, p = pipeline._domain_uv(V, F, None, "lscm")
    assert p.method == "harmonic" and "wide in space (first: 60 vertices around)" in p.messages[0]
    assert faces.shape == F.shape  # nothing spanned


def test_a_hole_s_width_is_a_circle_s_radius_and_a_crack_s_gap():
    t = np.arange(40) * 2 * np.pi / 40
    circle = np.column_stack([2 * np.cos(t), 2 * np.sin(t), 0 * t])
    assert hole_width(circle, np.arange(40)) == pytest.approx(2.0, rel=0.01)
    x = np.linspace(0.0, 10.0, 21)
    crack = np.concatenate([np.column_stack([x, 0 * x, 0 * x]), np.column_stack([x[::-1], 0 * x + 0.3, 0 * x])])
    assert hole_width(crack, np.arange(42)) == pytest.approx(0.3, rel=0.05)
    assert [len(w) for w in wide_holes(circle, [np.arange(40)])] == [40]  # radius 2 / spacing 0.31 > WIDE_HOLE
    assert wide_holes(crack, [np.arange(42)]) == [] and WIDE_HOLE > 0.3 / 0.5
