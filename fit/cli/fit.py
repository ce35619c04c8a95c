"""``trispline fit`` and ``trispline demo``: load (or generate) a mesh, validate, fit, write atomically.

    trispline fit MESH -o SURFACE.npz [--param lscm|spectral|harmonic|slim|uv|auto] [--repair | --keep-largest]
                  [--bend W ...] [--mesh-out FILE [--resolution N]] [--image PNG] [--control-net FILE]
    trispline fit --example -o SURFACE.npz                # the built-in synthetic scan
    trispline demo [-o DIR]                               # the example, with every output in DIR

Every option is checked before any work (absurd sizes are refused with the memory they would
need), and the mesh is validated and parameterized before JAX starts, so an unusable mesh
fails in a fraction of a second; JAX is imported (and switched to float64) only here.

One thing happens here rather than in :func:`~trispline.fit.pipeline.fit_surface`: the
parameterization (to report its choice, distortion and warnings, and to put the domain back
into the user's coordinates with :func:`trispline.param.user_domain` for ``--param uv``).
Data far from the origin get their net computed about the data's centre by the pipeline
itself. Energies are reported in data units and normalised
(:func:`trispline.fit.energy.normalised_energies`: the data scaled to a unit bounding-box
diagonal, per unit area of the domain), which compare across meshes.
"""
from __future__ import annotations

import argparse
import dataclasses
import time
from pathlib import Path
from typing import Any, Callable

import numpy as np

from trispline.param import DEFAULT_METHOD, METHODS, refuse_slivers
from trispline.spline.tolerances import FAR_PRECISION

from ..errors import FitError, ResultRejected, UsageError
from ..stages import FIT_STAGES
from ..weights import MAX_BLEND_POWER, FitWeights
from . import approximate
from .common import (
    EXIT_OK, UI, add_common, check_output, distinct, fmt, int_at_least, nonneg_float, positive_int, prefetch,
)

__all__ = ["WEIGHT_FIELDS", "WEIGHT_HELP", "FIT_STAGES", "EXAMPLE_FACES", "MAX_FIT_RINGS", "MAX_BLEND_POWER",
           "add_parsers", "cmd_fit", "cmd_demo"]

#: What the fit imports for its solve, imported beside the mesh's reading and mapping (:func:`prefetch`:
#: the CLI row of benchmarks/bench_fit_speed.py waited ~1.7 s for them on one core).
FIT_MODULES = ("jax", "jax.numpy", "optimistix")
#: Default faces of the built-in example scan.
EXAMPLE_FACES = 800


def example_faces(text: str) -> int:
    """argparse type of ``--example-faces``: at least the built-in scan's
    :data:`~trispline.fit.datasets.synthetic.MIN_FACES` (imported only when the option is given)."""
    from ..datasets.synthetic import MIN_FACES

    return int_at_least(MIN_FACES)(text)
#: One flag per :class:`~trispline.fit.weights.FitWeights` field: ``(name, type of its default)``
#: (``trispline.fit.weights`` imports no JAX, so the parser stays fast).
WEIGHT_FIELDS: tuple[tuple[str, type], ...] = tuple(
    (f.name, type(f.default)) for f in dataclasses.fields(FitWeights))
#: ``--fit-rings`` above this is refused: the local fits' neighbourhoods grow with its square
#: (1000 rings on a 9k-face mesh ran for minutes), and beyond a few rings they stop being local.
MAX_FIT_RINGS = 6
#: The meaning of each weight flag, as ``--help`` says it (docs/fit.md has the details).
WEIGHT_HELP = {
    "bend": "thin-plate bending over the domain: smooths the surface between the vertices",
    "tilt": "pulls each vertex's tangent frame toward its local fit's (stops bumps beside vertices)",
    "local": "pulls the other control points toward the blended local fits (accuracy on dense, smooth data)",
    "data": "weight of extra sample points (API data_points; the approximation's data term)",
    "angle": "nonlinear: frame normals toward the data normals (several Gauss-Newton steps; slower)",
    "fit_degree": "highest polynomial degree of the local fits: 2, or 3 (also the r^7 kernel)",
    "fit_rings": f"edge rings of neighbours each local fit uses, 1..{MAX_FIT_RINGS}",
    "blend_power": f"exponent of the corner blend of the local targets, 0..{MAX_BLEND_POWER:g}",
}


