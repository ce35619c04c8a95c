"""Planar parameterization of a validated open mesh: harmonic, LSCM, SLIM, given uv, or auto.

The raw maps are in :mod:`trispline.param.methods`; ``auto`` measures them
(:mod:`trispline.param.distortion`) and takes the cheapest good one. Every method ends the same way: the map is mirrored if it came out globally
clockwise (faces are never reordered or reoriented), checked for flipped and
degenerate triangles, repaired if needed (:mod:`trispline.param.repair`), normalised
(centred at the bounding box centre, farthest vertex at distance 1) and checked again
with the exact test of :class:`trispline.spline.topology.Triangulation`. A folded
domain is never returned: :class:`MeshError` instead.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from trispline.spline.errors import first_few
from trispline.spline.tolerances import ANGLE_DISTORTION_WARN
from trispline.spline.topology import signed_areas
from trispline.spline.util.progress import Report, silent, span

from .distortion import TANGLE_SEGMENTS, face_distortion, fold_mask, outline_crossings, score, summarize, warning
from .domain import UVTransform, normalise
from .errors import MeshError
from .methods import FREE_BOUNDARY_MAPS, MAPS, raw_map
from .repair import polygon_area, repair_folds
from .polymap import smoothest_map
from .smooth import smooth_uv
from .validate import ValidatedMesh, map_slivers, validate_mesh

METHODS = MAPS + ("auto",)
#: The maps ``method="auto"`` measures: the first alone when it is good (fold-free, score
#: within ``ANGLE_DISTORTION_WARN``), else all of them (SLIM, the slowest, only then).
AUTO_ORDER = ("spectral", "harmonic", "slim")
#: The parameterization of :func:`parameterize` and of ``fit_surface`` / ``trispline fit``
#: when none is named: a conformal map keeps triangle shapes, which the C1 conditions depend on
#: (docs/param.md compares the methods on real meshes), and the spectral one has no pinned
#: vertices, so the map does not depend on the order the file lists its faces in.
DEFAULT_METHOD = "spectral"
#: Whether :func:`parameterize` smooths the map (:func:`~trispline.param.smooth.smooth_uv`) by
#: default: on the analytic surfaces of ``benchmarks/bench_accuracy3d.py`` it brought the fit's
#: error to that of the true parameterization (docs/param.md, "Smoothing").
DEFAULT_SMOOTH = True
#: Whether the smoothed map gives way to a polynomial of the position in space that is smoother
#: (:func:`~trispline.param.polymap.smoothest_map`) by default (docs/param.md, "Polynomial maps").
DEFAULT_POLYNOMIAL = True


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
        The map used (for ``method="auto"`` the one it chose; see ``reason``).
    boundary : (nb,) int64
        Outer boundary loop, counter-clockwise in uv.
    transform : UVTransform
        The normalisation; :func:`~trispline.param.user_domain` and
        :meth:`UVTransform.as_extras` put the domain back into the user's frame.
    distortion : dict
        ``angle_p50/p90/p99/max`` (singular value ratio, 1 = conformal),
        ``area_p50/p90/p99/max`` (area share ratio, 1 = equiareal),
        ``flipped_before_repair``, ``degenerate_before_repair`` (face counts) and ``score``
        (``angle_max``, see :func:`~trispline.param.distortion.score`); all numbers.
    repaired : str or None
        ``"tutte"`` or ``"composite_harmonic"`` when the first map folded; ``"harmonic"`` or
        ``"slim"`` when that map is less sheared than the repair of a folded free-boundary map.
    messages : list of str
    report : dict
        Validation counts (see :class:`ValidatedMesh`).
    warning : str or None
        Why the map deserves a warning (it folded before repair, or its angle or area
        distortion exceeds ``ANGLE_DISTORTION_WARN`` or ``AREA_DISTORTION_WARN``), else None.
    source_uv : (nv, 2) float64 or None
        For ``method="uv"``: the coordinates as given (``V[:, :2]`` when none were), else None.
    reason : str
        For ``method="auto"``: which map it chose and why (also in ``messages``); else "".
    candidates : dict
        For ``method="auto"``: the distortion dict of every map it measured.
    smoothing : dict
        What :func:`~trispline.param.smooth.smooth_uv` did (``moved_max``, ``reverted``,
        ``fallback``, ``unfolded``: folds of the raw map it removed); empty when the map was not smoothed (``smooth=False``, ``method="uv"``).
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
    warning: str | None = None
    source_uv: np.ndarray | None = None
    reason: str = ""
    candidates: dict = field(default_factory=dict)
    smoothing: dict = field(default_factory=dict)


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
    smooth: bool = DEFAULT_SMOOTH,
    polynomial: bool = DEFAULT_POLYNOMIAL,
    embedded: bool = False,
    report: Report | None = None,
    validated: ValidatedMesh | None = None,
) -> Parameterization:
    """Map an open genus-0 mesh to a fold-free planar triangulation.

    Parameters
    ----------
    V : (nv, 3) float64
    F : (nf, 3) int
    method : {"lscm", "spectral", "harmonic", "slim", "uv", "auto"}
        ``spectral`` (:data:`DEFAULT_METHOD`): least squares conformal energy, free boundary and no
        pinned vertices (the spectral conformal map), so that the map does not depend on the file's
        face order. ``lscm``: the same energy with two far-apart boundary vertices pinned (their
        choice starts from the outline's lowest vertex id). ``harmonic``: outer loop to the unit circle by arc
        length, interior harmonic (cotangent weights), holes filled for the solve.
        ``slim``: the conformal (MIPS) energy minimised by SLIM from the Tutte embedding:
        nearly as conformal as LSCM, free boundary, and fold-free by construction (slower:
        a sparse solve per iteration). ``uv``: the given ``uv`` (e.g. OBJ texture
        coordinates), or ``V[:, :2]`` when ``uv`` is None (height fields). ``auto``:
        ``spectral`` when it is fold-free with a distortion score (worst angle distortion,
        ``angle_max``) within ``ANGLE_DISTORTION_WARN``; otherwise the lowest score of
        ``spectral``, ``harmonic`` and ``slim``, maps that did not fold first (``reason`` says
        which and why).
    uv : (nv, 2) float64, optional
        Only for ``method="uv"``.
    repair : bool
        Replace a folded map by a fold-free one (see ``Parameterization.repaired``);
        if False, a folded map raises.
    smooth : bool
        Replace each vertex's uv by a local polynomial fit of its neighbours' (as a function of
        position on the surface; boundary vertices along their loop, corners kept), which removes
        the discrete map's vertex-to-vertex irregularity (:mod:`trispline.param.smooth`); the
        result is checked for folds and falls back to the map itself. Not for ``method="uv"``
        (the given coordinates are kept as they are). Default :data:`DEFAULT_SMOOTH`.
    polynomial : bool
        With ``smooth``: the smoothed map (not the harmonic one, whose outline stays on its circle) gives
        way to a fold-free polynomial of degree 2-4 of the position in space fitted to it, or to the projection
        onto the mesh's mean plane (degree 1: a height field's natural map), when that is measurably smoother
        (:func:`~trispline.param.polymap.smoothest_map`; ``smoothing["polynomial"]`` names the degree).
        Default :data:`DEFAULT_POLYNOMIAL`.
    embedded : bool
        The map must also be one-to-one: a fold-free map whose outline crosses itself (it covers part
        of the plane twice: :func:`~trispline.param.distortion.outline_crossings`) gives way to the least
        sheared harmonic or SLIM map that does not (``repaired`` names it), or raises (``uv``: always).
        The interpolating fit does not need it; anything that locates points in uv does.
    validated : ValidatedMesh, optional
        What :func:`validate_mesh` made of these ``V, F``, where the caller has it: its mesh is mapped and
        the checks are not run again (a second validation took 0.3 s of a 100k-face fit's command line,
        ~2.5 s at 1M faces). The caller vouches that it is of these arrays (the shapes are checked).
    report : ``report(fraction)``, optional
        Progress as the steps end (the map, its smoothing, a repair; SLIM after each iteration):
        at 200k faces a folded LSCM map takes ~25 s to replace.

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
    if validated is not None and (np.shape(V) != validated.V.shape or np.shape(F) != validated.F.shape):
        raise MeshError("validated is not the validation of these V and F (their shapes differ)", ["validated"])
    vm = validate_mesh(V, F) if validated is None else validated
    report = report or silent
    p = (_auto(vm, repair, smooth, report, embedded, polynomial) if method == "auto"
         else _single(vm, method, uv, repair, smooth, report, embedded, polynomial))
    report(1.0)
    return p


