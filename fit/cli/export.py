"""``trispline export``: a surface file to a tessellated mesh, a surface file, a picture and/or the control net.

    trispline export SURFACE.npz -o OUT.obj|ply|stl|glb|json|npz|png|step|stp|iges|igs|3dm
                     [--resolution N] [--merge] [--control-net FILE [--net-lines]]
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
    p = sub.add_parser("export", help="write a surface file as exact CAD (STEP/IGES/3dm), a mesh, a picture or JSON/NPZ",
                       description="Write the surface exactly as B-spline faces (STEP AP214, IGES, 3dm; needs the "
                                   "extra trispline[cad]), the tessellated surface with analytic normals (watertight "
                                   "along patch boundaries), a surface file, a picture, and/or the control net.")
    p.add_argument("surface", metavar="SURFACE", help="surface file (.npz or .json)")
    p.add_argument("-o", "--output", metavar="OUT",
                   help="output (.step .stp .iges .igs .3dm .obj .ply .stl .glb .json .npz .png)")
    p.add_argument("--resolution", type=positive_int, default=8, help="steps per patch edge (default 8)")
    p.add_argument("--merge", action="store_true",
                   help="CAD: two B-spline faces per patch instead of three (exact too; files about 12%% smaller)")
    p.add_argument("--control-net", metavar="FILE", help="write the control net (.obj .ply .stl .glb)")
    p.add_argument("--net-lines", action="store_true",
                   help="write the control net as line segments (OBJ 'l' records) instead of triangles")
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
    out_path = check_output(args.output, EXPORT_FORMATS, "the output")
    net_path = check_output(args.control_net, (".obj",) if args.net_lines else MESH_FORMATS, "--control-net")
    distinct([out_path, net_path])
    surface = load_surface(args.surface)
    names = (["tessellate and write"] if out_path else []) + (["control net"] if net_path else [])
    with ui.stages(names, "export") as bar, AtomicOutputs() as out:
        if out_path is not None:
            export_surface(surface, out_path, resolution=args.resolution, outputs=out, merge=args.merge)
            bar.done()
        if net_path is not None:
            export_control_net(surface, net_path, lines=args.net_lines, outputs=out)
            bar.done()
        written = out.targets
    data = dict(command="export", input=args.surface, outputs=[str(p) for p in written],
                patches=surface.n_faces, resolution=args.resolution)
    if out_path is not None and out_path.suffix.lower() in MESH_FORMATS:
        from trispline.spline.tessellate import tessellation_counts

        tri = surface.triangulation
        nverts, ntris = tessellation_counts(tri.n_vertices, tri.n_edges, tri.n_faces, args.resolution)
        data.update(mesh_vertices=nverts, mesh_triangles=ntris)
    if out_path is not None and out_path.suffix.lower() in CAD_FORMATS:
        data.update(cad_faces=(2 if args.merge else 3) * surface.n_faces)
    ui.result(data, lambda d: "\n".join(f"wrote {p}" for p in d["outputs"]))
    return EXIT_OK
