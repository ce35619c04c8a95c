"""``trispline check``: continuity residuals and statistics of a surface file (exit 3 if C1 is broken).

    trispline check SURFACE.npz [--tolerance T] [--samples N]
"""
from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from typing import Any

import numpy as np

from trispline.spline.tolerances import CHECK_TOLERANCE, FLOOR_NEGLIGIBLE, PRECISION_MARGIN

from .common import (
    EXIT_CHECK, EXIT_OK, PROG, UI, add_common, fmt, load_surface, nonneg_float, positive_int, stored_deviation,
)

__all__ = ["add_parser", "cmd_check", "surface_report", "PRECISION_MARGIN"]



def add_parser(sub: Any) -> None:
    """Register ``check`` on an ``add_subparsers()`` action."""
    p = sub.add_parser("check", help="continuity residuals and statistics of a surface file",
                       description="Algebraic C0/C1 residuals across every interior edge, sampled value and "
                                   "gradient jumps, patch count, bounds, stored fit energies. Exit 3 if a "
                                   "relative residual exceeds the tolerance.")
    p.add_argument("surface", metavar="SURFACE", help="surface file (.npz or .json)")
    p.add_argument("--tolerance", type=nonneg_float, default=CHECK_TOLERANCE,
                   help=f"largest accepted relative residual (default {CHECK_TOLERANCE:g})")
    p.add_argument("--samples", type=positive_int, default=7, help="samples per edge for the jumps (default 7)")
    add_common(p)
    p.set_defaults(func=cmd_check)


def surface_report(surface: Any, *, tolerance: float = CHECK_TOLERANCE, samples: int = 7,
                   progress: Callable[[float], None] | None = None) -> dict:
    """Continuity residuals and statistics of a surface (the body of ``check``).

    The residuals are measured on the net moved to its bounding box's centre (exactly the same
    C1 conditions: they are affine), so that a surface far from the origin is judged on its own
    digits: :func:`_centre`, in the coordinates that lie farther from the origin than the surface
    is wide (elsewhere the move gains no digit, and its own rounding, divided by the height of a
    sliver, made jumps of its own: 2e-9 against the stored net's 1e-11 on a planar scan of random
    points). The stored coordinates are rounded to their own precision, though: a tile of 10 m
    at 1e6 m keeps about 1e-10 of its extent, a millimetre at 1e9 only 1e-4. ``precision_floor``
    holds the residuals that this rounding alone makes (measured on a random perturbation of
    half an ulp per coordinate); a residual passes when it is within ``tolerance`` plus
    :data:`PRECISION_MARGIN` times its floor. ``progress(fraction)``: as the sampled pass's edge
    ranges finish.
    """
    from trispline.spline.continuity import continuity_report
    from trispline.spline.surface import SplineSurface

    tri = surface.triangulation
    ctrl = np.asarray(surface.ctrl)
    pts = ctrl.reshape(-1, 3)
    centre = _centre(pts)
    centred = SplineSurface(surface.uv, surface.faces, ctrl - centre)
    alg = continuity_report(tri, ctrl - centre)
    num = {k: v for k, v in centred.continuity(samples, progress).items() if not isinstance(v, np.ndarray)}
    corners = _corner_points(tri, ctrl)
    report: dict[str, Any] = dict(
        patches=tri.n_faces, vertices=tri.n_vertices, edges=tri.n_edges,
        interior_edges=int(tri.interior_edges.size), boundary_edges=int(tri.boundary_edges.size),
        boundary_loops=len(tri.boundary_loops), holes=tri.n_holes,
        bounds=dict(control_points=[pts.min(0), pts.max(0)], corner_points=[corners.min(0), corners.max(0)],
                    uv=[tri.uv.min(0), tri.uv.max(0)]),
        c1_algebraic=alg, c1_sampled=num,
    )
    report.update(_stored_fit(dict(surface.extras), corners))
    worst = dict(c0_algebraic=alg["c0_relative"], c1_algebraic=alg["c1_relative"],
                 c0_sampled=num["c0_relative"], c1_sampled=num["c1_relative"])
    floor = _precision_floor(surface, samples, alg, num)
    failed = sorted(k for k, v in worst.items() if not v <= tolerance + PRECISION_MARGIN * floor[k])
    report.update(tolerance=tolerance, relative_residuals=worst, precision_floor=floor, centre=centre,
                  failed=failed, ok=not failed)
    return report


def _centre(pts: np.ndarray) -> np.ndarray:
    """``(3,)`` the move of the net ``pts (n, 3)`` for the check: its bounding box's centre in each coordinate
    whose centre lies farther from the origin than the box's widest side, else 0."""
    if not pts.size:
        return np.zeros(3)
    centre = 0.5 * (pts.min(0) + pts.max(0))
    return np.where(np.abs(centre) > np.ptp(pts, axis=0).max(), centre, 0.0)


