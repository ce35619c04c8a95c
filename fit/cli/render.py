"""The ``trispline render`` subcommand (registered by :func:`add_parser`).

    trispline render SURFACE.npz -o picture.png [--mode shaded|zebra|curvature|deviation|controlnet]
                     [--mesh DATA_MESH] [--view auto|iso|top|front|side|AZ,EL] [--size WxH] [--resolution N]
                     [--curvature mean|gaussian] [--stripes N] [--stripe-angle DEG] [--patch-lines auto|on|off]
                     [--title TEXT] [--caption TEXT] [--backend auto|pyvista|matplotlib] [--json] [--quiet]

Conventions of :mod:`trispline.fit.cli.common`: bad input (unreadable surface or mesh,
bad option, deviation without a data mesh) raises an ``InputError`` (exit 2,
one line on stderr); the picture is written atomically; ``--json`` prints the
result (size, backend, the view and stripe count chosen, the picture's scale
statistics) on stdout. :func:`main` runs ``trispline render ...`` on its own, with
the same exit codes. Every option's help says its default and its meaning.
"""
from __future__ import annotations

import argparse
import time
from typing import Any, Callable, Sequence

from ..errors import RenderError
from .common import (
    EXIT_OK, PROG, UI, Parser, add_common, check_output, finite_float, leave, load_surface, positive_float,
    positive_int, run_cli, stored_deviation,
)

__all__ = ["add_parser", "run", "main"]

DEFAULT_SIZE = "800x600"


