"""Local editing of a fitted C1 spline surface (the paper's section 5.3).

    python examples/03_local_edit.py

1. fit a height field, 2. pull one near-corner inner point and one flip point
(O(1) edits: only the neighbouring patches change), 3. a dependent point is refused
with the names of the free points that control it, 4. move a data vertex and
re-fair its 2-ring locally, compared with a global refit. Runs in seconds.
"""
from __future__ import annotations

import time

import jax
import numpy as np

from trispline.fit.pipeline import fit_surface
from trispline.fit.refair import LocalRefairer, fairness_energy
from trispline.spline.testing import domains
from trispline.spline.continuity import continuity_report
from trispline.spline.edit import DependentPointError, SplineEditor

jax.config.update("jax_enable_x64", True)

uv, faces = domains.random_delaunay(150, seed=2)
V = np.column_stack([uv, 0.3 * np.sin(3 * uv[:, 0]) * np.cos(2 * uv[:, 1])])
result = fit_surface(V, faces, uv=uv)
ed = SplineEditor.from_fit(result)
t = ed.space.tri
print(f"fitted: {t.n_faces} patches, {ed.space.n_free} free points")

# 2. an inner point near the corner of a face at the central vertex c, then a flip point
c = int(np.argmin(np.linalg.norm(uv - 0.5, axis=1)))
f0 = int(ed.vertex_faces(c)[0])
j = ed.inner_point(f0, int(np.flatnonzero(t.faces[f0] == c)[0]))
t0 = time.perf_counter()
res = ed.translate(j, [0.0, 0.0, 0.05])
print(f"moved {ed.describe_free(j)}: {res.points.size} control points and patches "
      f"{res.faces.tolist()} recomputed in {(time.perf_counter() - t0) * 1e6:.0f} us")
e = int(t.interior_edges[5])
side = 0 if ed.point_free_id(ed.space.layout.flip(t.edge_faces[e, 0], t.edge_opposite[e, 0])) >= 0 else 1
res = ed.translate(ed.flip_point(t.edge_faces[e, side], t.edge_opposite[e, side]), [0.0, 0.0, -0.05])
print(f"moved a flip point of edge {e}: patches {res.faces.tolist()} (the edge's two)")
assert set(res.faces.tolist()) == set(t.edge_faces[e].tolist())

# 3. a star point is computed from its corner region: refused, naming its controllers
try:
    ed.move_point(int(ed.space.layout.star(e, 0)), [0.0, 0.0, 1.0])
except DependentPointError as err:
    print("refused:", str(err)[:160], "...")

# every edit equals a full rebuild, bit for bit, and the surface stays C1
np.testing.assert_array_equal(ed.ctrl, ed.space.control_points(ed.free))
assert continuity_report(t, ed.ctrl)["c1_relative"] < 1e-10

# 4. move a data vertex, re-fair its 2-ring, compare with a global refit
v = c
xyz = V[v] + [0.0, 0.0, 0.2]
rf = LocalRefairer.from_fit(result, rings=2)
t0 = time.perf_counter()
out = rf.move_vertex(v, xyz)
t_local = time.perf_counter() - t0
V2 = rf.V
t0 = time.perf_counter()
refit = fit_surface(V2, faces, uv=uv)
t_global = time.perf_counter() - t0
e_local = rf.energy()["total"]
e_global = fairness_energy(refit.space, refit.free, V2, result.weights)["total"]
moved = SplineEditor.from_fit(result)
moved.move_vertex(v, xyz)
e_edit = fairness_energy(moved.space, moved.free, V2, result.weights)["total"]
print(f"vertex {v} moved: {out.free_ids.size} free points in {out.region.size} patches re-faired "
      f"in {t_local * 1e3:.1f} ms (global refit {t_global:.2f} s)")
print(f"energy: edit only {e_edit:.4g}, local re-fair {e_local:.4g}, global refit {e_global:.4g}")
np.testing.assert_array_equal(rf.editor.free[v], xyz)  # interpolates the moved vertex
assert continuity_report(t, rf.editor.ctrl)["c1_relative"] < 1e-10
assert e_global * (1 - 1e-7) <= e_local <= e_edit
assert e_local - e_global < 0.05 * (e_edit - e_global)
print("ok")
