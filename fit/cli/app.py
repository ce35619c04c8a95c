"""The ``trispline`` command line (also ``python -m trispline.fit``).

    trispline demo [-o DIR]                               # fit the built-in example scan
    trispline fit MESH -o SURFACE.npz [--param harmonic|lscm|uv] [--bend W ...]
                  [--keep-largest] [--mesh-out FILE --resolution N] [--image PNG]
    trispline fit --example -o SURFACE.npz                # the built-in synthetic scan
    trispline export SURFACE.npz -o OUT.obj|ply|stl|glb|json|npz|png [--resolution N]
                  [--control-net FILE [--net-lines]]
    trispline check SURFACE.npz [--tolerance T]           # continuity residuals, statistics
    trispline info MESH                                   # topology, what fit would reject

Every command takes ``--json`` (machine-readable result on stdout, nothing else
there), ``--quiet`` (no progress bars, no summary) and ``--debug`` (a traceback
for internal failures). Exit codes: 0 success; 1 internal failure; 2 bad input
(unreadable or unusable mesh or surface file, bad option; one line on stderr, no
traceback); 3 ``check``/``info`` found a problem (C1 broken beyond the
tolerance; a mesh ``fit`` would reject). Outputs are written atomically: a
failed command leaves no file behind, not even a partial one.

JAX is imported (and switched to float64) only by ``fit`` and ``demo``, so the
other commands start quickly.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import os
import sys
import time
import traceback
import warnings
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from trispline.spline.errors import InputError
from ..errors import CommandFailed, UsageError

__all__ = ["main", "build_parser", "EXIT_OK", "EXIT_FAILURE", "EXIT_INPUT", "EXIT_CHECK", "UsageError", "CommandFailed", "WEIGHT_FIELDS", "mesh_report", "surface_report"]

EXIT_OK = 0
EXIT_FAILURE = 1
EXIT_INPUT = 2
EXIT_CHECK = 3
PROG = "trispline"

#: Stages reported by ``fit_surface(progress=...)``, in order (for the progress bar).
FIT_STAGES = ("parameterize", "build", "assemble", "factor", "solve", "finish")
#: Default relative tolerance of ``check`` (algebraic identities hold to ~1e-14).
CHECK_TOLERANCE = 1e-9
#: Default faces of the built-in example scan.
EXAMPLE_FACES = 800




class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # type: ignore[override]
        raise UsageError(f"{message} (see '{self.prog} --help')")


# ============================================================================ output
class _UI:
    """Where things go: results on stdout, progress / warnings / errors on stderr."""

    def __init__(self, args: argparse.Namespace) -> None:
        self.json = bool(getattr(args, "json", False))
        self.quiet = bool(getattr(args, "quiet", False))
        self.warnings: list[str] = []

    def warn(self, message: str) -> None:
        message = _one_line(message)
        if message not in self.warnings:
            self.warnings.append(message)
            print(f"{PROG}: warning: {message}", file=sys.stderr, flush=True)

    def note(self, message: str) -> None:
        """A progress note on stderr (silenced by --quiet)."""
        if not self.quiet:
            print(f"{PROG}: {message}", file=sys.stderr, flush=True)

    def result(self, data: dict, text: Callable[[dict], str]) -> None:
        """The command's result: JSON or text on stdout (text silenced by --quiet)."""
        if self.json:
            data = dict(data, warnings=list(self.warnings))
            print(json.dumps(_jsonable(data), indent=2, allow_nan=False))
        elif not self.quiet:
            print(text(data))

    def stages(self, names: Sequence[str], title: str) -> "_Stages":
        return _Stages(names, title, disable=self.quiet)


