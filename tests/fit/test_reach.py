"""A surface stays at its scan: an approximation passes over a data weight whose surface overshoots between the
scan's points, makes a map the smoothing folded of the scan itself and reports a surface that still strays; an
interpolating fit reports its overshoot through a spike."""
from __future__ import annotations

import itertools
import json

import numpy as np
import pytest
import trimesh
from trispline.fit.approx import approximate_surface
from trispline.fit.approx import fit as approx_fit
from trispline.fit.approx.pipeline import WILD_REACH
from trispline.fit.cli import main
from trispline.fit.reach import box_reach, surface_reach
from trispline.fit.pipeline import OVERSHOOT
from trispline.spline.testing.domains import grid, slivered_hull


def far_ramp() -> tuple[np.ndarray, np.ndarray]:
    """A steep ramp (5 tanh(20 (x - 1/2)) over the unit square's criss-cross grid of 85 vertices) at coordinates
    near 1e6, rounded as an OBJ file stores them: cross-validation once scored 3e4 best, whose surface spiked 0.69
    diagonals above the scan between its vertices (while the local analysis took equally distant neighbours in
    the order of their roundings)."""
    P, F = grid(7, diagonal="crisscross")
    return np.round(np.c_[P, 5.0 * np.tanh(20.0 * (P[:, 0] - 0.5))] + 1e6, 8), F


def flat_slivers(seed: int) -> tuple[np.ndarray, np.ndarray]:
    """A flat scan: 30 points of the unit square and 8 hull points 1 to 100 above it (slivers of aspect 1e3)."""
    P, F = slivered_hull(30, 8, 1e-3, 5.0, seed=seed)
    return np.c_[P, np.zeros(len(P))], F


def test_the_reach_of_a_surface_is_its_distance_outside_the_box_in_diagonals():
    V = np.array([[0.0, 0.0, 0.0], [3.0, 4.0, 0.0]])  # diagonal 5
    assert box_reach(np.array([[1.0, 1.0, 0.0], [3.0, 9.0, 0.0], [-3.0, -4.0, 0.0]]), V) == pytest.approx([0, 1, 1])
    ctrl = np.zeros((1, 21, 3))
    ctrl[0, 0] = [0.0, 14.0, 0.0]  # a corner point of the patch: the surface goes there
    assert surface_reach(ctrl, V, 0.5) == pytest.approx(2.0)
    ctrl[0, 0] = [0.0, 4.0, 0.0]
    assert surface_reach(ctrl, V, 0.5) == 0.0


def test_a_weight_whose_surface_overshoots_between_the_scan_points_is_passed_over(monkeypatch):
    V, F = far_ramp()
    plain = approximate_surface(V, F, tolerance_rel=3e-3)
    assert plain.stats["met"] and plain.stats["reach"] <= WILD_REACH
    chosen = approx_fit.DATA_WEIGHTS.index(plain.stats["data_weight"])
    calls = itertools.count()  # each cross-validation judges every candidate weight once, in DATA_WEIGHTS's order
    measured = approx_fit.surface_reach

    def overshooting(ctrl, V, limit):  # the weight cross-validation chose makes a surface 0.69 diagonals out
        return 0.69 if next(calls) % len(approx_fit.DATA_WEIGHTS) == chosen else measured(ctrl, V, limit)

    monkeypatch.setattr(approx_fit, "surface_reach", overshooting)
    guarded = approximate_surface(V, F, tolerance_rel=3e-3)
    assert guarded.stats["met"] and guarded.stats["reach"] <= WILD_REACH
    assert guarded.stats["data_weight"] != plain.stats["data_weight"]


def test_a_map_the_smoothing_folds_is_made_of_the_scan_itself():
    V, F = flat_slivers(seed=2)
    r = approximate_surface(V, F, tolerance_rel=3e-3)
    assert any("the map of the scan itself is used" in m for m in r.parameterization.messages)
    P1 = np.c_[V[:, :2], np.ones(len(V))]  # LSCM of a flat scan: a similarity of its plane
    A, *_ = np.linalg.lstsq(P1, r.parameterization.uv, rcond=None)
    assert np.abs(P1 @ A - r.parameterization.uv).max() <= 1e-9 * np.ptp(r.parameterization.uv)
    assert r.stats["reach"] <= 1e-9 and np.abs(np.asarray(r.ctrl)[..., 2]).max() <= 1e-12


def test_a_surface_that_strays_from_its_scan_is_reported(tmp_path, capsys):
    V, F = flat_slivers(seed=9)  # its smoothing folds nothing, but drags vertices across the slivers
    path = tmp_path / "flat.obj"
    trimesh.Trimesh(V, F, process=False).export(path)
    rc = main(["fit", str(path), "-o", str(tmp_path / "s.npz"), "--tolerance-rel", "3e-3", "--json"])
    out, err = capsys.readouterr()
    line = next(x for x in err.splitlines() if "the surface strays" in x)
    assert rc == 0 and "bounding-box diagonals outside the scan's box" in line and "--repair peels them" in line
    assert json.loads(out)["reach"] == pytest.approx(float(line.split("strays ")[1].split()[0]), rel=0.05)
    assert json.loads(out)["reach"] > WILD_REACH


def test_an_interpolant_through_a_spike_of_coarse_data_reports_its_overshoot(tmp_path, capsys):
    P, F = grid(10)
    z = 0.1 * np.sin(3.0 * P[:, 0])
    z[55] += 3.0  # one vertex far above a gentle wave
    path = tmp_path / "spike.obj"
    trimesh.Trimesh(np.c_[P, z], F, process=False).export(path)
    rc = main(["fit", str(path), "-o", str(tmp_path / "s.npz"), "--json"])
    out, err = capsys.readouterr()
    assert rc == 0 and json.loads(out)["reach"] > OVERSHOOT
    assert "the surface overshoots the scan's box by" in err and "--tolerance-rel" in err
    z[55] -= 3.0
    trimesh.Trimesh(np.c_[P, z], F, process=False).export(path)
    assert main(["fit", str(path), "-o", str(tmp_path / "s.npz"), "--json"]) == 0
    out, err = capsys.readouterr()
    assert json.loads(out)["reach"] < 1e-3 and "overshoots" not in err
