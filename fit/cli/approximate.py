"""``trispline fit --tolerance ...``: approximate a dense scan by a coarse spline instead of interpolating it.

    trispline fit SCAN -o SURFACE.npz --tolerance T | --tolerance-rel R | --vertices N
                  [--corners data|fit] [--loss huber|cauchy|l2] [--strict]

Any of ``--tolerance``, ``--tolerance-rel`` or ``--vertices`` switches ``fit`` from
interpolation (one patch per scan triangle) to approximation
(:func:`trispline.fit.approx.approximate_surface`): a coarse spline on a subset of the
scan's vertices, refined until every inlier is within the tolerance or the vertex budget
is spent. A tolerance not met is a warning (exit 0), or with ``--strict`` an error
(exit 3, no file written). ``fit`` registers the options (:func:`add_options`) and hands
over (:func:`run`) with its own loading and writing steps.
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from typing import Any, Callable

from trispline.spline.tolerances import NOISE_CORRELATION_MAX, NOISE_SIGMAS

from ..errors import UsageError
from .common import EXIT_CHECK, EXIT_OK, PROG, UI, Interrupts, fmt, nonnegative_int, positive_float, positive_int

__all__ = ["add_options", "requested", "run", "NOISE_SIGMAS"]

#: The options that only make sense with an approximation.
_MODE_OPTIONS = ("corners", "loss", "strict", "outline_tolerance", "fill_holes")
#: Kept small holes (:data:`~trispline.param.tables.SMALL_HOLE` vertices or fewer) from which ``fit`` suggests
#: ``--fill-holes``: one may be a feature, several are dropouts.
SMALL_HOLES_ADVICE = 2
#: FitWeights fields the approximation uses.
_USED_WEIGHTS = ("bend", "data")


def vertex_budget(text: str) -> int:
    """argparse type of ``--vertices``: an integer >= 3 (the fewest a domain has: one triangle)."""
    v = positive_int(text)
    if v < 3:
        raise argparse.ArgumentTypeError(f"expected an integer >= 3 (a domain is at least one triangle), got {v}")
    return v


#: A kept fit with fewer than this share of the largest round's vertices: more vertices did not help.
STALLED_SHARE = 0.8


#: Where at least this share of the inliers over a missed tolerance lie on or beside sharp creases, the advice
#: names the creases.
CREASE_SHARE = 0.5


def _below_noise(st: dict) -> bool:
    """Whether the tolerance is below :data:`NOISE_SIGMAS` times the scan's noise estimate (where that estimate is
    noise: its residuals uncorrelated, else it is the local quadrics' model error)."""
    tol = st.get("tolerance")
    return (tol is not None and tol < NOISE_SIGMAS * st.get("noise", 0.0)
            and st.get("noise_correlation", 0.0) <= NOISE_CORRELATION_MAX)


def _advice(st: dict, history: list[dict], hull_slivers: int = 0) -> str:
    """What to try where the tolerance was not met: peel the outline's hull slivers where it has them; a tolerance
    below the noise raised; where the misses lie at sharp creases, say that a C1 surface rounds them; else more vertices, unless rounds with
    more did not help."""
    from ..approx.creases import CREASE_ANGLE

    if hull_slivers:
        return (f"the outline's {hull_slivers} hull slivers leave no scan vertex along its longest edges, where the "
                "coarse faces cannot follow the data: --repair peels them")
    if _below_noise(st):
        return (f"the tolerance is below {NOISE_SIGMAS} times the scan's noise estimate {st['noise']:.3g}: raise it to "
                f"{NOISE_SIGMAS * st['noise']:.3g} or more (a finer fit would follow the noise)")
    over, creased = st.get("over_tolerance", 0), st.get("over_near_creases", 0)
    if over and creased >= CREASE_SHARE * over:
        which = ("the scan vertex over it lies on or beside a sharp crease" if over == 1 else
                 f"{creased} of the {over} scan vertices over it lie on or beside sharp creases")
        return (f"{which} (faces meeting at more than {CREASE_ANGLE:.0f} degrees), which a C1 surface rounds over the "
                "patches beside them, at least a scan spacing wide: more vertices may not help there; raise the "
                "tolerance, or approximate the pieces between the creases separately")
    most = max((h["vertices"] for h in history), default=st["vertices"])
    if st["vertices"] < STALLED_SHARE * most:
        return (f"the fit kept has {st['vertices']} vertices: the rounds up to {most} deviated more, so more "
                f"vertices alone may not help (try --corners data, another --loss or a larger tolerance)")
    return "raise --vertices or the tolerance"


