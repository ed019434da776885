"""``oscillators lessons``: the lessons (``app.lessons``), each with the command that starts it
and the page of ``docs/lessons`` with its questions and measured answers; ``oscillators lessons
KEY`` prints one lesson whole."""

from __future__ import annotations

import argparse

from app.cli.commands import summary


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``lessons`` command to ``oscillators``."""
    parser = subparsers.add_parser(
        "lessons", help=summary("lessons"),
        description="The lessons, each a scene to open, what to look at, three questions for "
        "students and the answers the product measures (with the command that measures each). "
        "On the page they are in the Lessons folder.",
        epilog="examples:\n  oscillators lessons                  # every lesson and how to "
        "start it\n  oscillators lessons fpu-recurrence   # one lesson, its questions and "
        "answers",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("key", nargs="?", metavar="LESSON",
                        help="print this lesson whole (default: list them all)")
    parser.set_defaults(handler=command_lessons)


def command_lessons(arguments: argparse.Namespace) -> int:
    from app.lessons import LESSONS, lesson

    if arguments.key is not None:
        print(lesson(arguments.key).markdown(), end="")
        return 0
    for each in LESSONS:
        print(f"{each.key:24s} {each.title}\n{'':24s} start: {each.start}\n"
              f"{'':24s} docs/lessons/{each.key}.md")
    return 0
