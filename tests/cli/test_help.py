"""``--help`` of every command: every option explained, defaults shown, no stray %%."""

from __future__ import annotations

import argparse

import pytest

from scenarios.cli.parser import build_parser

PARSER = build_parser()
SUBCOMMANDS = next(a for a in PARSER._actions if isinstance(a, argparse._SubParsersAction))


@pytest.mark.parametrize("name", sorted(SUBCOMMANDS.choices))
def test_help_explains_every_option_and_shows_defaults(name):
    sub = SUBCOMMANDS.choices[name]
    text = sub.format_help()
    assert "%%" not in text and "%(" not in text
    for action in sub._actions:
        if isinstance(action, argparse._HelpAction):
            continue
        assert action.help, f"mrta {name} {action.dest}: no help text"
        default = action.default
        has_default = not (default is None or default is False or action.required)
        if action.option_strings and has_default:
            formatter = sub._get_formatter()
            assert "default" in formatter._get_help_string(action), (
                f"mrta {name} {action.option_strings[0]}: default not shown"
            )
