"""Real meshes: valid ones fold-free under harmonic and LSCM, the pelvis rejected.

The generated real-world-like scan (:func:`trispline.fit.datasets.face.face_scan`) runs in
every clone; the meshes of ../shared/data (or their copy in the cache folder,
:mod:`trispline.fit.datasets.cache`) where present, else they are skipped with the reason
and the command that brings them (``pytest -ra`` lists them). Meshes above 20k faces are
marked slow.
"""
from __future__ import annotations

import numpy as np
import pytest

from trispline.fit.datasets.cache import MISSING_DATA, find_data
from trispline.fit.datasets.face import face_scan
from trispline.fit.io import read_mesh
from trispline.param import MeshError, fold_mask, harmonic_uv, parameterize, validate_mesh
from trispline.spline.topology import Triangulation, signed_areas

VALID = {  # name: (faces, holes)
    "snail.obj": (1653, 0),
    "halftunnel.off": (1568, 2),
    "inspired_mesh.obj": (4288, 0),
    "lilium.obj": (6590, 0),
    "camelhead.off": (22704, 0),
    "face_gpjs.obj": (34144, 0),
    "beetle.off": (38656, 10),
    "mountain.obj": (50562, 0),
}
#: The generated scan: its faces and holes (face_scan(4000, seed=0)).
GENERATED = (4080, 1)


def needs_data(name: str) -> pytest.MarkDecorator:
    """Skip, with the reason and the command that brings the data, when ``name`` is in no data folder."""
    return pytest.mark.skipif(find_data(name) is None, reason=f"{name}: {MISSING_DATA}")


def data_mesh(name: str):
    """``read_mesh`` of the shared mesh ``name`` (the tests that call it are marked :func:`needs_data`)."""
    return read_mesh(find_data(name))


def _cases():
    for method in ("harmonic", "lscm"):
        yield pytest.param("generated", method, id=f"generated-{method}")
    for name, (nf, _) in VALID.items():
        for method in ("harmonic", "lscm"):
            marks = [needs_data(name)] + ([pytest.mark.slow] if nf > 20000 else [])
            yield pytest.param(name, method, marks=marks, id=f"{name}-{method}")


@pytest.mark.parametrize("name,method", list(_cases()))
def test_data_mesh_fold_free(name, method):
    if name == "generated":
        V, F = face_scan(4000, seed=0)
        nf, holes = GENERATED
    else:
        m = data_mesh(name)
        V, F = m.V, m.F
        nf, holes = VALID[name]
    assert F.shape[0] == nf
    p = parameterize(V, F, method)
    np.testing.assert_array_equal(p.faces, F)  # never reordered
    Triangulation(p.uv, p.faces)
    fl, dg = fold_mask(p.uv, p.faces)
    assert not fl.any() and not dg.any()
    assert p.report["holes"] == holes
    assert np.all(np.isfinite([v for v in p.distortion.values()]))


@needs_data("beetle.off")
@pytest.mark.slow
def test_beetle_free_holes_fold_but_filled_holes_do_not():
    m = data_mesh("beetle.off")
    vm = validate_mesh(m.V, m.F)
    outer = vm.boundary_loops[0]
    free = harmonic_uv(vm.V, vm.F, outer)
    n_folded = int((signed_areas(free, vm.F) <= 0).sum())
    assert n_folded == 162  # the documented failure of leaving the holes free
    p = parameterize(m.V, m.F, "harmonic")
    assert p.repaired is None and p.distortion["flipped_before_repair"] == 0


@needs_data("pelvis-registration-partial.obj")
def test_pelvis_rejected():
    m = data_mesh("pelvis-registration-partial.obj")
    with pytest.raises(MeshError) as e:
        validate_mesh(m.V, m.F)
    msg = str(e.value)
    assert "4 connected components" in msg and "keep-largest" in msg
    assert "non-manifold (bowtie) vertices" in msg and ": 27 (first:" in msg
    assert set(e.value.kinds) == {"components", "bowtie_vertices"}
    with pytest.raises(MeshError, match="bowtie"):
        parameterize(m.V, m.F, "harmonic")
    with pytest.raises(MeshError, match=r"bowtie\) vertices.*: 22 \(first"):
        validate_mesh(m.V, m.F, keep_largest=True)  # the largest component still has bowties


@needs_data("mountain.obj")
@pytest.mark.slow
def test_mountain_is_a_y_up_height_field():
    m = data_mesh("mountain.obj")
    with pytest.raises(MeshError, match=r"folds \d+ triangles.*pass uv=V\[:, \[0, 2\]\]"):
        parameterize(m.V, m.F, "uv", repair=False)
    p = parameterize(m.V, m.F, "uv", uv=m.V[:, [0, 2]])
    assert p.repaired is None and p.transform.mirrored  # (x, z) is clockwise seen from +y
    np.testing.assert_allclose(p.transform.to_raw(p.uv), m.V[:, [0, 2]] * [-1.0, 1.0], atol=1e-9)
    Triangulation(p.uv, p.faces)