def _option(parse: Callable[[str], Any]) -> Callable[[str], Any]:
    """An argparse type: ``parse(text)``, with its :class:`RenderError` reported as a bad option value."""

    def convert(text: str) -> Any:
        try:
            return parse(text)
        except RenderError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None

    convert.__name__ = parse.__name__
    return convert


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Register ``render`` on an ``add_subparsers()`` action; returns its parser (``func=run``)."""
    from ..render import BACKENDS, CURVATURES, MODES, VIEWS, check_view, parse_size
    from ..render.sampling import TARGET_TRIANGLES
    from ..render.scene import CURVATURE_PERCENTILE, PATCH_LINES_MAX
    from ..render.zebra import MAX_STRIPES, MIN_STRIPE_PIXELS, STRIPE_AREA_FRACTION

    p = subparsers.add_parser(
        "render", help="draw a picture of a surface: shaded, zebra, curvature, deviation or control net",
        description="Render a surface file off-screen to a PNG: shaded, zebra stripes (highlight lines of the "
                    "analytic normals: broken stripes show a kink), mean or Gaussian curvature, deviation from "
                    "the data mesh, or the control net. Uses PyVista/VTK without a display (pip install "
                    "'trispline[render]'), or matplotlib. Lengths are in the surface's own unit ('model units').")
    p.add_argument("surface", metavar="SURFACE", help="surface file to draw (.npz or .json)")
    p.add_argument("-o", "--output", required=True, metavar="PNG", help="picture to write (.png; required)")
    p.add_argument("--mode", choices=MODES, default="shaded",
                   help="what to show: shaded surface (front blue, back tan), zebra stripes, curvature colours, "
                        "deviation from the data mesh, or the control net (default shaded)")
    p.add_argument("--mesh", metavar="DATA_MESH",
                   help="data mesh for --mode deviation (default: the fit's data vertices stored in the surface)")
    p.add_argument("--view", type=_option(check_view), default="auto", metavar="VIEW",
                   help=f"camera direction: auto (look along the surface's mean normal, from the side it points "
                        f"to; iso for a surface that wraps around, such as a tube), {', '.join(VIEWS)}, or AZIMUTH,ELEVATION in degrees, z up (default auto)")
    p.add_argument("--size", type=_option(parse_size), default=DEFAULT_SIZE, metavar="WxH",
                   help=f"picture width x height in pixels, 16..8192 each (default {DEFAULT_SIZE})")
    p.add_argument("--resolution", type=positive_int, default=None, metavar="N",
                   help=f"samples per patch edge (default: automatic, about {TARGET_TRIANGLES['pyvista'] / 1e6:g}M "
                        f"triangles with PyVista, {TARGET_TRIANGLES['matplotlib'] / 1e3:g}k with matplotlib, "
                        f"at most 8)")
    p.add_argument("--curvature", choices=CURVATURES, default="mean",
                   help=f"for --mode curvature: mean H (1/model unit) or Gaussian K (1/model unit^2); the colour "
                        f"range is the {CURVATURE_PERCENTILE:g}th percentile of |value| (default mean)")
    p.add_argument("--stripes", type=positive_float, default=None, metavar="N",
                   help=f"zebra: stripe pairs (light tubes) per bounding-box diagonal (default: automatic, the "
                        f"most up to {MAX_STRIPES:g} that keep pairs {MIN_STRIPE_PIXELS:g} px wide on "
                        f"{100 * STRIPE_AREA_FRACTION:g}%% of the surface, so that they do not alias into noise)")
    p.add_argument("--stripe-angle", type=finite_float, default=45.0, metavar="DEG",
                   help="zebra: direction of the tubes on screen, degrees from horizontal (default 45)")
    p.add_argument("--patch-lines", choices=("auto", "on", "off"), default="auto",
                   help=f"draw the patch boundaries (default auto: up to {PATCH_LINES_MAX} patches)")
    p.add_argument("--title", default=None, metavar="TEXT", help="picture title (default: the mode and patch count)")
    p.add_argument("--caption", default=None, metavar="TEXT",
                   help="text in the bottom right corner (default: the date, the surface file name and the "
                        "trispline version; --caption '' for none)")
    p.add_argument("--backend", choices=BACKENDS, default=None,
                   help="auto (PyVista, else matplotlib with a warning), pyvista, matplotlib (default: "
                        "$TRISPLINE_RENDER_BACKEND, else auto)")
    add_common(p)
    p.set_defaults(func=run)
    return p


def _text(d: dict) -> str:
    stats = d["stats"]
    extra = ""
    if d["mode"] == "curvature":
        span = "undefined" if stats["min"] is None else f"in [{stats['min']:.3g}, {stats['max']:.3g}]"
        extra = f", {stats['curvature']} curvature {span}"
    elif d["mode"] == "deviation":
        extra = f", max deviation {stats['max_abs']:.3g}, RMS {stats['rms']:.3g}"
    elif d["mode"] == "zebra":
        how = "automatic" if stats["stripes_auto"] else "set"
        extra = (f", {stats['stripes']:g} stripes ({how}, pairs >= {stats['stripe_pixels']:.3g} px), "
                 f"stripe spacing {stats['stripe_spacing']:.3g}")
    return (f"wrote {d['output']} ({d['width']}x{d['height']}, {d['mode']}, {stats['patches']} patches at "
            f"resolution {stats['resolution']}, {d['backend']}, {d['seconds']:.1f} s{extra})")


def _scan_vertices(extras: dict) -> int | None:
    """How many vertices the scan of an approximation had (its stored inliers and rejected points), or None."""
    try:
        dev = stored_deviation(extras)
    except (TypeError, ValueError):  # a damaged file: no hint, the picture still drawn
        return None
    return None if dev is None or "count" not in dev else int(round(dev["count"] + dev.get("rejected", 0.0)))


def run(args: argparse.Namespace, ui: UI | None = None) -> int:
    """Body of ``trispline render``; ``ui`` is the command line's output helper (made if None)."""
    from ..render import caption_text, draw, write_png

    ui = ui if ui is not None else UI(args)
    out = check_output(args.output, (".png",), "the picture", [args.surface, args.mesh])
    if args.mesh is not None and args.mode != "deviation":
        ui.warn(f"--mesh is used by --mode deviation only; ignored for --mode {args.mode}")
    surface = load_surface(args.surface)
    mesh = None
    if args.mode == "deviation" and args.mesh is not None:
        from ..io import read_mesh

        md = read_mesh(args.mesh)
        mesh = (md.V, md.F)
        scanned = _scan_vertices(surface.extras)
        if scanned is not None and scanned != md.V.shape[0]:
            ui.warn(f"{args.mesh} has {md.V.shape[0]} vertices, the scan {args.surface} approximates had {scanned}: "
                    "is it the same scan? (the deviation is drawn against the mesh given)")
    lines = {"auto": None, "on": True, "off": False}[args.patch_lines]
    t0 = time.perf_counter()
    with ui.stages(("draw", "write"), "render") as bar:
        caption = caption_text(args.surface) if args.caption is None else args.caption
        pic = draw(surface, args.mode, mesh=mesh, view=args.view, size=args.size, resolution=args.resolution,
                   curvature=args.curvature, stripes=args.stripes, stripe_angle=args.stripe_angle,
                   patch_lines=lines, title=args.title, backend=args.backend, caption=caption or False)
        bar.done()
        write_png(pic.image, out)
        bar.done()
    seconds = time.perf_counter() - t0
    h, w = pic.image.shape[:2]
    view = pic.stats["view"]
    data = dict(command="render", input=args.surface, output=str(out), outputs=[str(out)], mode=args.mode,
                width=w, height=h, backend=pic.backend, view=[view["azimuth"], view["elevation"]],
                view_auto=view["auto"], caption=caption, legend=list(pic.legend), stats=pic.stats, seconds=seconds)
    ui.result(data, _text)
    return EXIT_OK


def main(argv: Sequence[str] | None = None) -> int:
    """``trispline render ...`` on its own (the same exit codes and messages as :func:`trispline.fit.cli.main`)."""

    def make_parser() -> argparse.ArgumentParser:
        parser = Parser(prog=PROG)
        sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=Parser)
        sub.required = True
        add_parser(sub)
        return parser

    code = run_cli(make_parser, argv)
    if argv is None:
        leave(code)
    return code


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
