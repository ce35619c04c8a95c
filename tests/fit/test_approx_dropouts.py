"""Scanner dropouts in the approximation: small holes kept by default (each costs coarse vertices and leaves a
hole in the surface), spanned with ``fill_holes`` so that the surface goes over them as over the rest of
the scan; the command line suggests it."""
from __future__ import annotations

import json

import numpy as np
import pytest
import trimesh
from trispline.fit.approx import approximate_surface
from trispline.fit.approx.holes import SMALL_HOLE, small_holes
from trispline.fit.cli import main
from trispline.spline.errors import InputError
from trispline.spline.topology import Triangulation

N = 30  # grid side


def wavy_grid() -> tuple[np.ndarray, np.ndarray]:
    """``(V (N^2, 3), F)``: a wavy height field over the unit square's grid, two triangles a cell."""
    x, y = np.meshgrid(np.linspace(0, 1, N), np.linspace(0, 1, N))
    a = (np.arange(N - 1)[None, :] + N * np.arange(N - 1)[:, None]).ravel()
    F = np.concatenate([np.column_stack([a, a + 1, a + N + 1]), np.column_stack([a, a + N + 1, a + N])])
    return np.column_stack([x.ravel(), y.ravel(), 0.1 * np.sin(3 * x.ravel()) * np.cos(2 * y.ravel())]), F


def dropouts(F: np.ndarray, count: int) -> np.ndarray:
    """``(count,)`` faces far from the outline and from each other (cells 4 apart): one-face holes."""
    cells = [(i, j) for i in range(4, N - 5, 4) for j in range(4, N - 5, 4)][:count]
    return np.array([i * (N - 1) + j for i, j in cells])


def loops(r) -> int:
    return len(Triangulation(r.domain.uv, r.domain.faces).boundary_loops)


def test_filled_dropouts_give_the_fit_of_the_scan_without_them():
    V, F = wavy_grid()
    drop = dropouts(F, 9)
    holed = np.delete(F, drop, axis=0)
    assert len(small_holes(V, holed, 3)) == 9 and not small_holes(V, holed, 2)
    kept = approximate_surface(V, holed, tolerance_rel=1e-3)
    filled = approximate_surface(V, holed, tolerance_rel=1e-3, fill_holes=3)
    whole = approximate_surface(V, np.concatenate([holed, F[drop]]), tolerance_rel=1e-3)
    assert loops(kept) == 10 and kept.stats["small_holes"] == 9 and kept.stats["holes_filled"] == 0
    assert loops(filled) == 1 and filled.stats["small_holes"] == 0 and filled.stats["holes_filled"] == 9
    assert kept.stats["vertices"] >= whole.stats["vertices"] + 9  # each hole keeps vertices of its own
    assert filled.stats["vertices"] == whole.stats["vertices"] and filled.stats["met"]
    assert filled.stats["deviation"]["max"] == pytest.approx(whole.stats["deviation"]["max"], rel=1e-3)
    assert filled.parameterization.messages[0].startswith("filled 9 holes of the scan with at most 3 vertices")


def test_only_holes_up_to_the_size_are_filled_and_the_outline_never():
    V, F = wavy_grid()
    small = dropouts(F, 1)
    block = [(20 * (N - 1) + j) + k * (N - 1) ** 2 for j in (20, 21) for k in (0, 1)]  # two cells
    holed = np.delete(F, np.r_[small, block], axis=0)  # a 3-vertex hole and a 6-vertex one
    sizes = sorted(h.size for h in small_holes(V, holed, 200))
    assert sizes == [3, 6]  # the outline (116 vertices) is never a hole
    r = approximate_surface(V, holed, tolerance_rel=1e-3, fill_holes=4)
    assert r.stats["holes_filled"] == 1 and loops(r) == 2 and r.stats["met"]


@pytest.mark.parametrize("value", [-1, 2.5, True, "3"])
def test_bad_fill_holes_is_refused(value):
    V, F = wavy_grid()
    with pytest.raises(InputError, match="fill_holes must be an integer >= 0"):
        approximate_surface(V, F, tolerance_rel=1e-3, fill_holes=value)


def test_fill_holes_needs_trispline_s_own_map():
    V, F = wavy_grid()
    holed = np.delete(F, dropouts(F, 2), axis=0)
    with pytest.raises(InputError, match="fill_holes needs trispline's own map"):
        approximate_surface(V, holed, tolerance_rel=1e-3, uv=V[:, :2], fill_holes=3)


def test_the_command_line_suggests_and_fills(tmp_path, capsys):
    V, F = wavy_grid()
    path = tmp_path / "drops.ply"
    trimesh.Trimesh(V, np.delete(F, dropouts(F, 4), axis=0), process=False).export(path)
    rc = main(["fit", str(path), "-o", str(tmp_path / "a.npz"), "--tolerance-rel", "1e-3", "-q"])
    err = capsys.readouterr().err
    assert rc == 0 and f"has 4 holes with at most {SMALL_HOLE} vertices around" in err
    rc = main(["fit", str(path), "-o", str(tmp_path / "b.npz"), "--tolerance-rel", "1e-3", "-q", "--json",
               "--fill-holes", str(SMALL_HOLE)])
    out, err = capsys.readouterr()
    d = json.loads(out)
    assert rc == 0 and d["holes_filled"] == 4 and d["small_holes"] == 0 and "--fill-holes" not in err
    rc = main(["fit", str(path), "-o", str(tmp_path / "c.npz"), "--fill-holes", "3"])
    assert rc == 2 and "--fill-holes needs --tolerance" in capsys.readouterr().err
    assert not (tmp_path / "c.npz").exists()


def test_info_counts_the_small_holes(tmp_path, capsys):
    from trispline.param import inspect_mesh

    V, F = wavy_grid()
    holed = np.delete(F, dropouts(F, 3), axis=0)
    assert inspect_mesh(V, holed)["small_holes"] == 3 and inspect_mesh(V, F)["small_holes"] == 0
    path = tmp_path / "drops.ply"
    trimesh.Trimesh(V, holed, process=False).export(path)
    assert main(["info", str(path)]) == 0
    assert f"holes 3 (3 with at most {SMALL_HOLE} vertices around: fit --fill-holes" in capsys.readouterr().out