# ============================================================================ parser
def add_parsers(sub: Any) -> None:
    """Register ``fit`` and ``demo`` on an ``add_subparsers()`` action."""
    p = sub.add_parser("fit", help="fit a C1 spline surface to an open mesh",
                       description="Interpolate the mesh vertices with an exactly C1 quintic spline and fair it. "
                                   "Vertex i of the mesh is vertex i of the surface (its corner point; with --repair "
                                   "or --keep-largest the file's source_vertex_index says which). The summary "
                                   "reports each energy term normalised: for the data scaled to a unit "
                                   "bounding-box diagonal, per unit area of the domain, so that the numbers "
                                   "compare across meshes (--json: energies_normalised, and energies in data "
                                   "units).")
    p.add_argument("mesh", nargs="?", metavar="MESH", help="input mesh (.obj .off .ply .stl .glb .gltf)")
    p.add_argument("--example", action="store_true", help="fit the built-in synthetic scan instead of MESH")
    p.add_argument("--example-faces", type=example_faces, default=EXAMPLE_FACES, metavar="N",
                   help=f"triangles of the built-in scan, with --example (default {EXAMPLE_FACES})")
    p.add_argument("-o", "--output", required=True, metavar="SURFACE", help="surface file to write (.npz or .json; required)")
    _add_fit_options(p)
    approximate.add_options(p)
    add_common(p)
    p.set_defaults(func=cmd_fit)

    p = sub.add_parser("demo", help="fit the built-in example scan; write mesh, surface, tessellation and picture",
                       description="Generate the built-in synthetic scan (open, bumpy, noisy, with a hole), fit it "
                                   "and write DIR/scan.obj, DIR/surface.npz, DIR/surface.ply and DIR/surface.png.")
    p.add_argument("-o", "--output-dir", default="trispline-demo", metavar="DIR",
                   help="folder for the results (created; its scan.obj and surface.* are replaced, other files kept; "
                        "default trispline-demo)")
    p.add_argument("--example-faces", type=example_faces, default=EXAMPLE_FACES, metavar="N",
                   help=f"triangles of the built-in scan (default {EXAMPLE_FACES})")
    _add_fit_options(p, outputs=False)
    add_common(p)
    p.set_defaults(func=cmd_demo, mesh=None, example=True, mesh_out=None, image=None, control_net=None)


def _add_fit_options(p: argparse.ArgumentParser, outputs: bool = True) -> None:
    """The fit's options; ``outputs``: also --mesh-out / --image / --control-net (fit, not demo)."""
    p.add_argument("--param", choices=METHODS, default=DEFAULT_METHOD,
                   help=f"parameterization (default {DEFAULT_METHOD}): spectral (conformal, free boundary, no pinned "
                        "vertices: the same map whatever the file's face order), lscm (conformal, free boundary, two "
                        "vertices pinned), harmonic "
                        "(boundary on a circle), slim (conformal and fold-free by construction; slower), uv (the "
                        "OBJ's texture coordinates, or x, y of a height field; the surface file's uv is then "
                        "exactly yours), auto (spectral unless it folds or is strongly distorted, else the "
                        "least distorted of spectral/harmonic/slim; says which and why)")
    p.add_argument("--keep-largest", action="store_true",
                   help="fit the largest connected component instead of rejecting several components "
                        "(vertices are renumbered; the surface file records the input index; default: off)")
    p.add_argument("--repair", action="store_true",
                   help="repair the mesh first: split bowtie vertices, cut non-manifold edges, drop zero-area and "
                        "duplicate faces, peel hull slivers off the outline (scattered points triangulated), cut folded "
                        "flaps, keep the largest component; says what changed, and the surface file's "
                        "source_vertex_index maps its vertices to the input's (default: off)")
    p.add_argument("--max-steps", type=positive_int, default=50, metavar="N",
                   help="Gauss-Newton step limit; the default quadratic energy needs 1 (default 50)")
    p.add_argument("--resolution", type=positive_int, default=None, metavar="N",
                   help="steps per patch edge of " + ("--mesh-out (N^2 triangles per patch) and of --image (at most "
                                                      "6)" if outputs else "surface.ply and surface.png")
                        + "; default: automatic from the patch count (mesh: about 1.5M triangles, at most 8; "
                          "picture: the renderer's own); a size beyond the available memory is refused up front")
    if outputs:
        p.add_argument("--mesh-out", metavar="FILE",
                       help="also write the tessellated surface (.obj .ply .stl .glb .off; default: none), with a "
                            "warning when it will be large")
        p.add_argument("--image", metavar="PNG",
                       help="also render a shaded picture of the surface, as 'trispline render' draws it (.png; "
                            "default: none)")
        p.add_argument("--control-net", metavar="FILE",
                       help="also write the control net as a mesh (.obj .ply .stl .glb .off; default: none)")
    defaults = FitWeights()
    g = p.add_argument_group("fairness weights (FitWeights; no unit: only their ratios matter, the terms are "
                             "scaled alike for any mesh size; details in docs/fit.md)")
    for name, kind in WEIGHT_FIELDS:
        conv = _WEIGHT_TYPES.get(name, positive_int if kind is int else nonneg_float)
        g.add_argument(f"--{name.replace('_', '-')}", dest=f"w_{name}", type=conv, default=None,
                       metavar="N" if kind is int else "W",
                       help=f"{WEIGHT_HELP.get(name, 'FitWeights.' + name)} (default {getattr(defaults, name):g})")