def _precision_floor(surface: Any, samples: int, alg: dict, num: dict) -> dict[str, float]:
    """The relative residuals that rounding the stored coordinates alone makes: those of a random
    perturbation of half an ulp per coordinate, over the surface's own scales (``alg`` and
    ``num``: its algebraic and sampled reports). Zeros when the coordinates, times the domain's worst
    triangle aspect, are finer than the tolerances could notice (data near the origin, no slivers)."""
    from trispline.spline.continuity import continuity_report
    from trispline.spline.patches import numeric_continuity

    from trispline.param.validate import face_aspects

    ctrl = np.asarray(surface.ctrl)
    keys = ("c0_algebraic", "c1_algebraic", "c0_sampled", "c1_sampled")
    scale = max(alg["scale"], 1e-300)
    # the sampled gradients divide by the domain triangles' heights: rounding grows with their aspect
    # (a grid whose points sit 1e-4 of a cell from an edge: c1_sampled 2.2e-9 with the stored net exactly C1)
    aspect = float(face_aspects(surface.uv, surface.faces).max()) if ctrl.size else 1.0
    if ctrl.size == 0 or np.finfo(float).eps * np.abs(ctrl).max() / scale * aspect < FLOOR_NEGLIGIBLE:
        return dict.fromkeys(keys, 0.0)
    rng = np.random.default_rng(0)
    delta = (rng.random(ctrl.shape) - 0.5) * np.spacing(np.abs(ctrl))
    a = continuity_report(surface.triangulation, delta)
    n = numeric_continuity(surface.uv, surface.faces, delta, samples)
    return dict(c0_algebraic=a["c0_max"] / scale, c1_algebraic=a["c1_max"] / scale,
                c0_sampled=n["c0_max"] / max(num["scale"], 1e-300),
                c1_sampled=n["c1_max"] / max(num["gradient_scale"], 1e-300))


def _corner_points(tri: Any, ctrl: np.ndarray) -> np.ndarray:
    """The corner control point of every vertex ``(nv, 3)``."""
    from trispline.spline.index import CORNER

    corners = np.empty((tri.n_vertices, 3))
    corners[tri.faces.ravel()] = ctrl[:, CORNER].reshape(-1, 3)
    return corners


def _stored_fit(ex: dict, corners: np.ndarray) -> dict[str, Any]:
    """What ``fit`` stored in the file's optional keys: energies, weights, settings, interpolation error.
    A malformed optional key (another writer's, an edited file) is left out and named in ``ignored_keys``."""
    report: dict[str, Any] = {}
    ignored: list[str] = []

    def read(keys: tuple[str, ...], convert: Callable[..., Any]) -> Any:
        if not all(k in ex for k in keys):
            return None
        try:
            return convert(*(ex[k] for k in keys))
        except (ValueError, TypeError, IndexError):
            ignored.extend(k for k in keys if k not in ignored)
            return None

    def named(names: Any, values: Any) -> dict[str, float]:
        names, values = [str(s) for s in np.atleast_1d(names)], [float(v) for v in np.atleast_1d(values)]
        if len(names) != len(values):
            raise ValueError("names and values differ in length")
        return dict(zip(names, values))

    for key, keys in (("energies", ("fit_energy_names", "fit_energies")),
                      ("weights", ("fit_weight_names", "fit_weights")),
                      ("energies_normalised", ("fit_energy_names", "fit_energies_normalised"))):
        value = read(keys, named)  # normalised: per unit area of a unit-diagonal surface
        if value is not None:
            report[key] = value
    for key in ("fit_param", "fit_param_chosen", "fit_source", "fit_iterations", "fit_converged"):
        value = read((key,), lambda v: np.asarray(v).item() if np.ndim(v) == 0 else np.asarray(v).tolist())
        if value is not None:
            report[key[4:]] = value
    for key in ("domain_max_move", "domain_max_relative_move"):  # fit snapped domain vertices (issue 14)
        value = read((key,), lambda v: float(np.asarray(v)))
        if value is not None:
            report[key] = value
    error = read(("data_vertices",),
                 lambda D: float(np.abs(corners - np.asarray(D, float).reshape(corners.shape)).max()))
    if error is not None:
        report["max_interpolation_error"] = error
    approximation = read(("approx_deviation_names", "approx_deviation"), lambda *_: _stored_approximation(ex))
    if approximation is not None:  # an approximation (fit --tolerance)
        report["approximation"] = approximation
    if ignored:
        report["ignored_keys"] = ignored
    return report


