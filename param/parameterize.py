"""Planar parameterization of a validated open mesh: harmonic, LSCM or given uv.

Every method ends the same way: the map is mirrored if it came out globally
clockwise (faces are never reordered or reoriented), checked for flipped and
degenerate triangles, repaired if needed (:mod:`trispline.param.repair`), normalised
(centred at the bounding box centre, farthest vertex at distance 1) and checked again
with the exact test of :class:`trispline.spline.topology.Triangulation`. A folded
domain is never returned: :class:`MeshError` instead.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from trispline.spline.checks import as_array
from trispline.spline.errors import InputError, first_few
from trispline.spline.topology import signed_areas

from . import _igl
from .distortion import face_distortion, summarize
from .errors import MeshError
from .repair import fill_holes, fold_mask, polygon_area, repair_folds
from .validate import ValidatedMesh, validate_mesh

METHODS = ("harmonic", "lscm", "uv")
#: The parameterization of :func:`parameterize` and of ``fit_surface`` / ``trispline fit``
#: when none is named: LSCM keeps triangle shapes, which the C1 conditions depend on
#: (docs/param.md compares the methods on real meshes).
DEFAULT_METHOD = "lscm"


@dataclass(frozen=True)
class UVTransform:
    """``raw = uv * scale + centre``: from normalised uv back to the method's raw map.

    ``mirrored`` says the raw map was the method's output with ``u`` negated
    (it came out clockwise).
    """

    centre: np.ndarray
    scale: float
    mirrored: bool = False

    def to_raw(self, uv: np.ndarray) -> np.ndarray:
        """``(n, 2)`` normalised -> raw."""
        return np.asarray(uv) * self.scale + self.centre

    def from_raw(self, raw: np.ndarray) -> np.ndarray:
        """``(n, 2)`` raw -> normalised."""
        return (np.asarray(raw) - self.centre) / self.scale


@dataclass(frozen=True, eq=False)
class Parameterization:
    """A fold-free planar domain for a mesh.

    Attributes
    ----------
    uv : (nv, 2) float64
        Normalised: bounding-box centre at 0, farthest vertex at distance 1.
    faces : (nf, 3) int64
        The input faces, same rows in the same order (a row is reversed only where
        validation repaired inconsistent orientation; see ``messages``). CCW in uv.
    method : str
    boundary : (nb,) int64
        Outer boundary loop, counter-clockwise in uv.
    transform : UVTransform
    distortion : dict
        ``angle_p50/p90/p99/max`` (singular value ratio, 1 = conformal),
        ``area_p50/p90/p99/max`` (area share ratio, 1 = equiareal),
        ``flipped_before_repair``, ``degenerate_before_repair`` (face counts).
    repaired : str or None
        ``"tutte"`` or ``"composite_harmonic"`` when the first map folded.
    messages : list of str
    report : dict
        Validation counts (see :class:`ValidatedMesh`).
    """

    uv: np.ndarray
    faces: np.ndarray
    method: str
    boundary: np.ndarray
    transform: UVTransform
    distortion: dict
    repaired: str | None = None
    messages: list[str] = field(default_factory=list)
    report: dict = field(default_factory=dict)


# ----------------------------------------------------------------------- methods
def harmonic_uv(V: np.ndarray, F: np.ndarray, loop: np.ndarray) -> np.ndarray:
    """Harmonic map ``(nv, 2)``: ``loop (n,)`` onto the unit circle spaced by 3D arc length,
    the other vertices by ``igl.harmonic`` (cotangent weights). Holes other than ``loop``
    stay free (:func:`parameterize` fills them first)."""
    return _igl.harmonic(V, F, loop, _igl.circle_boundary(V, loop))


def normalise(raw: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """``(uv, centre (2,), scale)``: bounding-box centre to 0, farthest vertex to distance 1."""
    centre = 0.5 * (raw.min(0) + raw.max(0))
    scale = float(np.sqrt(((raw - centre) ** 2).sum(1).max()))
    if not np.isfinite(scale) or scale <= 0:
        raise MeshError("the parameterization collapsed to a point (zero extent)", ["degenerate_map"])
    return (raw - centre) / scale, centre, scale


def far_apart(V: np.ndarray, loop: np.ndarray) -> tuple[int, int]:
    """Two vertices of ``loop`` far apart (two sweeps of farthest-point search)."""
    P = V[loop]
    i = int(np.argmax(((P - P[0]) ** 2).sum(1)))
    j = int(np.argmax(((P - P[i]) ** 2).sum(1)))
    return int(loop[i]), int(loop[j])


def _raw_map(vm: ValidatedMesh, method: str, uv: np.ndarray | None) -> np.ndarray:
    V, F = vm.V, vm.F
    nv = V.shape[0]
    if method == "harmonic":
        Vx, Fx = fill_holes(V, F, vm.boundary_loops[1:])
        return harmonic_uv(Vx, Fx, vm.boundary_loops[0])[:nv]
    if method == "lscm":
        i, j = far_apart(V, vm.boundary_loops[0])
        d = float(np.linalg.norm(V[i] - V[j]))
        return _igl.lscm(V, F, np.array([i, j]), np.array([[0.0, 0.0], [d, 0.0]]))
    # method == "uv"
    if uv is None:
        return V[:, :2].copy()
    try:
        uv = as_array(uv, "uv", (nv, 2))
    except InputError as exc:
        raise MeshError(f"{exc} (one per vertex)", ["uv_shape"]) from None
    if not np.isfinite(uv).all():
        raise MeshError(f"non-finite uv at vertices {first_few(np.flatnonzero(~np.isfinite(uv).all(1)))}",
                        ["non_finite"])
    return uv.copy()


def _height_axes_hint(vm: ValidatedMesh) -> str:
    """When ``V[:, :2]`` folds, name another coordinate pair that is a fold-free projection."""
    for ax in ((0, 2), (1, 2)):
        a = signed_areas(vm.V[:, ax], vm.F)
        if (a > 0).all() or (a < 0).all():
            return (f" (V[:, :2] is not a height-field projection, but V[:, [{ax[0]}, {ax[1]}]] is: "
                    f"pass uv=V[:, [{ax[0]}, {ax[1]}]])")
    return ""


def parameterize(
    V: np.ndarray,
    F: np.ndarray,
    method: str = DEFAULT_METHOD,
    *,
    uv: np.ndarray | None = None,
    repair: bool = True,
) -> Parameterization:
    """Map an open genus-0 mesh to a fold-free planar triangulation.

    Parameters
    ----------
    V : (nv, 3) float64
    F : (nf, 3) int
    method : {"lscm", "harmonic", "uv"}
        ``lscm`` (:data:`DEFAULT_METHOD`): least squares conformal, two far-apart boundary
        vertices pinned, free boundary. ``harmonic``: outer loop to the unit circle by arc
        length, interior harmonic (cotangent weights), holes filled for the solve.
        ``uv``: the given ``uv`` (e.g. OBJ texture coordinates), or ``V[:, :2]``
        when ``uv`` is None (height fields).
    uv : (nv, 2) float64, optional
        Only for ``method="uv"``.
    repair : bool
        Replace a folded map by a fold-free one (see ``Parameterization.repaired``);
        if False, a folded map raises.

    Raises
    ------
    MeshError
        Invalid mesh (see :func:`validate_mesh`), or the map folds and could not
        be repaired.
    """
    if method not in METHODS:
        raise MeshError(f"unknown parameterization method {method!r}; choose one of {', '.join(METHODS)}",
                        ["method"])
    if uv is not None and method != "uv":
        raise MeshError(f"uv was given but method is {method!r}; use method='uv'", ["method"])
    vm = validate_mesh(V, F)
    messages = list(vm.messages)
    raw = _raw_map(vm, method, uv)
    if not np.isfinite(raw).all():
        bad = np.flatnonzero(~np.isfinite(raw).all(1))
        raise MeshError(f"the {method} map produced non-finite uv at vertices {first_few(bad)}",
                        ["degenerate_map"])
    mirrored = bool(signed_areas(raw, vm.F).sum() < 0)
    if mirrored:
        raw = raw * np.array([-1.0, 1.0])
        messages.append(f"the {method} map came out clockwise; mirrored u")
    raw, repaired, folds = _unfold(vm, raw, method, uv is None, repair, messages)
    uvn, centre, scale = normalise(raw)
    _refuse_folds(uvn, vm.F, method, repaired)
    boundary = max(vm.boundary_loops, key=lambda l: abs(polygon_area(uvn[l])))
    dist = summarize(*face_distortion(vm.V, vm.F, uvn))
    dist["flipped_before_repair"], dist["degenerate_before_repair"] = folds
    return Parameterization(
        uv=uvn, faces=vm.F, method=method, boundary=boundary,
        transform=UVTransform(centre=centre, scale=scale, mirrored=mirrored),
        distortion=dist, repaired=repaired, messages=messages, report=vm.report,
    )


def _unfold(vm: ValidatedMesh, raw: np.ndarray, method: str, no_uv: bool, repair: bool,
            messages: list[str]) -> tuple[np.ndarray, str | None, tuple[int, int]]:
    """``(map, repair name or None, (flipped, degenerate) counts)``: ``raw`` itself when it does
    not fold, else its repair (reported in ``messages``); raises when folded and not ``repair``."""
    flipped, degen = fold_mask(raw, vm.F)
    n_flip, n_deg = int(flipped.sum()), int(degen.sum())
    if not (n_flip or n_deg):
        return raw, None, (n_flip, n_deg)
    what = f"{n_flip} flipped and {n_deg} degenerate triangles (first: " \
           f"{', '.join(str(int(i)) for i in np.flatnonzero(flipped | degen)[:5])})"
    hint = _height_axes_hint(vm) if method == "uv" and no_uv else ""
    if not repair:
        raise MeshError(f"the {method} parameterization folds {n_flip + n_deg} triangles: {what}; "
                        f"enable repair or choose another method{hint}", ["folded"])
    raw, repaired = repair_folds(vm, raw, method)
    messages.append(f"the {method} map had {what}; repaired with a {repaired} map{hint}")
    return raw, repaired, (n_flip, n_deg)


def _refuse_folds(uvn: np.ndarray, F: np.ndarray, method: str, repaired: str | None) -> None:
    """The last check on the normalised map: a folded domain is never returned."""
    flipped, degen = fold_mask(uvn, F)
    if (flipped | degen).any():
        bad = np.flatnonzero(flipped | degen)
        raise MeshError(
            f"the {method} parameterization folds {bad.size} triangles ({int(flipped.sum())} flipped, "
            f"{int(degen.sum())} degenerate; faces {first_few(bad)})"
            + (f" even after the {repaired} repair" if repaired else "")
            + "; the mesh may have near-degenerate faces: clean it or try another method",
            ["folded"],
        )
