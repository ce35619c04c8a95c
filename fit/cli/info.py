"""``trispline info``: topology report of a mesh and whether ``fit`` accepts it (exit 3 if not).

    trispline info MESH [--keep-largest] [--repair] [--param lscm|harmonic|slim|uv|auto]

The counts, the verdict and the distortion of the parameterization (``--param``, default
``lscm``; for a mesh fit accepts) come from :func:`trispline.param.inspect_mesh`; this
module only formats them, and warns when the map is strongly distorted.
"""
from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from trispline.param import DEFAULT_METHOD, METHODS, inspect_mesh
from trispline.param.tables import SMALL_HOLE

from .common import EXIT_CHECK, EXIT_OK, UI, add_common, fmt, one_line

__all__ = ["add_parser", "cmd_info"]


def add_parser(sub: Any) -> None:
    """Register ``info`` on an ``add_subparsers()`` action."""
    p = sub.add_parser("info", help="topology report of a mesh and whether fit accepts it",
                       description="Vertices, faces, boundary loops, holes, components, manifoldness, degenerate "
                                   "faces, and what fit would reject and why. Exit 3 if fit would reject it.")
    p.add_argument("mesh", metavar="MESH", help="input mesh (.obj .off .ply .stl .glb .gltf)")
    p.add_argument("--keep-largest", action="store_true", help="judge as fit --keep-largest would")
    p.add_argument("--repair", action="store_true",
                   help="judge the mesh repair makes of it (bowties split, non-manifold edges cut, zero-area "
                        "and duplicate faces dropped, hull slivers peeled, folded flaps cut, largest component kept), as fit "
                        "--repair would")
    p.add_argument("--param", choices=METHODS, default=DEFAULT_METHOD,
                   help=f"parameterization whose distortion is reported (default {DEFAULT_METHOD}; uv: the "
                        "file's texture coordinates, else x and y)")
    add_common(p)
    p.set_defaults(func=cmd_info)


def _fit_verdict(validation: dict[str, Any]) -> dict[str, Any]:
    """``inspect_mesh``'s validation verdict in the words of ``fit`` (one-line message)."""
    extra = {"mesh_repair": validation["mesh_repair"]} if "mesh_repair" in validation else {}
    if validation["accepted"]:
        return dict(accepted=True, problems=[], message="fit accepts this mesh", repairs=validation["repairs"],
                    **extra)
    return dict(accepted=False, problems=validation["problems"], message=one_line(validation["message"]), **extra)


def _distortion_text(d: dict[str, Any]) -> str:
    """One line: the parameterization's distortion percentiles and folds."""
    folds = d["flipped_before_repair"] + d["degenerate_before_repair"]
    return (f"  parameterization {d['method']}: angle distortion p50 {fmt(d['angle_p50'])}, p99 "
            f"{fmt(d['angle_p99'])}, max {fmt(d['angle_max'])}; area distortion p50 {fmt(d['area_p50'])}, "
            f"p99 {fmt(d['area_p99'])}, max {fmt(d['area_max'])}; "
            + (f"{folds} folded triangles repaired ({d['repaired']})" if folds else "no folds"))


def _info_text(d: dict) -> str:
    deg = d["degenerate_faces"]
    lines = [
        f"{d['file']}: {d['vertices']} vertices, {d['faces']} faces, {d['edges']} edges"
        + (f" ({d['dropped_unreferenced_vertices']} unreferenced vertices dropped)"
           if d.get("dropped_unreferenced_vertices") else ""),
        f"  components {d['components']}, boundary edges {d['boundary_edges']}, "
        f"boundary loops {d.get('boundary_loops', '?')}, holes {d.get('holes', '?')}"
        + (f" ({d['small_holes']} with at most {SMALL_HOLE} vertices around: fit --fill-holes {SMALL_HOLE} spans them "
           "in an approximation)" if d.get("small_holes") else "") + ", "
        f"genus {d.get('genus', '?')}, Euler characteristic {d['euler_characteristic']}",
        f"  manifold {d['manifold']} (non-manifold edges {d['non_manifold_edges']}, "
        f"bowtie vertices {d.get('bowtie_vertices', '?')}), degenerate faces: {deg['zero_area']} zero-area, "
        f"{deg['repeated_vertex']} with a repeated vertex; non-finite vertices {d['non_finite_vertices']}",
        f"  texture coordinates (vt): {'yes' if d.get('has_uv') else 'no'}"
        + (f" (not usable by --param uv: {d['uv_note']})" if d.get("uv_note") else ""),
        f"  folded edges (adjacent faces more than 90 degrees apart) {d['folded_edges']}"
        + (f", worst {d['worst_fold_degrees']:.0f} degrees ("
           + ("fit --repair cuts folded flaps)" if d.get("flaps") else "sharp creases, not flaps)")
           if d["folded_edges"] else ""),
        f"  hull slivers on the outline {d['hull_slivers']}"
        + (f", longest outline edge {d['longest_outline_edge']:.3g} x the median edge (fit --repair peels them)"
           if d["hull_slivers"] else ""),
    ]
    f = d["fit"]
    if f.get("mesh_repair", {}).get("messages"):
        lines.append(f"  repair: {'; '.join(f['mesh_repair']['messages'])}")
    if "distortion" in d:
        lines.append(_distortion_text(d["distortion"]))
        if d["distortion"]["reason"]:
            lines.append(f"  {d['distortion']['reason']}")
    if f["accepted"]:
        lines.append("  fit: accepted" + (f" ({'; '.join(f['repairs'])})" if f.get("repairs") else ""))
    else:
        lines.append(f"  fit: REJECTED [{', '.join(f['problems'])}]: {f['message']}")
    return "\n".join(lines)


def cmd_info(args: argparse.Namespace, ui: UI) -> int:
    """Body of ``trispline info``: exit 3 when ``fit`` would reject the mesh."""
    from ..io import read_mesh

    md = read_mesh(args.mesh)
    report = inspect_mesh(md.V, md.F, keep_largest=args.keep_largest, repair=args.repair, param=args.param,
                          uv=md.uv, vertex_ids=md.kept if md.dropped else None)
    report["fit"] = _fit_verdict(report.pop("validation"))
    if report["fit"]["accepted"] and not args.repair and not args.keep_largest:  # fit measures it in the domain
        from trispline.param import sliver_message

        sliver = sliver_message(md.V, md.F)
        if sliver:
            report["fit"] = dict(accepted=False, problems=["slivers"], message=sliver)
    if report.get("distortion", {}).get("warning"):
        ui.warn(report["distortion"]["warning"])
    data = dict(command="info", file=args.mesh, format=Path(args.mesh).suffix.lower()[1:],
                dropped_unreferenced_vertices=md.dropped, has_uv=md.uv is not None, uv_note=md.uv_note, **report)
    ui.result(data, _info_text)
    return EXIT_OK if report["fit"]["accepted"] else EXIT_CHECK