def add_options(p: argparse.ArgumentParser) -> None:
    """The approximation's options on ``fit``'s parser."""
    g = p.add_argument_group("approximation (a coarse spline within a tolerance instead of interpolation; "
                             "docs/approximate.md)")
    g.add_argument("--tolerance", type=positive_float, metavar="T",
                   help="largest deviation of a scan vertex from the surface, in model units "
                        "(default none: interpolate every vertex)")
    g.add_argument("--tolerance-rel", type=positive_float, metavar="R",
                   help="the same as a fraction of the bounding-box diagonal, e.g. 1e-3 (default none)")
    g.add_argument("--vertices", type=vertex_budget, metavar="N",
                   help="vertex budget (default 10%% of the scan with a tolerance; alone: at most N vertices, "
                        "spent where the deviation is largest)")
    g.add_argument("--corners", choices=("data", "fit"), default=None,
                   help="data (default): corner points interpolate their scan vertices; fit: they move too "
                        "(better on noisy scans)")
    g.add_argument("--loss", choices=("huber", "cauchy", "l2"), default=None,
                   help="data loss: huber (default), cauchy (ignores far outliers) or l2 (plain least squares)")
    g.add_argument("--outline-tolerance", action=argparse.BooleanOptionalAction, default=None,
                   help="the tolerance holds for the outline too (default): where a coarse chord spans a notch or a "
                        "bay of the scan's outline (no data under the surface there), refine until the surface's "
                        "boundary is within it (more vertices along ragged outlines); --no-outline-tolerance: the "
                        "gap is only reported, with a warning")
    g.add_argument("--fill-holes", type=nonnegative_int, default=None, metavar="K",
                   help="span holes with at most K vertices around (scanner dropouts) so that the surface goes "
                        "over them (default: every hole kept, each with three coarse vertices or more)")
    g.add_argument("--strict", action="store_true", default=None,
                   help="exit 3 (and write nothing) when the tolerance is not met within the budget")


def requested(args: argparse.Namespace) -> bool:
    """True when ``fit`` should approximate (a tolerance or a vertex budget was given)."""
    on = any(getattr(args, k, None) is not None for k in ("tolerance", "tolerance_rel", "vertices"))
    if not on:
        given = [f"--{'no-' * (getattr(args, k) is False)}{k.replace('_', '-')}" for k in _MODE_OPTIONS
                 if getattr(args, k, None) is not None]  # as typed: --no-outline-tolerance too
        if given:
            verb = "needs" if len(given) == 1 else "need"
            raise UsageError(f"{', '.join(given)} {verb} --tolerance, --tolerance-rel or --vertices (approximation)")
    return on


def _weights(args: argparse.Namespace, ui: UI, fields: tuple[tuple[str, type], ...]) -> Any:
    """The approximation's default weights with the given ``--bend`` / ``--data`` flags, or None (no flag:
    the data weight is cross-validated)."""
    from ..approx import APPROX_WEIGHTS

    given = {name: getattr(args, f"w_{name}") for name, _ in fields if getattr(args, f"w_{name}", None) is not None}
    ignored = sorted(set(given) - set(_USED_WEIGHTS))
    if ignored:
        ui.warn(f"the approximation uses only the bend and data weights; ignored: {', '.join(ignored)}")
    used = {k: v for k, v in given.items() if k in _USED_WEIGHTS}
    return dataclasses.replace(APPROX_WEIGHTS, **used) if used else None  # None: cross-validated data weight


class _Bar:
    """The approximation's progress bar: stage, vertex count, the inliers' deviation against the tolerance."""

    def __init__(self, ui: UI) -> None:
        from tqdm import tqdm

        self.bar = tqdm(total=None, desc="approximate: start JAX", file=sys.stderr, disable=ui.quiet, delay=1.0,
                        leave=False, bar_format="{desc} [{elapsed}]")

    def __call__(self, stage: str, info: dict) -> None:
        rec = info.get("record")
        if rec is None:
            desc = f"approximate: {stage} done"
        else:
            tol = "" if rec["tolerance"] is None else f" (tolerance {rec['tolerance']:.3g})"
            desc = f"approximate: round {rec['round']}, {rec['vertices']} vertices, max deviation {rec['max']:.3g}{tol}"
        with Interrupts.held():  # an interrupt inside tqdm could leave its lock held
            self.bar.set_description_str(desc, refresh=False)
            self.bar.update(0)  # shown once the work has taken over a second (tqdm's delay)

    def close(self) -> None:
        with Interrupts.held():
            self.bar.close()


