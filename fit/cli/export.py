"""``trispline export``: a surface file to a tessellated mesh, a surface file, a picture and/or the control net.

    trispline export SURFACE.npz -o OUT.obj|ply|stl|glb|json|npz|png|step|stp|iges|igs|3dm
                     [--resolution N] [--merge] [--control-net FILE [--net-lines]]

A mesh or CAD export's size is estimated before anything is written (``--json`` reports
``estimated_bytes``); above :data:`~trispline.fit.io.export.LARGE_EXPORT_BYTES` a
warning says so. The default ``--resolution`` follows the patch count
(:func:`~trispline.fit.io.sizes.export_resolution`); one given is honoured.
"""
from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from ..errors import UsageError
from .common import EXIT_OK, UI, add_common, check_output, distinct, load_surface, positive_int

__all__ = ["add_parser", "cmd_export"]


def add_parser(sub: Any) -> None:
    """Register ``export`` on an ``add_subparsers()`` action."""
    from ..io.export import LARGE_EXPORT_BYTES
    from ..io.sizes import EXPORT_TRIANGLES, MAX_EXPORT_RESOLUTION

    p = sub.add_parser("export",
                       help="write a surface file as exact CAD (STEP/IGES/3dm), a mesh, a picture or JSON/NPZ",
                       description="Write the surface exactly as B-spline faces (STEP AP214, IGES, 3dm; needs the "
                                   "extra trispline[cad]), the tessellated surface with analytic normals (watertight "
                                   "along patch boundaries), a surface file, a picture, and/or the control net. "
                                   "A mesh's or CAD file's size is estimated first, with a warning above "
                                   f"{LARGE_EXPORT_BYTES / 1e6:g} MB.")
    p.add_argument("surface", metavar="SURFACE", help="surface file to export (.npz or .json)")
    p.add_argument("-o", "--output", metavar="OUT",
                   help="output; the suffix picks the format: .step .stp .iges .igs .3dm (exact CAD), .obj .ply "
                        ".stl .glb .off (mesh), .json .npz (surface file), .png (shaded picture); default: none")
    p.add_argument("--resolution", type=positive_int, default=None, metavar="N",
                   help=f"steps per patch edge of a mesh (N^2 triangles per patch) or samples of a picture "
                        f"(default: automatic, about {EXPORT_TRIANGLES / 1e6:g}M triangles, "
                        f"1..{MAX_EXPORT_RESOLUTION}: {MAX_EXPORT_RESOLUTION} up to about "
                        f"{EXPORT_TRIANGLES // MAX_EXPORT_RESOLUTION**2 // 1000}k "
                        f"patches; pictures: the renderer's own)")
    p.add_argument("--merge", action="store_true",
                   help="CAD: two B-spline faces per patch instead of three (exact too; files about 12%% smaller; "
                        "default: three)")
    p.add_argument("--control-net", metavar="FILE",
                   help="also write the control net (.obj .ply .stl .glb .off; default: none)")
    p.add_argument("--net-lines", action="store_true",
                   help="write the control net as line segments (OBJ 'l' records) instead of triangles "
                        "(default: triangles)")
    add_common(p)
    p.set_defaults(func=cmd_export)


def cmd_export(args: argparse.Namespace, ui: UI) -> int:
    """Body of ``trispline export``: every output written atomically, all or nothing."""
    from trispline.spline.util.atomic import AtomicOutputs

    from ..io.export import EXPORT_FORMATS, MESH_FORMATS, export_control_net, export_surface
    from ..io.formats import CAD_FORMATS

    if args.output is None and args.control_net is None:
        raise UsageError("nothing to write: give -o OUT and/or --control-net FILE")
    if args.net_lines and args.control_net is None:
        raise UsageError("--net-lines needs --control-net FILE")
    if args.merge and not (args.output and Path(args.output).suffix.lower() in CAD_FORMATS):
        raise UsageError("--merge is for CAD outputs (-o OUT.step|.stp|.iges|.igs|.3dm)")
    out_path = check_output(args.output, EXPORT_FORMATS, "the output", [args.surface])
    net_path = check_output(args.control_net, (".obj",) if args.net_lines else MESH_FORMATS, "--control-net",
                            [args.surface])
    distinct([out_path, net_path])
    surface = load_surface(args.surface)
    data = dict(command="export", input=args.surface, output=None if out_path is None else str(out_path),
                patches=surface.n_faces, resolution=args.resolution, resolution_auto=args.resolution is None)
    data.update(_mesh_size(surface, out_path, args.resolution, args.merge))
    names = (["tessellate and write"] if out_path else []) + (["control net"] if net_path else [])
    with ui.stages(names, "export") as bar, AtomicOutputs() as out:
        if out_path is not None:
            export_surface(surface, out_path, resolution=data["resolution"], outputs=out, merge=args.merge)
            bar.done()
        if net_path is not None:
            export_control_net(surface, net_path, lines=args.net_lines, outputs=out)
            bar.done()
        written = out.targets
    data["outputs"] = [str(p) for p in written]
    ui.result(data, _text)
    return EXIT_OK


def _mesh_size(surface: Any, out_path: Path | None, resolution: int | None, merge: bool) -> dict[str, Any]:
    """The resolution a mesh output gets (``resolution`` or the automatic one), its vertex and
    triangle counts and its estimated size in bytes; a CAD output's faces and estimated size;
    nothing for other outputs."""
    from trispline.spline.tessellate import tessellation_counts

    from ..io.formats import CAD_FORMATS, MESH_FORMATS
    from ..io.sizes import estimate_export_bytes, export_resolution

    if out_path is not None and out_path.suffix.lower() in CAD_FORMATS:
        return dict(cad_faces=(2 if merge else 3) * surface.n_faces,
                    estimated_bytes=estimate_export_bytes(surface, out_path, merge=merge))
    if out_path is None or out_path.suffix.lower() not in MESH_FORMATS:
        return {}
    r = export_resolution(surface.n_faces) if resolution is None else resolution
    tri = surface.triangulation
    nverts, ntris = tessellation_counts(tri.n_vertices, tri.n_edges, tri.n_faces, r)
    return dict(resolution=r, mesh_vertices=nverts, mesh_triangles=ntris,
                estimated_bytes=estimate_export_bytes(surface, out_path, r))


def _text(d: dict) -> str:
    """The summary: each file written, a mesh with its size and resolution."""
    lines = []
    for p in d["outputs"]:
        if "cad_faces" in d and p == d["output"]:
            lines.append(f"wrote {p} ({d['cad_faces']:,} B-spline faces, about {d['estimated_bytes'] / 1e6:.3g} MB)")
        elif "estimated_bytes" in d and p == d["output"]:
            how = "automatic" if d["resolution_auto"] else "set"
            lines.append(f"wrote {p} ({d['mesh_triangles']:,} triangles, resolution {d['resolution']} ({how}), "
                         f"about {d['estimated_bytes'] / 1e6:.3g} MB)")
        else:
            lines.append(f"wrote {p}")
    return "\n".join(lines)