def _bounded(kind: type, low: float, high: float, low_open: bool = False) -> Callable[[str], Any]:
    """argparse type: a ``kind`` number in ``[low, high]`` (``(low, high]`` with ``low_open``)."""

    def convert(text: str) -> Any:
        try:
            v = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {'an integer' if kind is int else 'a number'}, "
                                             f"got {text!r}") from None
        ok = np.isfinite(v) and (v > low if low_open else v >= low) and v <= high
        if not ok:
            raise argparse.ArgumentTypeError(f"expected {'more than' if low_open else 'at least'} {low:g} and "
                                             f"at most {high:g}, got {text}")
        return v

    convert.__name__ = kind.__name__
    return convert


#: Flag types of the weights that are not plain non-negative numbers.
_WEIGHT_TYPES: dict[str, Callable[[str], Any]] = {
    "fit_degree": _bounded(int, 2, 3), "fit_rings": _bounded(int, 1, MAX_FIT_RINGS),
    "blend_power": _bounded(float, 0, MAX_BLEND_POWER),
}


# ============================================================================ commands
def cmd_fit(args: argparse.Namespace, ui: UI) -> int:
    """Body of ``trispline fit``."""
    from ..io.export import IMAGE_FORMATS, MESH_FORMATS, SURFACE_FORMATS

    if args.example and args.mesh:
        raise UsageError("give either MESH or --example, not both")
    if not args.example and not args.mesh:
        raise UsageError("the following arguments are required: MESH (or --example)")
    inputs = [args.mesh]
    outputs = dict(
        surface=check_output(args.output, SURFACE_FORMATS, "the surface", inputs),
        mesh=check_output(args.mesh_out, MESH_FORMATS, "--mesh-out", inputs),
        image=check_output(args.image, IMAGE_FORMATS, "--image", inputs),
        control_net=check_output(args.control_net, MESH_FORMATS, "--control-net", inputs),
    )
    distinct(list(outputs.values()))
    prefetch(*FIT_MODULES)
    if approximate.requested(args):  # --tolerance / --tolerance-rel / --vertices: fit/cli/approximate.py
        return approximate.run(args, ui, outputs, load=_load_input, write=_write, extras=_with_fit_extras,
                               fields=WEIGHT_FIELDS)
    data = _fit(args, ui, outputs)
    ui.result(data, _fit_text)
    return EXIT_OK


def cmd_demo(args: argparse.Namespace, ui: UI) -> int:
    """Body of ``trispline demo``: ``fit --example`` with every output in one folder (a folder it
    creates is removed again when the command fails before writing into it)."""
    from ..io.export import export_mesh

    folder = Path(args.output_dir)
    if folder.exists() and not folder.is_dir():
        raise UsageError(f"{folder} exists and is not a folder")
    created = not folder.exists()
    if not created:
        check_output(str(folder / "surface.npz"), (".npz",), "the demo's surface")
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UsageError(f"cannot create {folder}: {exc.strerror or exc}") from None
    outputs = dict(surface=folder / "surface.npz", mesh=folder / "surface.ply", image=folder / "surface.png",
                   control_net=None)

    def write_scan(out, VF) -> None:
        export_mesh(VF[0], VF[1], folder / "scan.obj", outputs=out)

    prefetch(*FIT_MODULES)
    try:
        data = _fit(args, ui, outputs, write_scan)
    except BaseException:
        if created and folder.is_dir() and not any(folder.iterdir()):
            folder.rmdir()
        raise
    data["output_dir"] = str(folder)
    ui.result(data, lambda d: _fit_text(d) + f"\n  view {folder / 'surface.png'}; "
                                            f"next: trispline check {folder / 'surface.npz'}")
    return EXIT_OK


