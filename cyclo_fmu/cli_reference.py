"""The command-line reference as Markdown, rendered from the argparse parser itself.

The docs site's ``reference/cli.md`` holds the marker ``<!-- cli-reference -->``; the MkDocs hook
``docs/_hooks/cli_reference.py`` replaces it with :func:`render_cli_reference`, so ``--help`` and
the documentation are one text and cannot disagree. ``tests/test_docs.py`` checks that every
option of every subcommand appears in the rendered page.
"""
from __future__ import annotations

import argparse

#: Marker in a Markdown page that the docs hook replaces with the rendered reference.
MARKER = "<!-- cli-reference -->"


def _subparsers(parser: argparse.ArgumentParser):
    """(name, help, subparser) of every subcommand, in the order they were added."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            helps = {a.dest: a.help for a in action._choices_actions}
            for name, sub in action.choices.items():
                yield name, helps.get(name) or "", sub


def _cell(text) -> str:
    """Text safe inside one Markdown table cell."""
    return " ".join(str(text).split()).replace("|", "\\|")


def _option_row(action: argparse.Action) -> str:
    if action.option_strings:
        names = ", ".join(f"`{s}`" for s in action.option_strings)
        if action.nargs != 0:
            names += f" `{action.metavar or action.dest.upper()}`"
    else:
        names = f"`{action.metavar or action.dest}`" + (" ..." if action.nargs in ("*", "+")
                                                        else "")
    facts = []
    if action.required or (not action.option_strings and action.nargs not in ("*", "?")):
        facts.append("required")
    if action.choices is not None:
        facts.append("one of " + ", ".join(f"`{c}`" for c in action.choices))
    if (action.default not in (None, False, argparse.SUPPRESS)
            and action.nargs != 0 and not isinstance(action.default, list)):
        facts.append(f"default `{action.default}`")
    help_text = "" if action.help in (None, argparse.SUPPRESS) else action.help
    return f"| {names} | {_cell(help_text) or '(no help text)'} | {_cell('; '.join(facts))} |"


def render_cli_reference(parser: argparse.ArgumentParser | None = None) -> str:
    """Markdown for every subcommand of ``cyclo-fmu``: its usage line, its help and a table of
    all its arguments (name, help text, required / choices / default), in parser order.

    Parameters
    ----------
    parser : argparse.ArgumentParser, optional
        The parser to render; default :func:`cyclo_fmu.cli.build_parser`.

    Returns
    -------
    str
        Markdown, one ``##`` section per subcommand.
    """
    if parser is None:
        from .cli import build_parser
        parser = build_parser()
    out = [f"`{parser.prog}` {_cell(parser.description or '')}", ""]
    names = [name for name, _, _ in _subparsers(parser)]
    out += ["Commands: " + ", ".join(f"[`{n}`](#{n})" for n in names) + ".", ""]
    for name, help_text, sub in _subparsers(parser):
        out += [f"## `{name}` {{#{name}}}", ""]
        if help_text:
            out += [help_text[0].upper() + help_text[1:] + ".", ""]
        usage = " ".join(sub.format_usage().replace("usage:", "").split())
        out += ["```text", usage, "```", ""]
        out += ["| argument | meaning | |", "|---|---|---|"]
        out += [_option_row(a) for a in sub._actions if not isinstance(a, argparse._HelpAction)]
        out.append("")
    return "\n".join(out)


def option_strings(parser: argparse.ArgumentParser | None = None) -> dict[str, list[str]]:
    """Every subcommand's option strings and positional names, for checks."""
    if parser is None:
        from .cli import build_parser
        parser = build_parser()
    return {name: [s for a in sub._actions if not isinstance(a, argparse._HelpAction)
                   for s in (a.option_strings or [a.metavar or a.dest])]
            for name, _, sub in _subparsers(parser)}
