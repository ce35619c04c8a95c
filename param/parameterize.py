"""Planar parameterization of a validated open mesh: harmonic, LSCM or given uv.

Every method ends the same way: the map is mirrored if it came out globally
clockwise (faces are never reordered or reoriented), checked for flipped and
degenerate triangles, repaired if needed, normalised (centred at the bounding
box centre, farthest vertex at distance 1) and checked again with the exact test
of :class:`trispline.spline.topology.Triangulation`. A folded domain is never
returned: :class:`MeshError` instead.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from trispline.spline.errors import first_few
from trispline.spline.topology import MIN_RELATIVE_AREA, signed_areas

from . import _igl
from .distortion import face_distortion, summarize
from .errors import MeshError
from .validate import ValidatedMesh, validate_mesh

METHODS = ("harmonic", "lscm", "uv")


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


# ----------------------------------------------------------------- building blocks
def fill_holes(V: np.ndarray, F: np.ndarray, holes: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Close each hole loop with a fan to a new vertex at the loop's centroid.

    ``holes`` are loops with the surface on their left (as from
    :func:`validate_mesh`). Returns ``(V_ext (nv + h, 3), F_ext (nf + sum len, 3))``;
    the original vertices and faces come first, unchanged.
    """
    if not holes:
        return V, F
    nv = V.shape[0]
    centres = np.stack([V[h].mean(0) for h in holes])
    sizes = np.array([len(h) for h in holes])
    cat = np.concatenate(holes)
    nxt = np.concatenate([np.roll(h, -1) for h in holes])
    cid = nv + np.repeat(np.arange(len(holes)), sizes)
    extra = np.column_stack([nxt, cat, cid])
    return np.concatenate([V, centres]), np.concatenate([F, extra])


def tutte(F: np.ndarray, nv: int, b: np.ndarray, bc: np.ndarray) -> np.ndarray:
    """Uniform-weight (Tutte) embedding ``(nv, 2)`` with vertices ``b`` fixed at ``bc``.

    Fold-free for a disk triangulation whose boundary ``bc`` is strictly convex
    (Floater 2003).
    """
    r = np.concatenate([F[:, 0], F[:, 1], F[:, 2], F[:, 1], F[:, 2], F[:, 0]])
    c = np.concatenate([F[:, 1], F[:, 2], F[:, 0], F[:, 0], F[:, 1], F[:, 2]])
    A = sp.coo_matrix((np.ones(r.size), (r, c)), shape=(nv, nv)).tocsr()
    A.data[:] = 1.0  # duplicates (interior edges) summed to 2 -> adjacency
    L = sp.diags(np.asarray(A.sum(1)).ravel()) - A
    fixed = np.zeros(nv, bool)
    fixed[b] = True
    free = np.flatnonzero(~fixed)
    out = np.zeros((nv, 2))
    out[b] = bc
    if free.size:
        Lff = L[free][:, free].tocsc()
        rhs = -(L[free][:, b] @ bc)
        # COLAMD: 0.3 s on a 50k-vertex scan, where MMD_AT_PLUS_A took 19.7 s (measured)
        out[free] = spla.splu(Lff, permc_spec="COLAMD").solve(np.asfortranarray(rhs))
    return out