# ============================================================================ the fit
@dataclasses.dataclass
class _Input:
    """The mesh to fit, after loading, repair and validation."""

    V: np.ndarray  # (nv, 3)
    F: np.ndarray  # (nf, 3)
    uv: np.ndarray | None  # (nv, 2) domain for the approximation: the file's vt, with --param uv only
    source: str  # the file name, or a description of the built-in scan
    kept: np.ndarray | None  # (nv,) index in the file of each vertex, when vertices were dropped or split
    parameterization: Any = None  # the Parameterization of the file's vt (--param uv), else made by _parameterize
    repair: dict | None = None  # --repair: changes and messages
    validated: Any = None  # validate_mesh's ValidatedMesh of V, F (the parameterization does not check again)


def _weights(args: argparse.Namespace) -> FitWeights:
    """The FitWeights of the weight flags (checked before any work)."""
    given = {name: getattr(args, f"w_{name}") for name, _ in WEIGHT_FIELDS
             if getattr(args, f"w_{name}", None) is not None}
    return FitWeights(**given)


def _fit(args: argparse.Namespace, ui: UI, outputs: dict[str, Path | None],
         extra_writes: Callable[[Any, Any], None] | None = None) -> dict:
    """Shared body of ``fit`` and ``demo``: load, validate, parameterize, fit, write everything atomically."""
    weights = _weights(args)
    mesh = _load_input(args, ui)
    _warn_far_from_origin(ui, mesh.V)
    _check_output_sizes(args, mesh, outputs)
    from ..limits import check_fit_memory

    check_fit_memory(mesh.F.shape[0])  # before the parameterization (minutes at 1M faces)
    p, param_seconds = _parameterize(args, ui, mesh)
    result, fit_seconds = _solve(args, ui, mesh, p, weights)
    _warn_overshoot(ui, result.stats["reach"])
    surface = _with_fit_extras(result, weights, args.param, mesh.source, mesh.kept, parameterization=p,
                               data=mesh.V)
    written = _write(args, ui, surface, outputs, extra_writes, (mesh.V, mesh.F))
    ex = surface.extras
    return dict(
        command=args.command, input=mesh.source, outputs=[str(p) for p in written],
        vertices=int(mesh.V.shape[0]), faces=int(mesh.F.shape[0]), patches=int(surface.n_faces),
        param=args.param, param_chosen=p.method, param_reason=p.reason, distortion=p.distortion,
        parameterization_repaired=p.repaired, repair=mesh.repair,
        weights=dataclasses.asdict(weights), energies=result.energies,
        energies_normalised=dict(zip(ex["fit_energy_names"].tolist(), ex["fit_energies_normalised"].tolist())),
        iterations=int(result.iterations), converged=bool(result.converged), c1_residual=float(result.c1_residual),
        max_interpolation_error=float(result.max_interpolation_error), reach=float(result.stats["reach"]),
        timings={**dict(result.timings), "parameterize": param_seconds}, seconds=fit_seconds + param_seconds,
        source_vertex_index=None if mesh.kept is None else "stored in the surface file",
        **_export_sizes(args, surface, outputs),
    )


def _warn_overshoot(ui: UI, reach: float) -> None:
    """A warning where the surface reaches farther than ``pipeline.OVERSHOOT`` outside the scan's box."""
    from ..pipeline import OVERSHOOT

    if reach > OVERSHOOT:
        ui.warn(f"the surface overshoots the scan's box by {reach:.2g} bounding-box diagonals between its vertices: "
                f"an interpolant through a spike, a step or a sliver of coarse data swings past it (check the data there; "
                f"--tolerance-rel approximates the scan instead of passing through every vertex)")