def _stored_approximation(ex: dict) -> dict[str, Any]:
    """An approximation's stored deviation statistics and settings (``approx_*`` keys)."""
    out: dict[str, Any] = dict(deviation=stored_deviation(ex))
    for key in ("approx_loss", "approx_corners", "approx_tolerance", "approx_budget", "approx_met", "approx_stop",
                "approx_noise", "approx_holes_filled", "approx_outline_tolerance"):
        if key in ex:
            v = np.asarray(ex[key]).item()
            out[key[7:]] = None if isinstance(v, float) and not np.isfinite(v) else v
    return out


def _check_text(d: dict) -> str:
    b = d["bounds"]["control_points"]
    lines = [
        f"{d['file']}: {d['patches']} patches, {d['vertices']} vertices, {d['interior_edges']} interior / "
        f"{d['boundary_edges']} boundary edges, {d['boundary_loops']} boundary loops ({d['holes']} holes)",
        f"  bounds: min {(np.round(b[0], 6) + 0.0).tolist()} max {(np.round(b[1], 6) + 0.0).tolist()}",  # no -0.0
        "  relative residuals: " + ", ".join(f"{k} {fmt(v)}" for k, v in d["relative_residuals"].items()),
    ]
    if "energies" in d:
        lines.append("  stored energies: " + ", ".join(f"{k} {fmt(v)}" for k, v in d["energies"].items()))
    if "energies_normalised" in d:
        lines.append("  normalised (unit bounding-box diagonal, per unit domain area): "
                     + ", ".join(f"{k} {fmt(v)}" for k, v in d["energies_normalised"].items()))
    if "max_interpolation_error" in d:
        lines.append(f"  max interpolation error: {fmt(d['max_interpolation_error'])}")
    if "domain_max_move" in d:
        lines.append(f"  domain snapped onto exact crossings: largest move {fmt(d['domain_max_move'])} "
                     f"({fmt(d.get('domain_max_relative_move', float('nan')))} of an edge)")
    if "approximation" in d:
        a, dev = d["approximation"], d["approximation"]["deviation"]
        tol = "no tolerance" if a.get("tolerance") is None else \
            f"tolerance {fmt(a['tolerance'])} {'met' if a.get('met') else 'NOT met'}"
        lines.append(f"  stored deviation of the scan (inliers): max {fmt(dev.get('max'))}, RMS {fmt(dev.get('rms'))} "
                     f"({tol}; {int(dev.get('rejected', 0))} rejected; loss {a.get('loss')}, corners {a.get('corners')}"
                     + (f"; {a['holes_filled']} small holes of the scan spanned" if a.get("holes_filled") else "") + ")")
        if dev.get("outline_gap") is not None:
            lines.append(f"  the outline's largest gap to the scan {fmt(dev['outline_gap'])}"
                         + ((" (held to the tolerance)" if a.get("tolerance") is None or dev["outline_gap"] <= a["tolerance"]
                             else " (held to the tolerance: NOT met)") if a.get("outline_tolerance") else ""))
    fl = d["precision_floor"]
    if any(fl.values()):
        where = (f"far from the origin (centre {np.round(d['centre'], 3).tolist()})" if np.any(d["centre"])
                 else "over thin domain triangles")
        lines.append(f"  {where}: the stored coordinates' "
                     f"rounding alone makes c1_algebraic {fmt(fl['c1_algebraic'])}, c1_sampled "
                     f"{fmt(fl['c1_sampled'])}; allowed: tolerance + {PRECISION_MARGIN:g} x that")
    verdict = ("OK: C1 within tolerance" if d["ok"]
               else f"FAILED: {', '.join(d['failed'])} above tolerance")
    lines.append(f"  {verdict} {d['tolerance']:g}")
    return "\n".join(lines)


def cmd_check(args: argparse.Namespace, ui: UI) -> int:
    """Body of ``trispline check``: exit 3 when a relative residual exceeds ``--tolerance``."""
    surface = load_surface(args.surface)
    with ui.stages(("residuals",), "check") as bar:
        report = surface_report(surface, tolerance=args.tolerance, samples=max(args.samples, 2),
                                progress=lambda f: bar.at("residuals", 0.9 * f))
        bar.done()
    if report.get("ignored_keys"):
        ui.warn(f"{args.surface}: ignored malformed optional keys: {', '.join(report['ignored_keys'])}")
    data = dict(command="check", file=args.surface, **report)
    ui.result(data, _check_text)
    if not report["ok"]:
        print(f"{PROG}: check failed: {', '.join(report['failed'])} above the tolerance "
              f"{args.tolerance:g}", file=sys.stderr)
        return EXIT_CHECK
    return EXIT_OK
