"""``trispline fit`` and ``trispline demo``: load (or generate) a mesh, validate, fit, write atomically.

    trispline fit MESH -o SURFACE.npz [--param lscm|harmonic|uv] [--bend W ...] [--keep-largest]
                  [--mesh-out FILE --resolution N] [--image PNG] [--control-net FILE]
    trispline fit --example -o SURFACE.npz                # the built-in synthetic scan
    trispline demo [-o DIR]                               # the example, with every output in DIR

The mesh is validated before JAX starts, so an unusable mesh fails in a fraction of
a second; JAX is imported (and switched to float64) only here.
"""
from __future__ import annotations

import argparse
import dataclasses
import time
from pathlib import Path
from typing import Any, Callable

import numpy as np

from trispline.param import DEFAULT_METHOD, METHODS

from ..errors import CommandFailed, FitError, UsageError
from ..stages import FIT_STAGES
from ..weights import FitWeights
from . import approximate
from .common import EXIT_OK, UI, add_common, check_output, distinct, fmt, nonneg_float, positive_int

__all__ = ["WEIGHT_FIELDS", "FIT_STAGES", "EXAMPLE_FACES", "add_parsers", "cmd_fit", "cmd_demo"]

#: Default faces of the built-in example scan.
EXAMPLE_FACES = 800
#: One flag per :class:`~trispline.fit.weights.FitWeights` field: ``(name, type of its default)``
#: (``trispline.fit.weights`` imports no JAX, so the parser stays fast).
WEIGHT_FIELDS: tuple[tuple[str, type], ...] = tuple(
    (f.name, type(f.default)) for f in dataclasses.fields(FitWeights))


# ============================================================================ parser
def add_parsers(sub: Any) -> None:
    """Register ``fit`` and ``demo`` on an ``add_subparsers()`` action."""
    p = sub.add_parser("fit", help="fit a C1 spline surface to an open mesh",
                       description="Interpolate the mesh vertices with an exactly C1 quintic spline and fair it. "
                                   "Vertex i of the mesh is vertex i of the surface (its corner point).")
    p.add_argument("mesh", nargs="?", metavar="MESH", help="input mesh (.obj .off .ply .stl .glb .gltf)")
    p.add_argument("--example", action="store_true", help="fit the built-in synthetic scan instead of MESH")
    p.add_argument("--example-faces", type=positive_int, default=EXAMPLE_FACES,
                   help=f"triangles of the built-in scan (default {EXAMPLE_FACES})")
    p.add_argument("-o", "--output", required=True, metavar="SURFACE", help="surface file to write (.npz or .json)")
    _add_fit_options(p)
    approximate.add_options(p)
    add_common(p)
    p.set_defaults(func=cmd_fit)

    p = sub.add_parser("demo", help="fit the built-in example scan; write mesh, surface, tessellation and picture",
                       description="Generate the built-in synthetic scan (open, bumpy, noisy, with a hole), fit it "
                                   "and write DIR/scan.obj, DIR/surface.npz, DIR/surface.ply and DIR/surface.png.")
    p.add_argument("-o", "--output-dir", default="trispline-demo", metavar="DIR",
                   help="folder for the results (created; default trispline-demo)")
    p.add_argument("--example-faces", type=positive_int, default=EXAMPLE_FACES,
                   help=f"triangles of the built-in scan (default {EXAMPLE_FACES})")
    _add_fit_options(p)
    add_common(p)
    p.set_defaults(func=cmd_demo, mesh=None, example=True)


def _add_fit_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--param", choices=METHODS, default=DEFAULT_METHOD,
                   help="parameterization: lscm (free boundary, default), harmonic (boundary on a circle), "
                        "uv (the OBJ's texture coordinates, or x, y of a height field)")
    p.add_argument("--keep-largest", action="store_true",
                   help="fit the largest connected component instead of rejecting several components "
                        "(vertices are renumbered; the surface file records the input index)")
    p.add_argument("--max-steps", type=positive_int, default=50, help="Gauss-Newton step limit (default 50)")
    p.add_argument("--resolution", type=positive_int, default=8,
                   help="tessellation steps per patch edge for --mesh-out / --image (default 8)")
    p.add_argument("--mesh-out", metavar="FILE", help="also write the tessellated surface (.obj .ply .stl .glb)")
    p.add_argument("--image", metavar="PNG", help="also render a picture of the surface (.png)")
    p.add_argument("--control-net", metavar="FILE", help="also write the control net as a mesh (.obj .ply .stl .glb)")
    g = p.add_argument_group("fairness weights (FitWeights fields; defaults and meaning in docs/fit.md)")
    for name, kind in WEIGHT_FIELDS:
        conv = positive_int if kind is int else nonneg_float
        g.add_argument(f"--{name.replace('_', '-')}", dest=f"w_{name}", type=conv, default=None,
                       metavar="N" if kind is int else "W", help=f"FitWeights.{name}")


