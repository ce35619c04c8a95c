"""The command-line reference in markdown, generated from the parser (``docs/cli.md`` is its output).

    python -m trispline.fit.cli.reference > docs/cli.md     # regenerate the page
    cli_reference()                                        # the same text, for the README

Each subcommand gets its description, its usage line and a table of its options with the
help text the parser has (which says each option's default, unit and meaning), so the page,
the README's embedded copy and ``--help`` cannot drift apart (``tests/fit/test_cli.py``
compares them).
"""
from __future__ import annotations

import argparse

from . import build_parser
from .common import PROG

__all__ = ["cli_reference", "command_reference"]

#: The page's opening lines.
_INTRO = f"""# Command-line reference

Generated from the parser by `python -m trispline.fit.cli.reference` (do not edit by hand);
`{PROG} COMMAND --help` prints the same. Every command takes `--json` (the result as JSON on
stdout, nothing else there), `-q/--quiet` and `--debug`. Exit codes: 0 success, 1 internal
failure, 2 bad input (one line `{PROG}: error: ...` on stderr, nothing written), 3 the result misses
what was asked (`check` or `info` found a problem, a fit did not converge within `--max-steps`, or
`--strict` missed its tolerance; nothing written), 130 interrupted, 143 terminated, 141 stdout closed by its reader. Outputs are written atomically: a
failed command leaves no file behind, and an existing output is untouched.
"""


def _subparsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    """The subcommands' parsers, in registration order."""
    for action in parser._actions:  # noqa: SLF001 - argparse has no public accessor
        if isinstance(action, argparse._SubParsersAction):  # noqa: SLF001
            return dict(action.choices.items())
    return {}


def _cell(text: str) -> str:
    """Text for a markdown table cell (``|`` escaped, one line)."""
    return " ".join(str(text).split()).replace("|", "\\|")


def _flags(action: argparse.Action) -> str:
    """``--name N`` (every option string, with the metavar when the option takes a value)."""
    if not action.option_strings:
        return f"`{action.metavar or action.dest}`"
    value = ""
    if action.nargs != 0:
        if action.choices is not None and action.metavar is None:
            value = " {" + ",".join(str(c) for c in action.choices) + "}"
        else:
            value = f" {action.metavar or action.dest.upper()}"
    return ", ".join(f"`{flag}{value}`" for flag in action.option_strings)


def command_reference(name: str, parser: argparse.ArgumentParser) -> str:
    """One subcommand's section: description, usage and the option table per argument group."""
    usage = " ".join(parser.format_usage().split())
    usage = usage.removeprefix("usage: ")
    lines = [f"## `{PROG} {name}`", "", _cell(parser.description or ""), "", "```", usage, "```", ""]
    for group in parser._action_groups:  # noqa: SLF001
        actions = [a for a in group._group_actions  # noqa: SLF001
                   if a.help is not argparse.SUPPRESS and not isinstance(a, argparse._HelpAction)]  # noqa: SLF001
        if not actions:
            continue
        lines += [f"**{group.title}**", "", "| option | meaning |", "|---|---|"]
        expand = parser._get_formatter()._expand_help  # noqa: SLF001 - the help as --help prints it
        lines += [f"| {_flags(a)} | {_cell(expand(a) if a.help else '')} |" for a in actions]
        lines.append("")
    return "\n".join(lines)


def cli_reference() -> str:
    """The whole reference (markdown), one section per subcommand, from :func:`build_parser`."""
    parser = build_parser()
    sections = [_INTRO] + [command_reference(n, p) for n, p in _subparsers(parser).items()]
    return "\n".join(sections).rstrip() + "\n"


if __name__ == "__main__":  # pragma: no cover
    print(cli_reference(), end="")