#: Shares of :func:`_single`'s progress: the map, then its smoothing, then a repair, then the checks.
_MAP_DONE, _SMOOTH_DONE, _REPAIR_DONE = 0.3, 0.45, 0.95


def _single(vm: ValidatedMesh, method: str, uv: np.ndarray | None, repair: bool,
            smooth: bool = DEFAULT_SMOOTH, report: Report = silent, embedded: bool = False,
            polynomial: bool = DEFAULT_POLYNOMIAL) -> Parameterization:
    """:func:`parameterize` with one map of :data:`~trispline.param.methods.MAPS`."""
    messages = list(vm.messages)
    raw = raw_map(vm, method, uv, span(report, 0.0, _MAP_DONE))
    report(_MAP_DONE)
    source_uv = raw.copy() if method == "uv" else None
    if not np.isfinite(raw).all():
        bad = np.flatnonzero(~np.isfinite(raw).all(1))
        raise MeshError(f"the {method} map produced non-finite uv at vertices {first_few(bad)}",
                        ["degenerate_map"])
    mirrored = bool(signed_areas(raw, vm.F).sum() < 0)
    if mirrored:
        raw = raw * np.array([-1.0, 1.0])
        messages.append(f"the {method} map came out clockwise; mirrored u")
    smoothing: dict = {}
    if smooth and method != "uv":  # first: a smooth map often has none of the raw map's few folds
        raw, smoothing = _smoothed(vm, raw, method, messages, polynomial)
    report(_SMOOTH_DONE)
    raw, repaired, folds = _unfold(vm, raw, method, uv is None, repair, messages,
                                   span(report, _SMOOTH_DONE, _REPAIR_DONE), embedded)
    if repaired is None:
        raw, repaired = _unsliver(vm, raw, method, repair, messages, span(report, _SMOOTH_DONE, _REPAIR_DONE),
                                  embedded)
    if embedded:
        raw, repaired = _unoverlap(vm, raw, method, repaired, messages, span(report, _SMOOTH_DONE, _REPAIR_DONE))
    elif method == "uv" and (crossings := outline_crossings(raw, vm.boundary_loops, tangle=TANGLE_SEGMENTS)):
        messages.append(f"the uv cover part of the plane more than once (their outline crosses itself at "
                        f"{crossings} points): the fit does not mind, but a point (u, v) there names more "
                        "than one point of the surface")
    if smooth and repaired in ("harmonic", "slim"):  # a map that replaced a worse repair
        smoothed, info = _smoothed(vm, raw, repaired, messages, polynomial)
        crossing = embedded and outline_crossings(smoothed, vm.boundary_loops, tangle=TANGLE_SEGMENTS)
        if not crossing:  # else kept unsmoothed: the smoothing's small moves made it cross
            raw, smoothing = smoothed, info
    report(_REPAIR_DONE)
    uvn, centre, scale = normalise(raw)
    _refuse_folds(uvn, vm.F, method, repaired)
    boundary = max(vm.boundary_loops, key=lambda l: abs(polygon_area(uvn[l])))
    dist = summarize(*face_distortion(vm.V, vm.F, uvn))
    dist["flipped_before_repair"], dist["degenerate_before_repair"] = folds
    dist["score"] = score(dist)
    return Parameterization(
        uv=uvn, faces=vm.F, method=method, boundary=boundary,
        transform=UVTransform(centre=centre, scale=scale, mirrored=mirrored),
        distortion=dist, repaired=repaired, messages=messages, report=vm.report,
        warning=warning(dist, sum(folds), method, repaired), source_uv=source_uv, smoothing=smoothing,
    )


