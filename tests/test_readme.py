"""The README is a user's manual that stays true: its links, commands and snippets work.

* every relative link and picture exists;
* every ``trispline ...`` command line it shows is accepted by the real parser;
* its Python snippets run (on the built-in example scan);
* its command synopsis is the parser's usage of every subcommand
  (``python tests/test_readme.py --update`` rewrites it);
* it stays short (issue 20: under 250 lines) and cites no file a clone lacks.
"""
from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from trispline.fit.cli import build_parser
from trispline.fit.cli.reference import _subparsers

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
TEXT = README.read_text()


SYNOPSIS = re.compile(r"(<!-- cli-synopsis:start -->\n)(.*?)(<!-- cli-synopsis:end -->)", re.S)


def synopsis() -> str:
    """The usage lines of every subcommand at 96 columns, in a fenced block."""
    old = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = "96"
    try:
        usages = [sp.format_usage().replace(" [-h]", "").rstrip().replace("\n       ", "\n")[len("usage: "):]
                  for sp in _subparsers(build_parser()).values()]
    finally:
        if old is None:
            del os.environ["COLUMNS"]
        else:
            os.environ["COLUMNS"] = old
    return "```\n" + "\n".join(usages) + "\n```\n"


def test_the_synopsis_is_the_parsers_usage():
    block = SYNOPSIS.search(TEXT)
    assert block is not None
    assert block.group(2) == synopsis(), "run: python tests/test_readme.py --update"


def _commands() -> list[str]:
    """The README's indented or fenced ``trispline ...`` lines, without trailing comments."""
    lines = []
    for line in TEXT.splitlines():
        stripped = line.strip()
        if line.startswith("    ") and stripped.startswith("trispline "):
            lines.append(stripped.split("  #")[0].strip())
    return lines


def test_readme_is_short_and_cites_nothing_a_clone_lacks():
    assert len(TEXT.splitlines()) < 250
    assert "DESIGN.md" not in TEXT and "../shared" not in TEXT.replace("`../shared/data`", "")


@pytest.mark.parametrize("target", sorted(set(re.findall(r"\]\(([^)#]+)\)", TEXT))))
def test_every_link_and_picture_exists(target):
    assert (ROOT / target).exists(), target


def test_the_readme_shows_commands_of_every_subcommand():
    shown = {cmd.split()[1] for cmd in _commands()}
    assert {"info", "fit", "render", "check", "export"} <= shown


@pytest.mark.parametrize("command", _commands())
def test_every_command_line_parses(command):
    args = build_parser().parse_args(shlex.split(command)[1:])  # argparse exits 2 on an unknown option
    assert callable(args.func)


def test_the_python_snippets_run(tmp_path):
    demo = subprocess.run([sys.executable, "-m", "trispline.fit", "demo", "-o", str(tmp_path / "trispline-demo"),
                           "--example-faces", "200", "--quiet"], capture_output=True, text=True, cwd=tmp_path)
    assert demo.returncode == 0, demo.stderr
    snippets = re.findall(r"```python\n(.*?)```", TEXT, flags=re.S)
    assert len(snippets) >= 2
    script = "\n".join(snippets) + "\nassert centres.shape == (3, 3)\n"
    script += "assert continuity_report(space.tri, ctrl)['c1_relative'] < 1e-12\n"
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    assert (tmp_path / "scan.npz").is_file()


if __name__ == "__main__" and sys.argv[1:] == ["--update"]:
    README.write_text(SYNOPSIS.sub(lambda m: m.group(1) + synopsis() + m.group(3), TEXT))
