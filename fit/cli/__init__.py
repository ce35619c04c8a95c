"""The ``trispline`` command line (also ``python -m trispline.fit``).

    trispline demo [-o DIR]                               # fit the built-in example scan
    trispline fit MESH -o SURFACE.npz [--param lscm|harmonic|uv] [--bend W ...]
                  [--keep-largest] [--mesh-out FILE --resolution N] [--image PNG]
    trispline fit --example -o SURFACE.npz                # the built-in synthetic scan
    trispline export SURFACE.npz -o OUT.obj|ply|stl|glb|json|npz|png [--resolution N]
                  [--control-net FILE [--net-lines]]
    trispline check SURFACE.npz [--tolerance T]           # continuity residuals, statistics
    trispline info MESH                                   # topology, what fit would reject
    trispline render SURFACE.npz -o PICTURE.png [--mode shaded|zebra|curvature|deviation|controlnet]

Every command takes ``--json`` (machine-readable result on stdout, nothing else
there), ``--quiet`` (no progress bars, no summary) and ``--debug`` (a traceback
for internal failures). Exit codes: 0 success; 1 internal failure; 2 bad input
(unreadable or unusable mesh or surface file, bad option; one line on stderr, no
traceback); 3 ``check``/``info`` found a problem (C1 broken beyond the
tolerance; a mesh ``fit`` would reject). Outputs are written atomically: a
failed command leaves no file behind, not even a partial one.

One module per subcommand (``fit`` with ``demo``, ``export``, ``check``, ``info``,
``render``), each registering itself with ``add_parser``; the shared plumbing (output,
progress, option types, output paths, :func:`~trispline.fit.cli.common.run_cli`) is in
``common``. JAX is imported (and switched to float64) only by ``fit`` and ``demo``, so
the other commands start quickly.
"""
from __future__ import annotations

import argparse
from typing import Sequence

from . import check, export, fit, info, render
from .common import PROG, Parser, leave, run_cli, version
from .fit import WEIGHT_FIELDS

__all__ = ["WEIGHT_FIELDS", "build_parser", "main"]


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``trispline`` (imports nothing heavy)."""
    parser = Parser(
        prog=PROG,
        description="Fit exactly C1 quintic triangular spline surfaces to open triangle meshes.",
        epilog="Exit codes: 0 ok, 1 internal failure, 2 bad input, 3 the result misses what was asked "
               "(check/info found a problem, a fit did not converge, --strict tolerance not met).",
    )
    parser.add_argument("--version", action="version", version=f"{PROG} {version()}")
    parser.add_argument("--debug", action="store_true", help="show the full traceback of internal failures")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=Parser)
    sub.required = True
    fit.add_parsers(sub)
    export.add_parser(sub)
    check.add_parser(sub)
    info.add_parser(sub)
    render.add_parser(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit code (see the module docstring).

    As the program itself (``argv`` None: the ``trispline`` script, ``python -m trispline.fit``)
    the process ends at once with the exit code, streams flushed (:func:`~.common.leave`);
    called with arguments (tests, other programs) it always returns.
    """
    code = run_cli(build_parser, argv)
    if argv is None:
        leave(code)
    return code