# ============================================================================ commands
def cmd_fit(args: argparse.Namespace, ui: UI) -> int:
    """Body of ``trispline fit``."""
    from ..io.export import IMAGE_FORMATS, MESH_FORMATS, SURFACE_FORMATS

    if args.example and args.mesh:
        raise UsageError("give either MESH or --example, not both")
    if not args.example and not args.mesh:
        raise UsageError("the following arguments are required: MESH (or --example)")
    outputs = dict(
        surface=check_output(args.output, SURFACE_FORMATS, "the surface"),
        mesh=check_output(args.mesh_out, MESH_FORMATS, "--mesh-out"),
        image=check_output(args.image, IMAGE_FORMATS, "--image"),
        control_net=check_output(args.control_net, MESH_FORMATS, "--control-net"),
    )
    distinct(list(outputs.values()))
    if approximate.requested(args):  # --tolerance / --tolerance-rel / --vertices: fit/cli/approximate.py
        return approximate.run(args, ui, outputs, load=_load_input, write=_write, extras=_with_fit_extras,
                               fields=WEIGHT_FIELDS)
    data = _fit(args, ui, outputs)
    ui.result(data, _fit_text)
    return EXIT_OK


def cmd_demo(args: argparse.Namespace, ui: UI) -> int:
    """Body of ``trispline demo``: ``fit --example`` with every output in one folder."""
    from ..io.export import export_mesh

    folder = Path(args.output_dir)
    if folder.exists() and not folder.is_dir():
        raise UsageError(f"{folder} exists and is not a folder")
    folder.mkdir(parents=True, exist_ok=True)
    outputs = dict(surface=folder / "surface.npz", mesh=folder / "surface.ply", image=folder / "surface.png",
                   control_net=None)
    for name in ("mesh_out", "image", "control_net"):
        if getattr(args, name, None):
            raise UsageError(f"demo writes its files into {folder}; --{name.replace('_', '-')} belongs to fit")

    def write_scan(out, VF) -> None:
        export_mesh(VF[0], VF[1], folder / "scan.obj", outputs=out)

    data = _fit(args, ui, outputs, write_scan)
    data["output_dir"] = str(folder)
    ui.result(data, lambda d: _fit_text(d) + f"\n  view {folder / 'surface.png'}; "
                                            f"next: trispline check {folder / 'surface.npz'}")
    return EXIT_OK


# ============================================================================ the fit
@dataclasses.dataclass
class _Input:
    """The mesh to fit, after loading and validation."""

    V: np.ndarray  # (nv, 3)
    F: np.ndarray  # (nf, 3)
    uv: np.ndarray | None  # (nv, 2) domain for fit_surface: the file's vt, with --param uv only
    source: str  # the file name, or a description of the built-in scan
    kept: np.ndarray | None  # (nv,) index in the file of each vertex, when vertices were dropped


def _fit(args: argparse.Namespace, ui: UI, outputs: dict[str, Path | None],
         extra_writes: Callable[[Any, Any], None] | None = None) -> dict:
    """Shared body of ``fit`` and ``demo``: load, validate, fit, write everything atomically."""
    mesh = _load_input(args, ui)
    result, weights, fit_seconds = _solve(args, ui, mesh)
    surface = _with_fit_extras(result, weights, args.param, mesh.source, mesh.kept)
    written = _write(args, ui, surface, outputs, extra_writes, (mesh.V, mesh.F))
    return dict(
        command=args.command, input=mesh.source, outputs=[str(p) for p in written],
        vertices=int(mesh.V.shape[0]), faces=int(mesh.F.shape[0]), patches=int(surface.n_faces),
        param=args.param,
        parameterization_repaired=getattr(result.parameterization, "repaired", None),
        weights=dataclasses.asdict(weights), energies=result.energies, iterations=int(result.iterations),
        converged=bool(result.converged), c1_residual=float(result.c1_residual),
        max_interpolation_error=float(result.max_interpolation_error),
        timings=dict(result.timings), seconds=fit_seconds,
        source_vertex_index=None if mesh.kept is None else "stored in the surface file",
    )


def _load_input(args: argparse.Namespace, ui: UI) -> _Input:
    """Read (or generate) the mesh and validate it, before JAX starts."""
    from trispline.param import parameterize, validate_mesh

    kept: np.ndarray | None = None
    file_uv = None
    if args.example:
        from ..datasets.synthetic import synthetic_scan

        V, F = synthetic_scan(args.example_faces)
        source = f"built-in example scan ({args.example_faces} faces requested)"
    else:
        from ..io import read_mesh

        md = read_mesh(args.mesh)
        V, F, file_uv = md.V, md.F, md.uv
        source = str(args.mesh)
        if md.dropped:
            kept = md.kept
    vm = validate_mesh(V, F, keep_largest=args.keep_largest)
    for m in vm.messages:
        ui.warn(m)
    if vm.kept is not None:
        V, F = vm.V, vm.F
        kept = vm.kept if kept is None else kept[vm.kept]
        file_uv = None if file_uv is None else file_uv[vm.kept]
        ui.warn(f"vertices were renumbered (the surface's source_vertex_index maps them to {source})")
    uv = None
    if args.param == "uv" and file_uv is not None:
        p = parameterize(V, F, method="uv", uv=file_uv)
        uv, F = p.uv, p.faces
        for m in p.messages:
            ui.warn(m)
    return _Input(V=V, F=F, uv=uv, source=source, kept=kept)


