"""The options that send a study's independent runs to a Dask cluster (``--workers N``,
``--scheduler tcp://HOST:PORT``), shared by the sweep commands, and the executor they ask for
(``app.study.executor``).  Neither option: the runs stay serial in this process."""

from __future__ import annotations

import argparse
import contextlib
import sys
from collections.abc import Iterator
from typing import Any

from app.cli.arguments import positive_int


def add_cluster_arguments(parser: argparse.ArgumentParser) -> None:
    """Add --workers and --scheduler to a sweep command."""
    group = parser.add_argument_group("running the runs on a Dask cluster")
    where = group.add_mutually_exclusive_group()
    where.add_argument("--workers", type=positive_int, metavar="N",
                       help="run the independent runs on a local Dask cluster of N worker "
                       "processes (default: serially in this process)")
    where.add_argument("--scheduler", metavar="tcp://HOST:PORT",
                       help="run them on an existing Dask cluster (started with `dask scheduler` "
                       "and `dask worker tcp://HOST:PORT`; the workers must import this program)")


@contextlib.contextmanager
def executor_from(arguments: argparse.Namespace) -> Iterator[Any]:
    """The executor of the parsed options; a lost run becomes one line and exit status 1."""
    from app.study.executor import LostRunsError, executor_for

    with executor_for(getattr(arguments, "workers", None),
                      getattr(arguments, "scheduler", None)) as executor:
        if executor.workers > 1 or arguments.scheduler:
            print(f"runs on {executor.description}", file=sys.stderr)
        try:
            yield executor
        except LostRunsError as error:
            print(f"error: {error}", file=sys.stderr)
            raise SystemExit(1) from None
