"""Results do not depend on where the mesh lies, how large it is, or how its file lists it.

* A rigid motion or a uniform scale of the mesh moves or scales the fitted surface the same way:
  control points to ``1e-9`` of the bounding-box diagonal (interpolating fit, both maps), the
  approximation's choices (coarse vertices, verdict, deviation over the diagonal) unchanged, and the
  energies scale like the size squared.
* A tile in real map coordinates (UTM offsets) fits as well as the same stored data at the origin:
  the difference is a few roundings of its coordinates.
* Renumbered vertices, shuffled faces and flipped orientation give the same surface; unreferenced or
  duplicated (unwelded) vertices are refused with the reason.
"""
from __future__ import annotations

from functools import lru_cache

import jax
import numpy as np
import pytest
from scipy.spatial import Delaunay
from scipy.spatial.transform import Rotation

jax.config.update("jax_enable_x64", True)

from trispline.fit import fit_surface  # noqa: E402
from trispline.fit.approx import approximate_surface  # noqa: E402
from trispline.fit.datasets.franke import exponential, sample_points  # noqa: E402
from trispline.spline.errors import InputError  # noqa: E402
from trispline.spline.testing.domains import orient_ccw  # noqa: E402

#: Control points of the interpolating fit agree to this fraction of the diagonal (measured: up to 1.7e-9,
#: the LSCM map of the sphere cap turned; 4e-12 or less elsewhere).
FIT_RTOL = 4e-9
#: UTM-like offsets of a terrain tile: easting, northing, height.
UTM = np.array([5e5, 5e6, 300.0])
#: At such offsets the stored coordinates are rounded to ulp(5e6) ~ 9e-10; the fit may cost this many of them.
UTM_ULPS = 32


def height_field(n: int = 150, seed: int = 4) -> tuple[np.ndarray, np.ndarray]:
    """Franke's exponential over ``n`` random points of the unit square."""
    p = sample_points(n, seed=seed)
    return np.column_stack([p, exponential(p[:, 0], p[:, 1])]), orient_ccw(p, Delaunay(p).simplices)


