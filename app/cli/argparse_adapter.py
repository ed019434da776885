"""The one place that reads argparse's private names: a parser's list of actions and the
sub-command action (argparse has no public API for either).  ``tests/test_adapters.py`` fails
when a Python version moves them."""

from __future__ import annotations

import argparse
from collections.abc import Iterator


def actions(parser: argparse.ArgumentParser) -> tuple[argparse.Action, ...]:
    """Every argument ``parser`` was given (positionals and options, help included), in order."""
    return tuple(parser._actions)  # noqa: SLF001 - argparse has no public list of actions


def is_help(action: argparse.Action) -> bool:
    """Whether ``action`` is the automatic ``--help``."""
    return isinstance(action, argparse._HelpAction)  # noqa: SLF001


def subcommands(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    """The sub-command parsers of ``parser`` by name (empty when it has none)."""
    for action in actions(parser):
        if isinstance(action, argparse._SubParsersAction):  # noqa: SLF001
            return dict(action.choices)
    return {}


def options(parser: argparse.ArgumentParser) -> Iterator[argparse.Action]:
    """The optional arguments of ``parser`` (those with option strings), help left out."""
    return (action for action in actions(parser) if action.option_strings and not is_help(action))
