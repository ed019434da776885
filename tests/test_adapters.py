"""Each private name of a library we borrow is read in one adapter module; these tests fail when
an installed version moves what the adapter reads (numba's cache locators are checked in
``tests/test_kernel_cache.py``)."""

from __future__ import annotations

import argparse

from app.cli import argparse_adapter, build_parser
from app.cli.arguments import command_from_arguments


def test_argparse_adapter_reads_a_parsers_actions():
    parser = argparse.ArgumentParser(prog="oscillators run")
    parser.add_argument("scene")
    parser.add_argument("--dt", type=float, default=0.01)
    parser.add_argument("--set", dest="overrides", action="append")
    found = argparse_adapter.actions(parser)
    assert [action.dest for action in found] == ["help", "scene", "dt", "overrides"]
    assert argparse_adapter.is_help(found[0]) and not argparse_adapter.is_help(found[2])
    assert [action.dest for action in argparse_adapter.options(parser)] == ["dt", "overrides"]
    arguments = parser.parse_args(["grid", "--dt", "0.02", "--set", "nx=4", "--set", "ny=3"])
    assert command_from_arguments(parser, arguments) == (
        "oscillators run grid --dt 0.02 --set nx=4 --set ny=3")


def test_argparse_adapter_finds_the_subcommands():
    commands = argparse_adapter.subcommands(build_parser())
    assert {"run", "serve", "record", "movie"} <= set(commands)
    assert argparse_adapter.subcommands(commands["run"]) == {}