def _approximate(args: argparse.Namespace, ui: UI, mesh: Any, weights: Any) -> tuple[Any, float]:
    """``(ApproxResult, seconds)``: JAX in float64, then the approximation with a progress bar."""
    bar = _Bar(ui)
    try:
        import jax

        jax.config.update("jax_enable_x64", True)
        from ..approx import approximate_surface

        t0 = time.perf_counter()
        result = approximate_surface(mesh.V, mesh.F, tolerance=args.tolerance, tolerance_rel=args.tolerance_rel,
                                     n_vertices=args.vertices, corners=args.corners or "data",
                                     loss=args.loss or "huber", weights=weights, uv=mesh.uv, param=args.param,
                                     progress=bar, outline_tolerance=args.outline_tolerance is not False,
                                     fill_holes=args.fill_holes or 0)
        return result, time.perf_counter() - t0
    finally:
        bar.close()


def _summary(args: argparse.Namespace, result: Any, mesh: Any, seconds: float) -> dict:
    """The command's result (the JSON object; :func:`_text` prints it)."""
    st = result.stats
    return dict(
        command="fit", mode="approximate", input=mesh.source, outputs=[], scan_vertices=int(mesh.V.shape[0]),
        scan_faces=int(mesh.F.shape[0]), vertices=st["vertices"], patches=st["patches"], param=args.param,
        param_used=result.parameterization.repaired or result.parameterization.method,
        corners=result.settings["corners"], loss=result.settings["loss"], tolerance=st["tolerance"],
        budget=st["budget"], met=st["met"], stop=st["stop"], deviation=st["deviation"],
        deviation_all=st["deviation_all"], outline_gap=st["outline_gap"], outline_tolerance=result.settings["outline_tolerance"],
        rejected=st["rejected"], noise=st["noise"], hull_slivers=st["hull_slivers"],
        over_tolerance=st["over_tolerance"], over_near_creases=st["over_near_creases"],
        holes_filled=st["holes_filled"], small_holes=st["small_holes"], regularity=st["regularity"], reach=st["reach"],
        noise_correlation=st["noise_correlation"], rounds=result.history,
        weights=dataclasses.asdict(result.weights), data_weight=st["data_weight"],
        cross_validated=st["cross_validated"], energies=result.energies, iterations=int(result.iterations),
        converged=bool(result.converged), c1_residual=float(result.c1_residual),
        max_interpolation_error=float(result.max_interpolation_error), timings=dict(result.timings),
        seconds=seconds)


def _gap_note(d: dict) -> str:
    """Whether the outline's gap is held to the tolerance (``--outline-tolerance``) or only reported."""
    if d["tolerance"] is None:
        return ""
    if d["outline_tolerance"]:
        return " (held to the tolerance)" if d["outline_gap"] <= d["tolerance"] else " (held to the tolerance: NOT met)"
    return " (beyond the tolerance: reported, not refined)" if d["outline_gap"] > d["tolerance"] else ""


def _text(d: dict) -> str:
    dev = d["deviation"]
    tol = ("no tolerance" if d["tolerance"] is None
           else f"tolerance {fmt(float(d['tolerance']))}: {'met' if d['met'] else 'NOT met'}")
    e = ", ".join(f"{k} {fmt(v)}" for k, v in d["energies"].items())
    return "\n".join([
        f"approximated {d['input']}: {d['scan_vertices']} scan vertices -> {d['vertices']} spline vertices, "
        f"{d['patches']} quintic patches (param {d['param']}"
        + (f" -> {d['param_used']}" if d["param_used"] != d["param"] else "")
        + f", corners {d['corners']}, loss {d['loss']})",
        f"  deviation of the inliers: max {fmt(dev['max'])}, RMS {fmt(dev['rms'])} ({tol}); the outline's largest "
        f"gap {fmt(d['outline_gap'])}{_gap_note(d)}; "
        f"{d['rejected']} points rejected as outliers; {len(d['rounds'])} rounds ({d['stop']})",
        f"  energies: {e}",
        f"  C1 residual {fmt(d['c1_residual'])} (relative), {d['seconds']:.1f} s",
        *(f"  wrote {p}" for p in d["outputs"]),
    ])