def _smoothed(vm: ValidatedMesh, raw: np.ndarray, method: str, messages: list[str], polynomial: bool = True
              ) -> tuple[np.ndarray, dict]:
    """:func:`~trispline.param.smooth.smooth_uv` of a raw map (the harmonic map's outline stays on its circle),
    then, with ``polynomial``, :func:`~trispline.param.polymap.smoothest_map` of that; ``info`` also counts the
    raw map's folds it removed (``unfolded``) and names the polynomial's degree (``polynomial``, 0: none)."""
    keep = vm.boundary_loops[0] if method == "harmonic" else None
    folds_before = int(np.logical_or(*fold_mask(raw, vm.F)).sum())
    new, info = smooth_uv(vm.V, vm.F, raw, vm.boundary_loops, keep=keep)
    info["polynomial"] = 0
    if polynomial and keep is None:  # not the harmonic map: its outline stays on its circle
        new, poly = smoothest_map(vm.V, vm.F, new)
        info.update(poly)
        if poly["polynomial"]:
            info["fallback"] = False  # a fold-free map, whatever the local fits did
            messages.append(f"the {method} map was replaced by the smoother "
                            + ("projection onto the mesh's mean plane" if poly["polynomial"] == 1 else
                               f"polynomial of degree {poly['polynomial']} of the position fitted to it"))
    info["unfolded"] = folds_before if folds_before and not info["fallback"] else 0
    if info["unfolded"]:
        messages.append(f"smoothing the {method} map removed its {folds_before} folded triangles")
    elif info["fallback"] and not folds_before:
        messages.append(f"smoothing folded the {method} map; kept it unsmoothed")
    return new, info