def _load_input(args: argparse.Namespace, ui: UI) -> _Input:
    """Read (or generate) the mesh, repair it (``--repair``) and validate it, before JAX starts."""
    from trispline.param import parameterize, validate_mesh

    kept: np.ndarray | None = None
    file_uv = None
    if args.example:
        from ..datasets.synthetic import synthetic_scan
        from ..limits import APPROXIMATE_INSTEAD, check_fit_memory

        if not approximate.requested(args):  # before generating it (10M faces: minutes); the demo cannot approximate
            check_fit_memory(args.example_faces, advice="ask for fewer --example-faces" if args.func is cmd_demo
                             else APPROXIMATE_INSTEAD)
        V, F = synthetic_scan(args.example_faces)
        source = f"built-in example scan ({args.example_faces} faces requested)"
    else:
        from ..io import read_mesh

        with ui.stages(("read",), "load"):  # the elapsed time ticks (a 1M-face OBJ: ~4 s)
            md = read_mesh(args.mesh)
        V, F, file_uv = md.V, md.F, md.uv
        source = str(args.mesh)
        if args.param == "uv" and md.uv_note:  # not (x, y) in their place without a word
            from trispline.param import MeshError

            raise MeshError(f"{source}: --param uv cannot use the file's texture coordinates: {md.uv_note} "
                            "(without vt lines, --param uv maps (x, y) as a height field)", ["uv"])
        if md.dropped:
            kept = md.kept
    repair = None
    if getattr(args, "repair", False):
        V, F, kept, file_uv, repair = _repair(ui, V, F, kept, file_uv, source)
    with ui.stages(("check",), "load"):  # its messages after the bar (1M faces: ~3 s)
        vm = validate_mesh(V, F, keep_largest=args.keep_largest, vertex_ids=kept)  # messages: the file's numbers
    for m in vm.messages:
        ui.warn(m)
    # an approximating fit need not pass the folds
    if repair is None and not approximate.requested(args):
        _warn_folds(ui, vm.V, vm.F)
    if repair is None:
        _warn_hull(ui, vm.V, vm.F)
    if vm.kept is not None:
        V, F = vm.V, vm.F
        kept = vm.kept if kept is None else kept[vm.kept]
        file_uv = None if file_uv is None else file_uv[vm.kept]
        ui.warn(f"vertices were renumbered (the surface's source_vertex_index maps them to {source})")
    uv, p = None, None
    if args.param == "uv" and file_uv is not None:
        p = parameterize(V, F, method="uv", uv=file_uv, validated=vm)
        uv, F = p.uv, p.faces
        _announce(ui, p)
    return _Input(V=V, F=F, uv=uv, source=source, kept=kept, parameterization=p, repair=repair, validated=vm)


def _repair(ui: UI, V: np.ndarray, F: np.ndarray, kept: np.ndarray | None, file_uv: np.ndarray | None,
            source: str) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, np.ndarray | None, dict]:
    """``--repair``: :func:`trispline.param.repair_mesh`, saying what changed; the vertex map composed."""
    from trispline.param import repair_mesh

    r = repair_mesh(V, F, keep_largest=True)
    for m in r.messages:
        ui.warn(f"repair: {m}")
    if not r.changed:
        return V, F, kept, file_uv, dict(changes=r.changes, messages=["nothing to repair"])
    src = r.source_vertex_index
    kept = src if kept is None else np.asarray(kept)[src]
    ui.warn(f"vertices were renumbered by the repair (the surface's source_vertex_index maps them to {source})")
    return r.V, r.F, kept, None if file_uv is None else file_uv[src], dict(changes=r.changes, messages=r.messages)


def _announce(ui: UI, p: Any) -> None:
    """The parameterization's messages and its distortion warning (auto's choice and reason are in the summary)."""
    for m in p.messages:
        if m != p.reason:
            ui.warn(m)
    if p.warning:
        ui.warn(p.warning)


def _parameterize(args: argparse.Namespace, ui: UI, mesh: _Input) -> tuple[Any, float]:
    """``(Parameterization, seconds)``: the one of ``--param uv`` made when loading, else ``--param``'s map."""
    if mesh.parameterization is not None:
        refuse_slivers(mesh.parameterization.uv, mesh.parameterization.faces, V=mesh.V, method="uv")
        return mesh.parameterization, 0.0
    from trispline.param import parameterize

    t0 = time.perf_counter()
    with ui.stages((args.param,), "parameterize") as bar:
        p = parameterize(mesh.V, mesh.F, method=args.param, report=lambda fraction: bar.at(args.param, fraction),
                         validated=mesh.validated)
    refuse_slivers(p.uv, p.faces, V=mesh.V, method=p.method)  # before the map's warnings: one thing said
    _announce(ui, p)
    return p, time.perf_counter() - t0