def _solve(args: argparse.Namespace, ui: UI, mesh: _Input) -> tuple[Any, Any, float]:
    """``(FitResult, FitWeights, seconds)``: JAX in float64, then ``fit_surface`` with a progress bar."""
    with ui.stages(("start JAX",) + FIT_STAGES, "fit") as bar:
        import jax

        jax.config.update("jax_enable_x64", True)
        from ..pipeline import fit_surface

        bar.done()
        given = {name: getattr(args, f"w_{name}") for name, _ in WEIGHT_FIELDS
                 if getattr(args, f"w_{name}", None) is not None}
        weights = FitWeights(**given)
        t0 = time.perf_counter()
        try:
            result = fit_surface(mesh.V, mesh.F, uv=mesh.uv, param=args.param, weights=weights,
                                 max_steps=args.max_steps, progress=_progress(bar))
        except FitError as exc:
            raise CommandFailed(f"{exc} (try a larger --max-steps or other weights)") from exc
        seconds = time.perf_counter() - t0
    return result, weights, seconds


def _progress(bar: Any) -> Callable[..., None]:
    """``fit_surface``'s progress callback for the bar: stage ends, and chunks within a stage."""

    def progress(stage: str, _seconds: float, fraction: float | None = None) -> None:
        if fraction is None:
            bar.done(stage)
        else:
            bar.at(stage, fraction)

    return progress


def _write(args: argparse.Namespace, ui: UI, surface: Any, outputs: dict[str, Path | None],
           extra_writes: Callable[[Any, Any], None] | None, VF: tuple[np.ndarray, np.ndarray]) -> list[Path]:
    """Write the surface and the requested extras, all or nothing; returns the files written."""
    from trispline.spline.util.atomic import AtomicOutputs

    from ..io.export import export_control_net, export_surface

    with ui.stages(("write",), "write"), AtomicOutputs() as out:
        surface.save(out.path(outputs["surface"]))
        if outputs.get("mesh") is not None:
            export_surface(surface, outputs["mesh"], resolution=args.resolution, outputs=out)
        if outputs.get("image") is not None:
            export_surface(surface, outputs["image"], resolution=min(args.resolution, 6), outputs=out)
        if outputs.get("control_net") is not None:
            export_control_net(surface, outputs["control_net"], outputs=out)
        if extra_writes is not None:
            extra_writes(out, VF)
        return out.targets


def _with_fit_extras(result: Any, weights: Any, param: str, source: str, kept: np.ndarray | None) -> Any:
    """The fitted surface with the fit's settings and energies as optional file keys."""
    from trispline.spline.surface import SplineSurface

    extras = dict(result.surface.extras) if result.surface is not None else {}
    w = dataclasses.asdict(weights)
    extras.update(
        fit_weight_names=np.array(list(w), dtype=str),
        fit_weights=np.array([float(v) for v in w.values()]),
        fit_energy_names=np.array(list(result.energies), dtype=str),
        fit_energies=np.array([float(v) for v in result.energies.values()]),
        fit_param=np.array(param),
        fit_source=np.array(source),
        fit_iterations=np.array(int(result.iterations)),
        fit_converged=np.array(bool(result.converged)),
    )
    if kept is not None:
        extras["source_vertex_index"] = np.asarray(kept, np.int64)
    return SplineSurface(result.uv, result.faces, result.ctrl, extras=extras)


def _fit_text(d: dict) -> str:
    e = ", ".join(f"{k} {fmt(v)}" for k, v in d["energies"].items())
    return "\n".join([
        f"fitted {d['input']}: {d['vertices']} vertices, {d['patches']} quintic patches "
        f"(param {d['param']}{', repaired by ' + d['parameterization_repaired'] if d['parameterization_repaired'] else ''})",
        f"  energies: {e}",
        f"  Gauss-Newton steps {d['iterations']}, C1 residual {fmt(d['c1_residual'])} (relative), "
        f"max interpolation error {fmt(d['max_interpolation_error'])}, {d['seconds']:.1f} s",
        "  time: " + ", ".join(f"{k} {v:.2f} s" for k, v in d["timings"].items()),
        *(f"  wrote {p}" for p in d["outputs"]),
    ])
