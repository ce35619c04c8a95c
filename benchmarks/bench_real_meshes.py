"""Fit every usable mesh in ../shared/data and report continuity, interpolation and time.

    python benchmarks/bench_real_meshes.py [--param harmonic|lscm] [--only NAME ...]

Issue 4 item 6: every disk and disk-with-holes mesh fits with a C1 residual below
1e-9 (relative, algebraic, DESIGN.md section 2) and exact interpolation (corner point
of vertex i equals vertex i). Meshes that trispline rejects (e.g. the multi-component
pelvis) are listed with the reason. Skips cleanly when the data folder is absent.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import jax

jax.config.update("jax_enable_x64", True)


from trispline.fit import fit_surface  # noqa: E402
from trispline.fit.io import read_mesh  # noqa: E402
from trispline.spline.errors import InputError  # noqa: E402

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
C1_TARGET = 1e-9


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--param", default="lscm", choices=["harmonic", "lscm"])
    ap.add_argument("--only", nargs="*", help="mesh file names to run")
    args = ap.parse_args(argv)
    if not DATA.is_dir():
        print(f"no data folder at {DATA}; nothing to do")
        return 0
    files = sorted(p for p in DATA.iterdir() if p.suffix in (".obj", ".off", ".ply", ".stl"))
    if args.only:
        files = [p for p in files if p.name in args.only]
    hdr = (f"{'mesh':<34} {'faces':>7} {'holes':>5} {'param':>8} {'fit s':>7} {'GN':>3} "
           f"{'C1 rel':>8} {'interp err':>10} {'bend':>9} {'ok':>3}")
    print(hdr)
    print("-" * len(hdr))
    failures = 0
    for path in files:
        md = read_mesh(path)
        try:
            t = time.perf_counter()
            r = fit_surface(md.V, md.F, param=args.param)
            dt = time.perf_counter() - t
        except InputError as exc:
            print(f"{path.name:<34} {len(md.F):>7} {'':>5} {args.param:>8}  rejected: {str(exc)[:90]}")
            continue
        holes = len(r.space.tri.boundary_loops) - 1
        ok = r.c1_residual < C1_TARGET and r.max_interpolation_error == 0.0
        failures += not ok
        print(f"{path.name:<34} {len(md.F):>7} {holes:>5} {args.param:>8} {dt:>7.1f} {r.iterations:>3} "
              f"{r.c1_residual:>8.1e} {r.max_interpolation_error:>10.1e} {r.energies['bend']:>9.3g} "
              f"{'yes' if ok else 'NO':>3}")
    print(f"target: C1 relative < {C1_TARGET:g} and interpolation error exactly 0 on every accepted mesh; "
          f"{failures} failure(s)")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