def _warn_folds(ui: UI, V: np.ndarray, F: np.ndarray) -> None:
    """One line before the work when the scan folds over (an interpolating surface spikes there)."""
    from trispline.param.inspect import fold_report

    folds = fold_report(V, F)
    if folds["folded_edges"] and folds["flaps"]:
        ui.warn(f"the mesh folds over at {folds['folded_edges']} edges (adjacent faces up to "
                f"{folds['worst_fold_degrees']:.0f} degrees apart): the surface may spike there; use --repair "
                "to cut folded flaps")
    elif folds["folded_edges"]:  # sharp creases: cutting faces off them would change the data
        ui.warn(f"the mesh has {folds['folded_edges']} creases sharper than a right angle (adjacent faces up to "
                f"{folds['worst_fold_degrees']:.0f} degrees apart): an interpolating surface overshoots there; "
                "an approximation (--tolerance-rel) rounds them")


def _warn_hull(ui: UI, V: np.ndarray, F: np.ndarray) -> None:
    """One line before the work when the outline is closed off by hull slivers (scattered points triangulated)."""
    from trispline.param.inspect import hull_report

    hull = hull_report(V, F)
    if hull["hull_slivers"]:
        ui.warn(f"the outline runs along {hull['hull_slivers']} hull slivers (long thin faces; its longest edge is "
                f"{hull['longest_outline_edge']:.0f} times the median edge), as a triangulation of scattered points "
                "makes along their convex hull: the map distorts there and an approximation cannot place vertices "
                "along those edges; use --repair to peel them off")


def _warn_far_from_origin(ui: UI, V: np.ndarray) -> None:
    """Warn when ``V (nv, 3)`` lies so far from the origin that float64 keeps few digits of its extent."""
    extent = float(np.ptp(V, axis=0).max()) if V.size else 0.0
    far = float(np.abs(V).max()) if V.size else 0.0
    if extent > 0 and np.finfo(float).eps * far / extent > FAR_PRECISION:
        ui.warn(f"the mesh lies {far:.3g} from the origin with an extent of {extent:.3g}: its coordinates keep "
                f"about {np.finfo(float).eps * far / extent:.1g} of the extent, so the surface file is C1 only to "
                "about 100 times that (trispline check allows for it); subtract an offset for more digits")


def _check_output_sizes(args: argparse.Namespace, mesh: _Input, outputs: dict[str, Path | None]) -> None:
    """Refuse (exit 2), before the fit, a --mesh-out tessellation that cannot fit in memory, and a mesh output whose
    format cannot hold the data's coordinates (STL, GLB: 32-bit floats)."""
    from ..io.formats import check_coordinate_range

    for key in ("mesh", "control_net"):
        if outputs.get(key) is not None:
            check_coordinate_range(outputs[key], mesh.V)
    if outputs.get("mesh") is None:
        return
    from trispline.spline.tessellate import require_tessellation_memory

    from ..io.sizes import export_resolution, require_export_memory

    F = np.sort(mesh.F, axis=1)
    edges = np.unique(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [0, 2]]]), axis=0).shape[0]
    nf = F.shape[0]
    r = export_resolution(nf) if args.resolution is None else args.resolution
    require_tessellation_memory(mesh.V.shape[0], edges, nf, r)
    require_export_memory(mesh.V.shape[0], edges, nf, r, outputs["mesh"])


def _export_sizes(args: argparse.Namespace, surface: Any, outputs: dict[str, Path | None]) -> dict[str, Any]:
    """``mesh_resolution`` and ``estimated_bytes`` of the mesh output, when there is one."""
    from ..io.sizes import estimate_export_bytes, export_resolution

    if outputs.get("mesh") is None:
        return {}
    r = export_resolution(surface.n_faces) if args.resolution is None else args.resolution
    return dict(mesh_resolution=r, estimated_bytes=estimate_export_bytes(surface, outputs["mesh"], r))