def sphere_cap(n: int = 160, seed: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """A cap of a sphere of radius 1.5 (polar angles to 0.9 rad) over random points, with a hole."""
    rng = np.random.default_rng(seed)
    t = np.sort(rng.uniform(0, 2 * np.pi, 40))
    r = np.sqrt(rng.uniform(0, 0.9, n))
    a = rng.uniform(0, 2 * np.pi, n)
    p = np.vstack([np.column_stack([r * np.cos(a), r * np.sin(a)]), np.column_stack([np.cos(t), np.sin(t)])])
    F = orient_ccw(p, Delaunay(p).simplices)
    F = F[np.linalg.norm(p[F].mean(1) - [0.3, 0.1], axis=1) > 0.25]  # the hole
    used = np.unique(F)
    p, F = p[used], np.searchsorted(used, F)
    rho = np.linalg.norm(p, axis=1, keepdims=True)
    polar = 0.9 * rho
    return np.column_stack([1.5 * np.sin(polar) * p / np.maximum(rho, 1e-300), 1.5 * np.cos(polar)]), F


def regular_grid(n: int = 12) -> tuple[np.ndarray, np.ndarray]:
    """A height field on an exact ``n x n`` grid: many neighbours at equal distances (a terrain tile's DEM),
    whose roundings once picked the local fits' neighbours (a harmonic fit moved 7.7e-4 of the diagonal)."""
    t = np.linspace(0.0, 1.0, n + 1)
    x, y = (a.ravel() for a in np.meshgrid(t, t, indexing="ij"))
    i, j = (a.ravel() for a in np.meshgrid(np.arange(n), np.arange(n), indexing="ij"))
    a, b, c, d = i * (n + 1) + j, (i + 1) * (n + 1) + j, (i + 1) * (n + 1) + j + 1, i * (n + 1) + j + 1
    F = np.concatenate([np.column_stack([a, b, c]), np.column_stack([a, c, d])])
    return np.column_stack([x, y, 0.1 * np.sin(3 * x) * np.cos(2 * y)]), F


MESHES = {"height field": height_field, "sphere cap with a hole": sphere_cap, "regular grid": regular_grid}


def diagonal(V: np.ndarray) -> float:
    return float(np.linalg.norm(np.ptp(V, axis=0)))


def motion(name: str) -> tuple[float, np.ndarray, np.ndarray]:
    """``(scale, rotation (3, 3), translation (3,))``: ``V -> scale * V @ R.T + t``."""
    turn = Rotation.random(random_state=7).as_matrix()  # seeded: the same angles every run
    return {"millimetres": (1e-3, np.eye(3), np.zeros(3)), "kilometres": (1e3, np.eye(3), np.zeros(3)),
            "shifted": (1.0, np.eye(3), np.array([1e3, -1e3, 1e3])),
            "turned": (1.0, turn, np.array([0.3, -2.0, 1.0])),
            "turned and scaled": (1e3, turn, np.array([-4.0, 2.0, 7.0]))}[name]


MOTIONS = ("millimetres", "kilometres", "shifted", "turned", "turned and scaled")


@lru_cache(maxsize=None)
def fitted(mesh: str, param: str):
    V, F = MESHES[mesh]()
    return V, F, fit_surface(V, F, param=param)


def stored(V: np.ndarray, t: np.ndarray) -> np.ndarray:
    """``V`` as a file at offset ``t`` stores it, moved back (exactly: ``(V + t) - t``): what a fit at that
    offset is compared with, as the offset's own rounding of the input is not the fit's doing."""
    return (V + t) - t


@pytest.mark.parametrize("param", ["spectral", "harmonic"])
@pytest.mark.parametrize("mesh", list(MESHES))
@pytest.mark.parametrize("move", MOTIONS)
def test_fit_moves_and_scales_with_the_mesh(mesh, param, move):
    V, F, base = fitted(mesh, param)
    s, R, t = motion(move)
    if move == "shifted":
        V = stored(V, t)
        base = fit_surface(V, F, param=param)
    res = fit_surface(s * V @ R.T + t, F, param=param)
    assert np.array_equal(res.faces, base.faces)
    expected = s * base.ctrl @ R.T + t
    assert np.abs(res.ctrl - expected).max() <= FIT_RTOL * s * diagonal(V)
    assert res.c1_residual <= 1e-9 and res.max_interpolation_error == 0.0  # what `trispline check` asks
    for term, energy in base.energies.items():  # data units: length squared
        assert res.energies[term] == pytest.approx(s**2 * energy, rel=1e-6, abs=1e-12 * s**2)


@pytest.mark.parametrize("mesh", list(MESHES))
def test_fit_at_map_coordinates_is_as_good_as_at_the_origin(mesh):
    """A tile stored at UTM offsets: compared with the fit of the same stored data moved back (the
    offset's own rounding of the input is not the fit's), within a few roundings of its coordinates."""
    V, F = MESHES[mesh]()
    W = V + UTM
    at_origin = fit_surface(stored(V, UTM), F)
    res = fit_surface(W, F)
    ulp = np.spacing(np.abs(W).max())
    assert np.abs(res.ctrl - (at_origin.ctrl + UTM)).max() <= UTM_ULPS * ulp
    assert res.max_interpolation_error == 0.0
    # C1 to the rounding of the stored coordinates, as `trispline check` allows far from the origin
    assert res.c1_residual <= UTM_ULPS * ulp / diagonal(V)
    assert res.energies["bend"] == pytest.approx(at_origin.energies["bend"], rel=1e-6)


def permuted(V, F, how: str, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(V', F', old)``: the same mesh listed otherwise; ``old[i]`` is the input vertex of vertex ``i``."""
    if how == "vertices renumbered":
        old = rng.permutation(len(V))
        return V[old], np.argsort(old)[F], old
    if how == "faces shuffled":
        return V, F[rng.permutation(len(F))], np.arange(len(V))
    return V, F[:, ::-1], np.arange(len(V))  # every face flipped


def same_surface(a, b, old: np.ndarray, rng: np.random.Generator) -> float:
    """Largest distance between surfaces ``a`` and ``b`` (FitResults over the same triangles; ``old``:
    the vertex of ``a`` of each vertex of ``b``) at random points of every triangle."""
    index = {tuple(sorted(f)): i for i, f in enumerate(a.faces)}
    fb = old[b.faces]
    fa = np.array([index[tuple(sorted(f))] for f in fb])
    bary = rng.dirichlet(np.ones(3), len(fb))
    bary_a = np.zeros_like(bary)
    for k in range(3):  # the same point in a's vertex order
        slot = np.argmax(a.faces[fa] == fb[:, k:k + 1], axis=1)
        bary_a[np.arange(len(fb)), slot] = bary[:, k]
    return float(np.abs(b.surface.evaluate(np.arange(len(fb)), bary) - a.surface.evaluate(fa, bary_a)).max())


LSCM_PINS = pytest.mark.xfail(strict=True, reason=(
    "param.methods.far_apart starts its farthest-point sweeps at the outline's lowest vertex id, and LSCM's map "
    "depends on its two pins beyond a similarity: renumbered vertices move the pins (the face order does not); "
    "the spectral map has no pins"))
LISTINGS = [(param, how) for param in ("lscm", "spectral", "harmonic")
            for how in ("vertices renumbered", "faces shuffled", "faces flipped")]


@pytest.mark.parametrize("param, how", [pytest.param(*case, marks=LSCM_PINS) if case == ("lscm", "vertices renumbered")
                                        else case for case in LISTINGS])
def test_fit_does_not_depend_on_how_the_file_lists_the_mesh(param, how):
    V, F, base = fitted("sphere cap with a hole", param)
    rng = np.random.default_rng(11)
    W, G, old = permuted(V, F, how, rng)
    res = fit_surface(W, G, param=param)
    assert same_surface(base, res, old, rng) <= FIT_RTOL * diagonal(V)


def test_unreferenced_vertices_are_named():
    V, F = sphere_cap()
    extra = np.random.default_rng(2).normal(size=(3, 3))
    with pytest.raises(InputError, match=rf"vertices used by no face: 3 \(first: {len(V)}, "):
        fit_surface(np.vstack([V, extra]), F)


def test_an_unwelded_mesh_is_refused_with_the_cure():
    V, F = sphere_cap()
    with pytest.raises(InputError, match="exactly on a vertex of another component.*merge them"):
        fit_surface(V[F.ravel()], np.arange(F.size).reshape(-1, 3))


@lru_cache(maxsize=None)
def approximated(how: str):
    V, F = height_field(300, seed=2)
    V = stored(V, UTM)  # the map-coordinates case compares with the data its file stores
    kw = dict(tolerance_rel=1e-3) if how == "tolerance" else dict(n_vertices=30)
    return V, F, kw, approximate_surface(V, F, **kw)


AT_MAP_COORDINATES = pytest.param("map coordinates", marks=pytest.mark.xfail(strict=False, reason=(
    "the approximation's fit works in the scan's own coordinates: at UTM offsets its control points move by "
    "2e-6 (tolerance) / 5e-6 (budget) of the diagonal and its bending energy by 4e-7 / 1.1e-5, over the same "
    "domain and coarse vertices")))


@pytest.mark.parametrize("how", ["tolerance", "budget"])
@pytest.mark.parametrize("move", ["millimetres", "kilometres", "turned", AT_MAP_COORDINATES])
def test_approximation_makes_the_same_choices_wherever_the_mesh_lies(how, move):
    V, F, kw, base = approximated(how)
    s, R, t = (1.0, np.eye(3), UTM) if move == "map coordinates" else motion(move)
    res = approximate_surface(s * V @ R.T + t, F, **kw)
    assert np.array_equal(res.vertices, base.vertices)
    for key in ("vertices", "patches", "met", "stop", "rejected", "rounds"):
        assert res.stats[key] == base.stats[key], key
    dev, dev0 = res.stats["deviation"], base.stats["deviation"]
    for key in ("max", "rms"):  # to 1e-7 of the diagonal (measured at map coordinates: 3.6e-8; else 1e-13)
        assert dev[key] / s == pytest.approx(dev0[key], abs=1e-7 * diagonal(V)), key
    assert res.energies["bend"] / s**2 == pytest.approx(base.energies["bend"], rel=1e-6)
    assert np.abs((res.ctrl - t) @ R / s - base.ctrl).max() <= 1e-6 * diagonal(V)


FLIPPED_OUTLINE = pytest.mark.xfail(strict=True, reason=(
    "the outline's thinning (fit.approx.boundary.thin_loop) spaces its kept vertices walking each loop in its "
    "orientation: a scan with every face flipped has its loops reversed and keeps other outline vertices"))


@pytest.mark.parametrize("how", ["faces shuffled", pytest.param("faces flipped", marks=FLIPPED_OUTLINE)])
def test_approximation_does_not_depend_on_the_face_order(how):
    """The default map has no pins and every boundary loop starts at its lowest vertex id, so the coarse
    vertices, the verdict and the surface are those of the file's own order (halftunnel.off met its tolerance
    in its file's order and missed it by 1.4x shuffled, when LSCM's pins followed the first boundary edge)."""
    V, F, kw, base = approximated("tolerance")
    W, G, _ = permuted(V, F, how, np.random.default_rng(5))
    res = approximate_surface(W, G, **kw)
    assert np.array_equal(np.sort(res.vertices), np.sort(base.vertices))
    for key in ("vertices", "patches", "met", "stop", "rejected", "rounds"):
        assert res.stats[key] == base.stats[key], key
    for key in ("max", "rms"):
        assert res.stats["deviation"][key] == pytest.approx(base.stats["deviation"][key], abs=1e-9 * diagonal(V))
