"""Issue 35.5: the help of every subcommand — every option has a help text, no default is shown
twice, a flag never shows "(default: True/False)" (its help says in words what it does), and
every command writes into ``out`` unless told otherwise. In-process, through the parser."""

from __future__ import annotations

import argparse
import re

import pytest

from torchirid.app import cli


def _subparsers():
    parser = cli.build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return parser, sub.choices


PARSER, SUBPARSERS = _subparsers()


def _shown(parser, action) -> str:
    """The help of ``action`` as ``--help`` prints it (defaults expanded), on one line."""
    return " ".join(parser._get_formatter()._expand_help(action).split()) if action.help else ""


def test_every_command_is_here():
    assert sorted(SUBPARSERS) == sorted(c.NAME for c in cli.COMMANDS)


@pytest.mark.parametrize("name", sorted(SUBPARSERS))
def test_help_has_no_artefacts(name, capsys):
    parser = SUBPARSERS[name]
    with pytest.raises(SystemExit) as e:
        PARSER.parse_args([name, "--help"])
    assert e.value.code == 0
    text = " ".join(capsys.readouterr().out.split())
    assert text.startswith(f"usage: torchirid {name} ")
    for action in parser._actions:
        label = "/".join(action.option_strings) or action.dest
        shown = _shown(parser, action)
        assert shown.strip(), f"{name} {label}: no help text"
        assert shown in text, (name, label)
        assert len(re.findall(r"\bdefault\b", shown, re.IGNORECASE)) <= 1, f"{name} {label}: default shown twice: {shown}"
        if action.nargs == 0:  # a flag: its help says what it does, not "(default: False)"
            assert not re.search(r"default: *(true|false)", shown, re.IGNORECASE), f"{name} {label}: {shown}"
    assert not re.search(r"\(default: *(True|False)\)", text)
    assert not re.search(r"\(default:? ([^)]*)\) \(default:? \1\)", text)


def test_no_white_says_what_it_does():
    shown = _shown(SUBPARSERS["scatterogram"], next(a for a in SUBPARSERS["scatterogram"]._actions
                                                    if "--no-white" in a.option_strings))
    assert "True" not in shown and "leave out the white-environment row" in shown and "unless" in shown


@pytest.mark.parametrize("name", sorted(SUBPARSERS))
def test_a_default_out_is_out(name):
    """Every command with a default --out writes under ``out`` (render-sphere wrote into ``.``)."""
    out = next((a for a in SUBPARSERS[name]._actions if a.dest == "out"), None)
    if out is not None and not out.required:
        assert out.default.split("/")[0] == "out", (name, out.default)


def test_the_parser_imports_no_figure_module():
    """Building the parser (``torchirid --help``) loads no figure that draws, no matplotlib, and not the
    library subpackages that only a command's run needs (they load when it runs)."""
    import subprocess
    import sys

    code = ("import sys; from torchirid.app import cli; cli.build_parser(); "
            "print(' '.join(sorted(m for m in sys.modules if m == 'matplotlib' or m.startswith(("
            "'torchirid.app.figures.', 'torchirid.ibl', 'torchirid.spectral', 'colour')))))")
    loaded = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    # _format: the --format choices; film_maps: imported by fit_film at module level (matplotlib inside)
    assert set(loaded) <= {"torchirid.app.figures._format", "torchirid.app.figures.film_maps"}, loaded