def _solve(args: argparse.Namespace, ui: UI, mesh: _Input, p: Any, weights: FitWeights) -> tuple[Any, float]:
    """``(FitResult, seconds)``: JAX in float64, then ``fit_surface`` on ``p``'s domain with a progress bar."""
    with ui.stages(("start JAX",) + FIT_STAGES, "fit") as bar:
        import jax

        jax.config.update("jax_enable_x64", True)
        from ..pipeline import fit_surface

        bar.done()
        t0 = time.perf_counter()
        try:
            result = fit_surface(mesh.V, p.faces, param=p, weights=weights, max_steps=args.max_steps,
                                 progress=_progress(bar))
        except FitError as exc:
            raise ResultRejected(f"the fit did not converge in {exc.steps} Gauss-Newton steps (--max-steps "
                                 f"{args.max_steps}); nothing written: raise --max-steps, or lower --angle") from exc
        seconds = time.perf_counter() - t0
    return result, seconds


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
    """Write the surface and the requested extras, all or nothing; returns the files written.

    The mesh gets ``--resolution`` (None: :func:`~trispline.fit.io.sizes.export_resolution`, with
    the size warning of :func:`~trispline.fit.io.export.export_surface`); the picture is drawn by
    the one renderer (as ``trispline render`` would, shaded, dated caption) at ``min(--resolution, 6)``.
    """
    from trispline.spline.util.atomic import AtomicOutputs

    from ..io.export import export_control_net, export_surface
    from ..render.caption import caption_text

    with ui.stages(("write",), "write"), AtomicOutputs() as out:
        surface.save(out.path(outputs["surface"]))
        if outputs.get("mesh") is not None:
            export_surface(surface, outputs["mesh"], resolution=args.resolution, outputs=out)
        if outputs.get("image") is not None:
            r = None if args.resolution is None else min(args.resolution, 6)
            export_surface(surface, outputs["image"], resolution=r, outputs=out,
                           caption=caption_text(getattr(args, "mesh", None)))
        if outputs.get("control_net") is not None:
            export_control_net(surface, outputs["control_net"], outputs=out)
        if extra_writes is not None:
            extra_writes(out, VF)
        return out.targets


def _with_fit_extras(result: Any, weights: Any, param: str, source: str, kept: np.ndarray | None, *,
                     parameterization: Any = None, data: np.ndarray | None = None) -> Any:
    """The fitted surface with the fit's settings and energies as optional file keys; with the
    ``parameterization`` the fit used, on the user's domain (:func:`trispline.param.user_domain`)
    with its normalisation stored, and with the ``data`` vertices, its normalised energies."""
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
    uv, faces, ctrl = result.uv, result.faces, result.ctrl
    if data is not None:
        from ..energy import normalised_energies

        extras["fit_energies_normalised"] = np.array(list(normalised_energies(result.energies, data, uv, faces)
                                                          .values()))
    if parameterization is not None:
        from trispline.param import user_domain

        uv, faces, ctrl = user_domain(parameterization, ctrl, uv)
        extras.update(parameterization.transform.as_extras(), fit_param_chosen=np.array(parameterization.method))
    return SplineSurface(uv, faces, ctrl, extras=extras)


def _fit_text(d: dict) -> str:
    e = ", ".join(f"{k} {fmt(v)}" for k, v in d["energies_normalised"].items())
    chosen = d["param_chosen"] if d["param_chosen"] == d["param"] else f"{d['param']}: {d['param_chosen']}"
    dist = d["distortion"]
    return "\n".join([
        f"fitted {d['input']}: {d['vertices']} vertices, {d['patches']} quintic patches "
        f"(param {chosen}{', repaired by ' + d['parameterization_repaired'] if d['parameterization_repaired'] else ''}"
        f"; angle distortion max {fmt(float(dist['angle_max']))}, area distortion max {fmt(float(dist['area_max']))})",
        *([f"  {d['param_reason']}"] if d["param_reason"] else []),
        *([f"  repair: {'; '.join(d['repair']['messages'])}"] if d["repair"] else []),
        f"  energies (unit bounding-box diagonal, per unit domain area): {e}",
        f"  Gauss-Newton steps {d['iterations']}, C1 residual {fmt(d['c1_residual'])} (relative), "
        f"max interpolation error {fmt(d['max_interpolation_error'])}, {d['seconds']:.1f} s",
        "  time: " + ", ".join(f"{k} {v:.2f} s" for k, v in d["timings"].items()),
        *(f"  wrote {p}" for p in d["outputs"]),
    ])