def _good(p: Parameterization) -> bool:
    """Fold-free as first computed, and a score within ``ANGLE_DISTORTION_WARN``."""
    return _folds(p) == 0 and p.distortion["score"] <= ANGLE_DISTORTION_WARN


def _auto(vm: ValidatedMesh, repair: bool, smooth: bool, report: Report = silent,
          embedded: bool = False, polynomial: bool = DEFAULT_POLYNOMIAL) -> Parameterization:
    """``method="auto"``: the first of :data:`AUTO_ORDER` when it is good, else the least distorted map, fold-free first."""
    tried: dict[str, Parameterization] = {}
    failed: dict[str, str] = {}
    for k, name in enumerate(AUTO_ORDER):
        if tried.get(AUTO_ORDER[0]) is not None and _good(tried[AUTO_ORDER[0]]):
            break
        try:
            tried[name] = _single(vm, name, None, repair, smooth,
                                  span(report, k / len(AUTO_ORDER), (k + 1) / len(AUTO_ORDER)), embedded, polynomial)
        except MeshError as exc:
            failed[name] = str(exc).splitlines()[0]
    if not tried:
        raise MeshError("auto: no parameterization worked: "
                        + "; ".join(f"{k}: {v}" for k, v in failed.items()), ["folded"])
    rank = {k: (_folds(p) > 0, p.distortion["score"]) for k, p in tried.items()}
    best = min(rank, key=rank.__getitem__)
    others = [f"{k} {_verdict(p)}" for k, p in tried.items() if k != best]
    others += [f"{k} failed ({v})" for k, v in failed.items()]
    reason = (f"auto chose {best} ({_verdict(tried[best])})" + (f" over {', '.join(others)}" if others else "")
              + f"; score = worst angle distortion, good = no fold and score <= {ANGLE_DISTORTION_WARN:g}")
    p = tried[best]
    return dataclasses.replace(p, messages=p.messages + [reason], reason=reason,
                               warning=warning(p.distortion, _folds(p), "auto"),
                               candidates={k: q.distortion for k, q in tried.items()})


def _folds(p: Parameterization) -> int:
    """Faces the first map flipped or collapsed (repaired since)."""
    return int(p.distortion["flipped_before_repair"] + p.distortion["degenerate_before_repair"])


def _verdict(p: Parameterization) -> str:
    """``"score 1.07"`` or ``"score 2.1e+04, 3 folds repaired"``."""
    folds = _folds(p)
    return f"score {p.distortion['score']:.3g}" + (f", {folds} folds repaired" if folds else "")


def _unfold(vm: ValidatedMesh, raw: np.ndarray, method: str, no_uv: bool, repair: bool,
            messages: list[str], report: Report = silent, embedded: bool = False
            ) -> tuple[np.ndarray, str | None, tuple[int, int]]:
    """``(map, repair name or None, (flipped, degenerate) counts)``: ``raw`` itself when it does
    not fold, else its replacement (reported in ``messages``); raises when folded and not ``repair``.

    A folded free-boundary map (``lscm``, ``slim``) gives way to the least sheared (lowest score) of the
    fold-free harmonic and SLIM maps (:func:`_global_alternative`; one-to-one ones where ``embedded``, so that
    :func:`_unoverlap` has no second to make); the repair that keeps the map's outline
    (:func:`~trispline.param.repair.repair_folds`: libigl's composite harmonic map) only where neither is
    fold-free. Its outline is worth keeping where the user gave it (``uv``); a free boundary's is not,
    and the repair was the more sheared on every mesh measured whose LSCM map folds (score: halftunnel
    9.8 against SLIM's 2.3; Enneper at 200 / 800 vertices 220 / 7e8 against the harmonic map's 1.1; the
    200k-face scan of ``bench_fit_speed.py`` against SLIM's 5e3), and the slowest (that scan: 33 s of the
    map's 55 s).
    """
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
    free_boundary = method in FREE_BOUNDARY_MAPS
    alt = _global_alternative(vm, method, span(report, 0.0, 0.9), embedded) if free_boundary else None
    raw, repaired = (alt[0], alt[1]) if alt is not None else repair_folds(vm, raw, method)
    messages.append(f"the {method} map had {what}; repaired with a {repaired} map{hint}")
    return raw, repaired, (n_flip, n_deg)