def _pinch_cure(st: dict) -> str:
    """What to try for a nearly singular patch: a lower data weight, unless the approximation already chose the
    weight again among those whose fit is regular (a tolerance and a cross-validated weight) and found none close
    to the best held-out score: then the map or the scan's own shape there (face_gpjs at 1e-3: 3e-4 at the
    cross-validated 3e5, 1e-3 at 3e4 and at 3e3, 1e-3 with --param slim or harmonic or --corners fit)."""
    from ..approx.fit import REGULAR_SLACK
    from ..approx.pipeline import REWEIGH_PINCHED

    if not st["cross_validated"]:
        return "a lower --data weight smooths it"
    if st["tolerance"] is None or not REWEIGH_PINCHED:
        return f"a lower --data weight than the cross-validated {st['data_weight']:g} smooths it"
    return (f"no data weight whose held-out error is within {REGULAR_SLACK:.0%} of the best gives a regular surface "
            f"(a lower --data weight than the cross-validated {st['data_weight']:g} may, at some accuracy; or the "
            f"scan's shape or its map is that sharp there: `trispline render --mode curvature` shows where)")


def run(args: argparse.Namespace, ui: UI, outputs: dict, *, load: Callable, write: Callable, extras: Callable,
        fields: tuple[tuple[str, type], ...]) -> int:
    """Body of ``fit`` when approximating: ``load``, ``write`` and ``extras`` are ``fit``'s own steps
    (load and validate the mesh; write all outputs atomically; the fit's file keys)."""
    import numpy as np

    mesh = load(args, ui)
    weights = _weights(args, ui, fields)
    result, seconds = _approximate(args, ui, mesh, weights)
    for m in result.parameterization.messages:  # a map replaced (folded, overlapping), mirrored, ...
        ui.warn(m)
    data = _summary(args, result, mesh, seconds)
    st = result.stats
    if _below_noise(st):
        ui.warn(f"the tolerance {st['tolerance']:.3g} is below {NOISE_SIGMAS} times the scan's noise estimate "
                f"{st['noise']:.3g}: it can only be met by following the noise")
    held = result.settings["outline_tolerance"]  # with a tolerance, unless --no-outline-tolerance
    if st["tolerance"] is not None and st["outline_gap"] > st["tolerance"] and not held:
        ui.warn(f"the surface's boundary stands up to {st['outline_gap']:.3g} ({st['outline_gap'] / st['tolerance']:.2g} "
                f"times the tolerance) from the scan's outline, with no scan data under it: a chord across a notch, "
                f"a hole's bay or a ragged run of the outline (--no-outline-tolerance: the tolerance holds for the "
                f"scan's vertices only)")
    from trispline.param.tables import SMALL_HOLE

    from ..approx.pipeline import PINCHED, WILD_REACH

    if st["reach"] > WILD_REACH:
        cure = ("the outline's hull slivers (--repair peels them)" if st["hull_slivers"]
                else "a map the scan's own shape distorts (try --param harmonic or slim)")
        ui.warn(f"the surface strays {st['reach']:.2g} bounding-box diagonals outside the scan's box, between its "
                f"vertices (a patch folds or overshoots there): {cure}")
    if st["regularity"] < PINCHED:
        ui.warn(f"the surface is nearly singular in a patch (against the scan's own, its area element falls to "
                f"{st['regularity']:.2g} of its median there: the curvature spikes); {_pinch_cure(st)}")
    if st["small_holes"] >= SMALL_HOLES_ADVICE and not args.fill_holes:
        ui.warn(f"the scan has {st['small_holes']} holes with at most {SMALL_HOLE} vertices around (dropouts?): the "
                f"surface keeps each, with three coarse vertices or more; --fill-holes {SMALL_HOLE} spans them")
    if st["tolerance"] is not None and not st["met"]:
        what = (f"the tolerance {st['tolerance']:.3g} was not met within {st['budget']} vertices: the inliers' "
                f"max deviation is {st['deviation']['max']:.3g}"
                + (f", the outline's largest gap {st['outline_gap']:.3g}" if held else "")
                + f" ({st['stop']})")
        advice = _advice(st, result.history, st["hull_slivers"])
        if args.strict:
            ui.result(data, _text)
            print(f"{PROG}: error: {what}; nothing written (--strict); {advice}", file=sys.stderr)
            return EXIT_CHECK
        ui.warn(f"{what}; {advice}")
    surface = extras(result, result.weights, args.param, mesh.source, None)
    if mesh.kept is not None:  # coarse vertex -> vertex of the mesh file
        from trispline.spline.surface import SplineSurface

        ids = np.asarray(mesh.kept, np.int64)[result.vertices]
        surface = SplineSurface(surface.uv, surface.faces, surface.ctrl,
                                extras={**surface.extras, "approx_scan_vertices": ids})
    data["outputs"] = [str(p) for p in write(args, ui, surface, outputs, None, (mesh.V, mesh.F))]
    ui.result(data, _text)
    return EXIT_OK