class _Stages:
    """A tqdm bar over named stages on stderr; appears only for work taking over ~1 s."""

    def __init__(self, names: Sequence[str], title: str, disable: bool) -> None:
        from tqdm import tqdm

        self.names = list(names)
        self.title = title
        self.i = 0
        self.bar = tqdm(total=len(self.names), desc=self._desc(), file=sys.stderr, disable=disable,
                        delay=1.0, leave=False, bar_format="{desc} {bar:20} {n}/{total} [{elapsed}]")

    def _desc(self) -> str:
        name = self.names[self.i] if self.i < len(self.names) else "done"
        return f"{self.title}: {name}"

    def done(self, name: str | None = None) -> None:
        """Mark the current (or the named) stage finished."""
        if name is not None and name in self.names:
            step = self.names.index(name) + 1 - self.i
        else:
            step = 1
        if step > 0:
            self.i += step
            self.bar.set_description_str(self._desc(), refresh=False)
            self.bar.update(step)

    def close(self) -> None:
        self.bar.close()

    def __enter__(self) -> "_Stages":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _one_line(message: str) -> str:
    """Collapse a multi-line message ("problems:\\n  - a\\n  - b") into one line."""
    lines = [ln.strip() for ln in str(message).splitlines() if ln.strip()]
    if not lines:
        return "(no message)"
    rest = [ln[2:] if ln.startswith("- ") else ln for ln in lines[1:]]
    return " ".join([lines[0], "; ".join(rest)]) if rest else lines[0]


def _jsonable(value: Any) -> Any:
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return _jsonable(value.tolist())
    if isinstance(value, np.generic):
        return _jsonable(value.item())
    if isinstance(value, Path):
        return str(value)
    if isinstance(value, float) and not np.isfinite(value):
        return None
    return value


def _fmt(x: float) -> str:
    return f"{x:.3g}" if isinstance(x, float) else str(x)


# ============================================================================ parser
def _positive_int(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}") from None
    if v < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {v}")
    return v