def _unsliver(vm: ValidatedMesh, raw: np.ndarray, method: str, repair: bool, messages: list[str],
              report: Report = silent, embedded: bool = False) -> tuple[np.ndarray, str | None]:
    """``(map, name of its replacement or None)``: a fold-free free-boundary map that squeezed triangles of
    the mesh into slivers too thin to fit (:func:`~trispline.param.validate.map_slivers`; LSCM on an open
    cylinder of tall triangles: aspect 6e12) gives way to the least sheared harmonic or SLIM map without
    them, as a folded one does; else it stays (and a fit refuses it, naming the map)."""
    if method not in FREE_BOUNDARY_MAPS or not repair:
        return raw, None
    bad = map_slivers(vm.V, raw, vm.F)
    if not bad.any():
        return raw, None
    alt = _global_alternative(vm, method, report, embedded)
    if alt is None:
        return raw, None
    messages.append(f"the {method} map squeezed {int(bad.sum())} triangles into slivers (faces "
                    f"{first_few(np.flatnonzero(bad))}); replaced with the {alt[1]} map")
    return alt[0], alt[1]


def _unoverlap(vm: ValidatedMesh, raw: np.ndarray, method: str, repaired: str | None, messages: list[str],
               report: Report = silent) -> tuple[np.ndarray, str | None]:
    """``(map, repair name)``: ``raw`` when its outline does not cross itself, else the least sheared
    one-to-one harmonic or SLIM map (:func:`_global_alternative`); raises where there is none, and for
    the caller's own ``uv``."""
    crossings = outline_crossings(raw, vm.boundary_loops, tangle=TANGLE_SEGMENTS)
    if not crossings:
        return raw, repaired
    what = f"the {repaired or method} map overlaps itself (its outline crosses itself at {crossings} points)"
    alt = None if method == "uv" else _global_alternative(vm, method, report, embedded=True)
    if alt is None:
        raise MeshError(f"{what}, and a one-to-one map is needed"
                        + (": give uv that cover no point twice, or map the mesh with a method (lscm, harmonic, slim)"
                           if method == "uv" else "; no fold-free harmonic or SLIM map was found either"),
                        ["overlap"])
    messages.append(f"{what}; replaced with the {alt[1]} map")
    return alt[0], alt[1]


#: SLIM replaces the harmonic map as :func:`_global_alternative` only where its score is below this times the
#: harmonic map's. Started from the harmonic map, SLIM ends a hair less sheared than it where the harmonic map
#: is already conformal (Enneper at 800 vertices: 1.0560 against 1.0564), and there the harmonic map fitted
#: better (4.8e-7 RMS against 5.4e-7); where the harmonic map's circle squeezes the outline SLIM wins by far
#: (halftunnel 2.3 against 2.9, a noisy 100k-face scan 3.4 against 313).
GLOBAL_MARGIN = 0.9


def _global_alternative(vm: ValidatedMesh, method: str, report: Report = silent, embedded: bool = False
                        ) -> tuple[np.ndarray, str, float] | None:
    """``(map, name, score)`` of the least sheared of the harmonic and SLIM maps other than ``method``
    that neither fold nor make slivers (:func:`~trispline.param.validate.map_slivers`), nor, where
    ``embedded``, cross their own outline (:func:`~trispline.param.distortion.outline_crossings`), or None.
    Why: an Enneper surface's LSCM folded one triangle; its composite-harmonic
    repair had a triangle sheared 3e8-fold, which the fit could not factor; its harmonic map fits
    (issue 17). Halftunnel's LSCM folded one triangle; the repair (score 9.8) left 46 patches above 20x
    the data's largest |H| and the boundary band's curvature p99 60x the interior's; SLIM (score 2.3)
    none and 1.3x (issue 18)."""
    best: tuple[np.ndarray, str, float] | None = None
    alts = [a for a in ("harmonic", "slim") if a != method]
    for k, alt in enumerate(alts):
        try:  # the harmonic map is one solve; SLIM's iterations take the rest
            uv = raw_map(vm, alt, report=span(report, 0.1 * k, 1.0) if alt == "slim" else None)
        except (MeshError, np.linalg.LinAlgError):  # SLIM on a degenerate start: not a candidate
            continue
        report(0.1 if alt == "harmonic" else 1.0)
        if signed_areas(uv, vm.F).sum() < 0:
            uv = uv * np.array([-1.0, 1.0])
        if (np.isfinite(uv).all() and not np.logical_or(*fold_mask(uv, vm.F)).any()
                and not map_slivers(vm.V, uv, vm.F).any()
                and not (embedded and outline_crossings(uv, vm.boundary_loops, tangle=TANGLE_SEGMENTS))):
            s = score(summarize(*face_distortion(vm.V, vm.F, uv)))
            if best is None or s < (GLOBAL_MARGIN if best[1] == "harmonic" else 1.0) * best[2]:
                best = (uv, alt, s)
    return best


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