def fold_mask(uv: np.ndarray, F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(flipped (nf,), degenerate (nf,))`` masks, with Triangulation's relative area test."""
    a = signed_areas(uv, F)
    scale = max(np.abs(a).mean(), np.finfo(float).tiny)
    flipped = a < 0
    degenerate = ~flipped & (a <= MIN_RELATIVE_AREA * scale)
    return flipped, degenerate


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


def polygon_area(P: np.ndarray) -> float:
    """Signed area of a closed polygon ``(n, 2)`` (positive if CCW)."""
    x, y = P[:, 0], P[:, 1]
    return 0.5 * float((x * np.roll(y, -1) - np.roll(x, -1) * y).sum())


# ----------------------------------------------------------------------- methods
def _raw_map(vm: ValidatedMesh, method: str, uv: np.ndarray | None) -> np.ndarray:
    V, F = vm.V, vm.F
    nv = V.shape[0]
    if method == "harmonic":
        outer = vm.boundary_loops[0]
        Vx, Fx = fill_holes(V, F, vm.boundary_loops[1:])
        bc = _igl.circle_boundary(Vx, outer)
        return _igl.harmonic(Vx, Fx, outer, bc)[:nv]
    if method == "lscm":
        i, j = far_apart(V, vm.boundary_loops[0])
        d = float(np.linalg.norm(V[i] - V[j]))
        return _igl.lscm(V, F, np.array([i, j]), np.array([[0.0, 0.0], [d, 0.0]]))
    # method == "uv"
    if uv is None:
        return V[:, :2].copy()
    uv = np.asarray(uv, dtype=np.float64)
    if uv.shape != (nv, 2):
        raise MeshError(f"uv must have shape ({nv}, 2) (one per vertex), got {uv.shape}", ["uv_shape"])
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


def _repair(vm: ValidatedMesh, raw: np.ndarray, method: str) -> tuple[np.ndarray, str]:
    """A fold-free replacement for ``raw``: the method's outer boundary reached by a
    composite harmonic map from a Tutte embedding, else the Tutte embedding itself."""
    V, F = vm.V, vm.F
    nv = V.shape[0]
    outer = vm.boundary_loops[0]
    Vx, Fx = fill_holes(V, F, vm.boundary_loops[1:])
    circle = _igl.circle_boundary(Vx, outer)
    base = tutte(Fx, Vx.shape[0], outer, circle)
    if method != "harmonic":
        target = raw[outer]
        if polygon_area(target) > 0:
            scale = np.sqrt(polygon_area(target) / np.pi)
            centre = target.mean(0)
            try:
                cand = _igl.composite_harmonic(base, Fx, outer, (target - centre) / scale)
            except Exception:  # noqa: BLE001 - igl may fail on a self-overlapping target
                cand = None
            if cand is not None and np.isfinite(cand).all():
                fl, dg = fold_mask(cand, Fx)
                if not (fl | dg).any():
                    return cand[:nv] * scale + centre, "composite_harmonic"
    return base[:nv], "tutte"


def parameterize(
    V: np.ndarray,
    F: np.ndarray,
    method: str = "harmonic",
    *,
    uv: np.ndarray | None = None,
    repair: bool = True,
) -> Parameterization:
    """Map an open genus-0 mesh to a fold-free planar triangulation.

    Parameters
    ----------
    V : (nv, 3) float64
    F : (nf, 3) int
    method : {"harmonic", "lscm", "uv"}
        ``harmonic``: outer loop to the unit circle by arc length, interior
        harmonic (cotangent weights), holes filled for the solve. ``lscm``: least
        squares conformal, two far-apart boundary vertices pinned, free boundary.
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
    Fv = vm.F
    messages = list(vm.messages)
    raw = _raw_map(vm, method, uv)
    if not np.isfinite(raw).all():
        bad = np.flatnonzero(~np.isfinite(raw).all(1))
        raise MeshError(f"the {method} map produced non-finite uv at vertices {first_few(bad)}",
                        ["degenerate_map"])
    mirrored = bool(signed_areas(raw, Fv).sum() < 0)
    if mirrored:
        raw = raw * np.array([-1.0, 1.0])
        messages.append(f"the {method} map came out clockwise; mirrored u")
    flipped, degen = fold_mask(raw, Fv)
    n_flip, n_deg = int(flipped.sum()), int(degen.sum())
    repaired = None
    if n_flip or n_deg:
        what = f"{n_flip} flipped and {n_deg} degenerate triangles (first: " \
               f"{', '.join(str(int(i)) for i in np.flatnonzero(flipped | degen)[:5])})"
        hint = _height_axes_hint(vm) if method == "uv" and uv is None else ""
        if not repair:
            raise MeshError(f"the {method} parameterization folds {n_flip + n_deg} triangles: {what}; "
                            f"enable repair or choose another method{hint}", ["folded"])
        raw, repaired = _repair(vm, raw, method)
        messages.append(f"the {method} map had {what}; repaired with a {repaired} map{hint}")
    uvn, centre, scale = normalise(raw)
    flipped, degen = fold_mask(uvn, Fv)
    if (flipped | degen).any():
        bad = np.flatnonzero(flipped | degen)
        raise MeshError(
            f"the {method} parameterization folds {bad.size} triangles ({int(flipped.sum())} flipped, "
            f"{int(degen.sum())} degenerate; faces {first_few(bad)})"
            + (f" even after the {repaired} repair" if repaired else "")
            + "; the mesh may have near-degenerate faces: clean it or try another method",
            ["folded"],
        )
    loops = vm.boundary_loops
    boundary = max(loops, key=lambda l: abs(polygon_area(uvn[l])))
    angle, area = face_distortion(vm.V, Fv, uvn)
    dist = summarize(angle, area)
    dist["flipped_before_repair"] = n_flip
    dist["degenerate_before_repair"] = n_deg
    return Parameterization(
        uv=uvn, faces=Fv, method=method, boundary=boundary,
        transform=UVTransform(centre=centre, scale=scale, mirrored=mirrored),
        distortion=dist, repaired=repaired, messages=messages, report=vm.report,
    )