def _nonneg_float(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not (np.isfinite(v) and v >= 0):
        raise argparse.ArgumentTypeError(f"expected a finite number >= 0, got {text}")
    return v


#: One flag per :class:`~trispline.fit.pipeline.FitWeights` field (name, type). Listed here
#: rather than read from the dataclass so that the parser does not import JAX (2 s);
#: tests/test_cli.py checks that this table matches ``dataclasses.fields(FitWeights)``.
WEIGHT_FIELDS: tuple[tuple[str, type], ...] = (
    ("bend", float), ("tilt", float), ("local", float), ("data", float), ("angle", float),
    ("fit_degree", int), ("fit_rings", int), ("blend_power", float),
)


def _add_common(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("output control")
    g.add_argument("--json", action="store_true", help="print the result as JSON on stdout (nothing else there)")
    g.add_argument("-q", "--quiet", action="store_true", help="no progress bars and no summary")
    g.add_argument("--debug", action="store_true", default=argparse.SUPPRESS,
                   help="show the full traceback of internal failures")


def _add_fit_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--param", choices=("harmonic", "lscm", "uv"), default="lscm",
                   help="parameterization: lscm (free boundary, default), harmonic (boundary on a circle), "
                        "uv (the OBJ's texture coordinates, or x, y of a height field)")
    p.add_argument("--keep-largest", action="store_true",
                   help="fit the largest connected component instead of rejecting several components "
                        "(vertices are renumbered; the surface file records the input index)")
    p.add_argument("--max-steps", type=_positive_int, default=50, help="Gauss-Newton step limit (default 50)")
    p.add_argument("--resolution", type=_positive_int, default=8,
                   help="tessellation steps per patch edge for --mesh-out / --image (default 8)")
    p.add_argument("--mesh-out", metavar="FILE", help="also write the tessellated surface (.obj .ply .stl .glb)")
    p.add_argument("--image", metavar="PNG", help="also render a picture of the surface (.png)")
    p.add_argument("--control-net", metavar="FILE", help="also write the control net as a mesh (.obj .ply .stl .glb)")
    g = p.add_argument_group("fairness weights (FitWeights fields; defaults and meaning in docs/fit.md)")
    for name, kind in WEIGHT_FIELDS:
        conv = _positive_int if kind is int else _nonneg_float
        g.add_argument(f"--{name.replace('_', '-')}", dest=f"w_{name}", type=conv, default=None,
                       metavar="N" if kind is int else "W", help=f"FitWeights.{name}")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``trispline`` (imports nothing heavy)."""
    parser = _Parser(
        prog=PROG,
        description="Fit exactly C1 quintic triangular spline surfaces to open triangle meshes.",
        epilog="Exit codes: 0 ok, 1 internal failure, 2 bad input, 3 check/info found a problem.",
    )
    parser.add_argument("--version", action="version", version=f"{PROG} {_version()}")
    parser.add_argument("--debug", action="store_true", help="show the full traceback of internal failures")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True

    p = sub.add_parser("fit", help="fit a C1 spline surface to an open mesh",
                       description="Interpolate the mesh vertices with an exactly C1 quintic spline and fair it. "
                                   "Vertex i of the mesh is vertex i of the surface (its corner point).")
    p.add_argument("mesh", nargs="?", metavar="MESH", help="input mesh (.obj .off .ply .stl .glb .gltf)")
    p.add_argument("--example", action="store_true", help="fit the built-in synthetic scan instead of MESH")
    p.add_argument("--example-faces", type=_positive_int, default=EXAMPLE_FACES,
                   help=f"triangles of the built-in scan (default {EXAMPLE_FACES})")
    p.add_argument("-o", "--output", required=True, metavar="SURFACE", help="surface file to write (.npz or .json)")
    _add_fit_options(p)
    _add_common(p)
    p.set_defaults(func=cmd_fit)

    p = sub.add_parser("demo", help="fit the built-in example scan; write mesh, surface, tessellation and picture",
                       description="Generate the built-in synthetic scan (open, bumpy, noisy, with a hole), fit it "
                                   "and write DIR/scan.obj, DIR/surface.npz, DIR/surface.ply and DIR/surface.png.")
    p.add_argument("-o", "--output-dir", default="trispline-demo", metavar="DIR",
                   help="folder for the results (created; default trispline-demo)")
    p.add_argument("--example-faces", type=_positive_int, default=EXAMPLE_FACES,
                   help=f"triangles of the built-in scan (default {EXAMPLE_FACES})")
    _add_fit_options(p)
    _add_common(p)
    p.set_defaults(func=cmd_demo, mesh=None, example=True)

    p = sub.add_parser("export", help="tessellate a surface file to OBJ/PLY/STL/GLB (or JSON/NPZ/PNG)",
                       description="Write the tessellated surface with analytic normals (watertight along patch "
                                   "boundaries), a surface file, a picture, and/or the control net.")
    p.add_argument("surface", metavar="SURFACE", help="surface file (.npz or .json)")
    p.add_argument("-o", "--output", metavar="OUT", help="output (.obj .ply .stl .glb .json .npz .png)")
    p.add_argument("--resolution", type=_positive_int, default=8, help="steps per patch edge (default 8)")
    p.add_argument("--control-net", metavar="FILE", help="write the control net (.obj .ply .stl .glb)")
    p.add_argument("--net-lines", action="store_true",
                   help="write the control net as line segments (OBJ 'l' records) instead of triangles")
    _add_common(p)
    p.set_defaults(func=cmd_export)

    p = sub.add_parser("check", help="continuity residuals and statistics of a surface file",
                       description="Algebraic C0/C1 residuals across every interior edge, sampled value and "
                                   "gradient jumps, patch count, bounds, stored fit energies. Exit 3 if a "
                                   "relative residual exceeds the tolerance.")
    p.add_argument("surface", metavar="SURFACE", help="surface file (.npz or .json)")
    p.add_argument("--tolerance", type=_nonneg_float, default=CHECK_TOLERANCE,
                   help=f"largest accepted relative residual (default {CHECK_TOLERANCE:g})")
    p.add_argument("--samples", type=_positive_int, default=7, help="samples per edge for the jumps (default 7)")
    _add_common(p)
    p.set_defaults(func=cmd_check)

    p = sub.add_parser("info", help="topology report of a mesh and whether fit accepts it",
                       description="Vertices, faces, boundary loops, holes, components, manifoldness, degenerate "
                                   "faces, and what fit would reject and why. Exit 3 if fit would reject it.")
    p.add_argument("mesh", metavar="MESH", help="input mesh (.obj .off .ply .stl .glb .gltf)")
    p.add_argument("--keep-largest", action="store_true", help="judge as fit --keep-largest would")
    _add_common(p)
    p.set_defaults(func=cmd_info)

    # `trispline render` lives in its own module (trispline.fit.cli.render), which builds on
    # this module's helpers; it is optional, so a checkout without it still works
    try:
        from . import render as render_cli
    except ModuleNotFoundError as exc:
        if exc.name != f"{__package__}.render_cli":
            raise
    else:
        render_cli.add_parser(sub)
    return parser


def _version() -> str:
    try:
        from importlib.metadata import version

        return version("trispline")
    except Exception:  # noqa: BLE001 - not installed (source checkout)
        return "unknown"


# ============================================================================ helpers
def _check_output(path: str | None, formats: tuple[str, ...], what: str) -> Path | None:
    """Validate an output path before any work: known suffix, existing folder."""
    if path is None:
        return None
    from ..io.export import check_export_path
    from trispline.spline.util.atomic import OutputError

    check_export_path(path, formats)
    p = Path(path)
    folder = p.parent
    if not folder.is_dir():
        raise OutputError(f"cannot write {what} {p}: folder {folder} does not exist")
    if p.is_dir():
        raise OutputError(f"cannot write {what} {p}: it is a folder")
    if not os.access(folder, os.W_OK):
        raise OutputError(f"cannot write {what} {p}: folder {folder} is not writable")
    return p


def _distinct(paths: Sequence[Path | None]) -> None:
    seen: dict[Path, Path] = {}
    for p in paths:
        if p is None:
            continue
        key = p.resolve()
        if key in seen:
            raise UsageError(f"{p} is named as two different outputs")
        seen[key] = p


def _enable_x64() -> None:
    import jax

    jax.config.update("jax_enable_x64", True)


def _load_surface(path: str):
    from trispline.spline.surface import SplineSurface

    return SplineSurface.load(path)


# ============================================================================ fit
def _fit(args: argparse.Namespace, ui: _UI, outputs: dict[str, Path | None],
         extra_writes: Callable[[Any, Any], None] | None = None) -> dict:
    """Shared body of ``fit`` and ``demo``: load, validate, fit, write everything atomically."""
    from trispline.param import parameterize, validate_mesh

    from trispline.spline.util.atomic import AtomicOutputs
    from ..io.export import export_control_net, export_surface

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
    # validate before JAX starts: invalid meshes fail in a fraction of a second
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

    with ui.stages(("start JAX",) + FIT_STAGES, "fit") as bar:
        _enable_x64()
        from ..pipeline import FitError, FitWeights, fit_surface

        bar.done()
        given = {name: getattr(args, f"w_{name}") for name, _ in WEIGHT_FIELDS
                 if getattr(args, f"w_{name}", None) is not None}
        weights = FitWeights(**given)
        t0 = time.perf_counter()
        try:
            result = fit_surface(V, F, uv=uv, param=args.param, weights=weights, max_steps=args.max_steps,
                                 progress=lambda stage, _seconds: bar.done(stage))
        except FitError as exc:
            raise CommandFailed(f"{exc} (try a larger --max-steps or other weights)") from exc
        fit_seconds = time.perf_counter() - t0

    surface = _with_fit_extras(result, weights, args.param, source, kept)
    with ui.stages(("write",), "write"), AtomicOutputs() as out:
        surface.save(out.path(outputs["surface"]))
        if outputs.get("mesh") is not None:
            export_surface(surface, outputs["mesh"], resolution=args.resolution, outputs=out)
        if outputs.get("image") is not None:
            export_surface(surface, outputs["image"], resolution=min(args.resolution, 6), outputs=out)
        if outputs.get("control_net") is not None:
            export_control_net(surface, outputs["control_net"], outputs=out)
        if extra_writes is not None:
            extra_writes(out, (V, F))
        written = out.targets
    return dict(
        command=args.command, input=source, outputs=[str(p) for p in written],
        vertices=int(V.shape[0]), faces=int(F.shape[0]), patches=int(surface.n_faces),
        param=args.param,
        parameterization_repaired=getattr(result.parameterization, "repaired", None),
        weights=dataclasses.asdict(weights), energies=result.energies, iterations=int(result.iterations),
        converged=bool(result.converged), c1_residual=float(result.c1_residual),
        max_interpolation_error=float(result.max_interpolation_error),
        timings=dict(result.timings), seconds=fit_seconds,
        source_vertex_index=None if kept is None else "stored in the surface file",
    )


def _with_fit_extras(result, weights, param: str, source: str, kept: np.ndarray | None):
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
    e = ", ".join(f"{k} {_fmt(v)}" for k, v in d["energies"].items())
    return "\n".join([
        f"fitted {d['input']}: {d['vertices']} vertices, {d['patches']} quintic patches "
        f"(param {d['param']}{', repaired by ' + d['parameterization_repaired'] if d['parameterization_repaired'] else ''})",
        f"  energies: {e}",
        f"  Gauss-Newton steps {d['iterations']}, C1 residual {_fmt(d['c1_residual'])} (relative), "
        f"max interpolation error {_fmt(d['max_interpolation_error'])}, {d['seconds']:.1f} s",
        *(f"  wrote {p}" for p in d["outputs"]),
    ])


def cmd_fit(args: argparse.Namespace, ui: _UI) -> int:
    from ..io.export import IMAGE_FORMATS, MESH_FORMATS, SURFACE_FORMATS

    if args.example and args.mesh:
        raise UsageError("give either MESH or --example, not both")
    if not args.example and not args.mesh:
        raise UsageError("the following arguments are required: MESH (or --example)")
    outputs = dict(
        surface=_check_output(args.output, SURFACE_FORMATS, "the surface"),
        mesh=_check_output(args.mesh_out, MESH_FORMATS, "--mesh-out"),
        image=_check_output(args.image, IMAGE_FORMATS, "--image"),
        control_net=_check_output(args.control_net, MESH_FORMATS, "--control-net"),
    )
    _distinct(list(outputs.values()))
    data = _fit(args, ui, outputs)
    ui.result(data, _fit_text)
    return EXIT_OK


def cmd_demo(args: argparse.Namespace, ui: _UI) -> int:
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


# ============================================================================ export
def cmd_export(args: argparse.Namespace, ui: _UI) -> int:
    from trispline.spline.util.atomic import AtomicOutputs
    from ..io.export import EXPORT_FORMATS, MESH_FORMATS, export_control_net, export_surface

    if args.output is None and args.control_net is None:
        raise UsageError("nothing to write: give -o OUT and/or --control-net FILE")
    if args.net_lines and args.control_net is None:
        raise UsageError("--net-lines needs --control-net FILE")
    out_path = _check_output(args.output, EXPORT_FORMATS, "the output")
    net_path = _check_output(args.control_net, (".obj",) if args.net_lines else MESH_FORMATS, "--control-net")
    _distinct([out_path, net_path])
    surface = _load_surface(args.surface)
    names = (["tessellate and write"] if out_path else []) + (["control net"] if net_path else [])
    with ui.stages(names, "export") as bar, AtomicOutputs() as out:
        if out_path is not None:
            export_surface(surface, out_path, resolution=args.resolution, outputs=out)
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
    ui.result(data, lambda d: "\n".join(f"wrote {p}" for p in d["outputs"]))
    return EXIT_OK


# ============================================================================ check
def surface_report(surface, *, tolerance: float = CHECK_TOLERANCE, samples: int = 7) -> dict:
    """Continuity residuals and statistics of a surface (the body of ``check``)."""
    from trispline.spline.index import CORNER
    from trispline.spline.continuity import continuity_report

    tri = surface.triangulation
    ctrl = np.asarray(surface.ctrl)
    alg = continuity_report(tri, ctrl)
    num = surface.continuity(samples)
    num = {k: v for k, v in num.items() if not isinstance(v, np.ndarray)}
    pts = ctrl.reshape(-1, 3)
    corners = np.empty((tri.n_vertices, 3))
    corners[tri.faces.ravel()] = ctrl[:, CORNER].reshape(-1, 3)
    report: dict[str, Any] = dict(
        patches=tri.n_faces, vertices=tri.n_vertices, edges=tri.n_edges,
        interior_edges=int(tri.interior_edges.size), boundary_edges=int(tri.boundary_edges.size),
        boundary_loops=len(tri.boundary_loops), holes=tri.n_holes,
        bounds=dict(control_points=[pts.min(0), pts.max(0)], corner_points=[corners.min(0), corners.max(0)],
                    uv=[tri.uv.min(0), tri.uv.max(0)]),
        c1_algebraic=alg, c1_sampled=num,
    )
    ex = dict(surface.extras)
    if "fit_energy_names" in ex and "fit_energies" in ex:
        report["energies"] = dict(zip([str(s) for s in np.atleast_1d(ex["fit_energy_names"])],
                                      [float(v) for v in np.atleast_1d(ex["fit_energies"])]))
    if "fit_weight_names" in ex and "fit_weights" in ex:
        report["weights"] = dict(zip([str(s) for s in np.atleast_1d(ex["fit_weight_names"])],
                                     [float(v) for v in np.atleast_1d(ex["fit_weights"])]))
    for key in ("fit_param", "fit_source", "fit_iterations", "fit_converged"):
        if key in ex:
            v = np.asarray(ex[key])
            report[key[4:]] = v.item() if v.ndim == 0 else v.tolist()
    if "data_vertices" in ex:
        D = np.asarray(ex["data_vertices"], float)
        if D.shape == corners.shape:
            report["max_interpolation_error"] = float(np.abs(corners - D).max())
    worst = dict(c0_algebraic=alg["c0_relative"], c1_algebraic=alg["c1_relative"],
                 c0_sampled=num["c0_relative"], c1_sampled=num["c1_relative"])
    failed = sorted(k for k, v in worst.items() if not v <= tolerance)
    report.update(tolerance=tolerance, relative_residuals=worst, failed=failed, ok=not failed)
    return report


def _check_text(d: dict) -> str:
    b = d["bounds"]["control_points"]
    lines = [
        f"{d['file']}: {d['patches']} patches, {d['vertices']} vertices, {d['interior_edges']} interior / "
        f"{d['boundary_edges']} boundary edges, {d['boundary_loops']} boundary loops ({d['holes']} holes)",
        f"  bounds: min {np.round(b[0], 6).tolist()} max {np.round(b[1], 6).tolist()}",
        "  relative residuals: " + ", ".join(f"{k} {_fmt(v)}" for k, v in d["relative_residuals"].items()),
    ]
    if "energies" in d:
        lines.append("  stored energies: " + ", ".join(f"{k} {_fmt(v)}" for k, v in d["energies"].items()))
    if "max_interpolation_error" in d:
        lines.append(f"  max interpolation error: {_fmt(d['max_interpolation_error'])}")
    verdict = ("OK: C1 within tolerance" if d["ok"]
               else f"FAILED: {', '.join(d['failed'])} above tolerance")
    lines.append(f"  {verdict} {d['tolerance']:g}")
    return "\n".join(lines)


def cmd_check(args: argparse.Namespace, ui: _UI) -> int:
    surface = _load_surface(args.surface)
    with ui.stages(("residuals",), "check") as bar:
        report = surface_report(surface, tolerance=args.tolerance, samples=max(args.samples, 2))
        bar.done()
    data = dict(command="check", file=args.surface, **report)
    ui.result(data, _check_text)
    if not report["ok"]:
        print(f"{PROG}: check failed: {', '.join(report['failed'])} above the tolerance "
              f"{args.tolerance:g}", file=sys.stderr)
        return EXIT_CHECK
    return EXIT_OK


# ============================================================================ info
def mesh_report(V: np.ndarray, F: np.ndarray, *, keep_largest: bool = False) -> dict:
    """Topology report of a mesh and whether :func:`validate_mesh` accepts it (the body of ``info``)."""
    import scipy.sparse as sp
    from scipy.sparse.csgraph import connected_components

    from trispline.param import MeshError, face_areas_3d, validate_mesh
    from trispline.param.validate import MIN_RELATIVE_AREA_3D, _fan_counts

    V = np.asarray(V, np.float64)
    F = np.asarray(F, np.int64)
    nv, nf = V.shape[0], F.shape[0]
    finite = np.isfinite(V).all(1)
    rep: dict[str, Any] = dict(vertices=nv, faces=nf, non_finite_vertices=int((~finite).sum()))
    if finite.any():
        rep["bounds"] = [V[finite].min(0), V[finite].max(0)]
    repeated = (F[:, 0] == F[:, 1]) | (F[:, 1] == F[:, 2]) | (F[:, 0] == F[:, 2])
    area = face_areas_3d(V, F) if finite.all() else np.full(nf, np.nan)
    zero = area <= MIN_RELATIVE_AREA_3D * max(float(np.nanmean(area)) if nf else 0.0, np.finfo(float).tiny)
    rep["degenerate_faces"] = dict(repeated_vertex=int(repeated.sum()), zero_area=int((zero & ~repeated).sum()))
    # edges
    e = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    e = e[e[:, 0] != e[:, 1]]
    edges, count = np.unique(e, axis=0, return_counts=True)
    bnd = edges[count == 1]
    rep.update(edges=int(edges.shape[0]), boundary_edges=int(bnd.shape[0]),
               non_manifold_edges=int((count > 2).sum()))
    A = sp.coo_matrix((np.ones(edges.shape[0]), (edges[:, 0], edges[:, 1])), shape=(nv, nv))
    ncomp, lab = connected_components(A, directed=False)
    used = np.zeros(nv, bool)
    used[F.ravel()] = True
    rep["components"] = int(np.unique(lab[used]).size)
    rep["euler_characteristic"] = int(used.sum() - edges.shape[0] + nf)
    bow = 0
    if not repeated.any():
        he = np.stack([F[:, [1, 2, 0]], F[:, [2, 0, 1]]], axis=-1).reshape(-1, 2)
        key = np.minimum(he[:, 0], he[:, 1]) * nv + np.maximum(he[:, 0], he[:, 1])
        _, he_edge, cnt = np.unique(key, return_inverse=True, return_counts=True)
        bow = int((_fan_counts(F, he_edge.ravel(), cnt, nv) > 1).sum())
        rep["bowtie_vertices"] = bow
    manifold = rep["non_manifold_edges"] == 0 and bow == 0 and not repeated.any()
    rep["manifold"] = bool(manifold)
    if manifold:
        # boundary loops: cycles of the boundary-edge graph (each vertex on at most one loop)
        if bnd.size:
            B = sp.coo_matrix((np.ones(bnd.shape[0]), (bnd[:, 0], bnd[:, 1])), shape=(nv, nv))
            _, blab = connected_components(B, directed=False)
            loops = int(np.unique(blab[np.unique(bnd)]).size)
        else:
            loops = 0
        rep["boundary_loops"] = loops
        rep["closed"] = loops == 0
        if rep["components"] == 1:
            rep["holes"] = max(loops - 1, 0)
            rep["genus"] = (2 - rep["euler_characteristic"] - loops) / 2
    try:
        vm = validate_mesh(V, F, keep_largest=keep_largest)
    except MeshError as exc:
        rep["fit"] = dict(accepted=False, problems=list(exc.kinds), message=_one_line(str(exc)))
    else:
        rep.update({k: v for k, v in vm.report.items() if k in ("boundary_loops", "holes", "genus")})
        rep["fit"] = dict(accepted=True, problems=[], message="fit accepts this mesh", repairs=list(vm.messages))
    return rep


def _info_text(d: dict) -> str:
    deg = d["degenerate_faces"]
    lines = [
        f"{d['file']}: {d['vertices']} vertices, {d['faces']} faces, {d['edges']} edges"
        + (f" ({d['dropped_unreferenced_vertices']} unreferenced vertices dropped)"
           if d.get("dropped_unreferenced_vertices") else ""),
        f"  components {d['components']}, boundary edges {d['boundary_edges']}, "
        f"boundary loops {d.get('boundary_loops', '?')}, holes {d.get('holes', '?')}, "
        f"genus {d.get('genus', '?')}, Euler characteristic {d['euler_characteristic']}",
        f"  manifold {d['manifold']} (non-manifold edges {d['non_manifold_edges']}, "
        f"bowtie vertices {d.get('bowtie_vertices', '?')}), degenerate faces: {deg['zero_area']} zero-area, "
        f"{deg['repeated_vertex']} with a repeated vertex; non-finite vertices {d['non_finite_vertices']}",
        f"  texture coordinates (vt): {'yes' if d.get('has_uv') else 'no'}",
    ]
    f = d["fit"]
    if f["accepted"]:
        lines.append("  fit: accepted" + (f" ({'; '.join(f['repairs'])})" if f.get("repairs") else ""))
    else:
        lines.append(f"  fit: REJECTED [{', '.join(f['problems'])}]: {f['message']}")
    return "\n".join(lines)


def cmd_info(args: argparse.Namespace, ui: _UI) -> int:
    from ..io import read_mesh

    md = read_mesh(args.mesh)
    report = mesh_report(md.V, md.F, keep_largest=args.keep_largest)
    data = dict(command="info", file=args.mesh, format=Path(args.mesh).suffix.lower()[1:],
                dropped_unreferenced_vertices=md.dropped, has_uv=md.uv is not None, **report)
    ui.result(data, _info_text)
    return EXIT_OK if report["fit"]["accepted"] else EXIT_CHECK


# ============================================================================ main
def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit code (see the module docstring)."""
    return run_cli(build_parser, argv)


def run_cli(make_parser: Callable[[], argparse.ArgumentParser], argv: Sequence[str] | None = None) -> int:
    """Parse ``argv`` with ``make_parser()`` and run the chosen command with the CLI's
    error handling: one-line messages, exit 2 for bad input, 1 for internal failures."""
    argv = list(sys.argv[1:] if argv is None else argv)
    debug = "--debug" in argv
    ui = _UI(argparse.Namespace())
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("always", UserWarning)
            shown = warnings.showwarning

            def show(message, category, filename, lineno, file=None, line=None):
                if issubclass(category, UserWarning):
                    ui.warn(str(message))
                else:  # pragma: no cover - third-party warnings keep their usual form
                    shown(message, category, filename, lineno, file, line)

            warnings.showwarning = show
            try:
                args = make_parser().parse_args(argv)
                ui.json, ui.quiet = bool(getattr(args, "json", False)), bool(getattr(args, "quiet", False))
                return int(args.func(args, ui))
            finally:
                warnings.showwarning = shown
    except SystemExit as exc:  # --help, --version
        return int(exc.code or 0) if not isinstance(exc.code, str) else EXIT_INPUT
    except InputError as exc:
        if debug:
            traceback.print_exc()
        print(f"{PROG}: error: {_one_line(str(exc))}", file=sys.stderr)
        return EXIT_INPUT
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted", file=sys.stderr)
        return 130
    except CommandFailed as exc:
        if debug:
            traceback.print_exc()
        print(f"{PROG}: error: {_one_line(str(exc))}", file=sys.stderr)
        return EXIT_FAILURE
    except Exception as exc:  # noqa: BLE001 - the CLI's last line of defence
        if debug:
            traceback.print_exc()
        hint = "" if debug else " (run with --debug for the traceback)"
        print(f"{PROG}: internal error: {type(exc).__name__}: {_one_line(str(exc))}{hint}", file=sys.stderr)
        return EXIT_FAILURE


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
