"""The README and docs/ as a newcomer meets them: every link and image they name exists, the
README stays short, and every `oscillators` command of the README is one the CLI takes."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest

from app.cli import build_parser

ROOT = Path(__file__).resolve().parent.parent
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)\)")
"""A Markdown link or image: its target."""
MENTION = re.compile(r"`((?:docs|benchmarks|scripts|tests|sim|app)/[\w./-]+\.(?:md|py|png|gif|sh))`")
"""A file named in code quotes (`docs/web.md`, `benchmarks/recording_speed.py`)."""


@pytest.mark.parametrize("page", PAGES, ids=[str(p.relative_to(ROOT)) for p in PAGES])
def test_every_link_image_and_named_file_exists(page):
    text = page.read_text(encoding="utf-8")
    prose = re.sub(r"`[^`\n]*`", "", re.sub(r"```.*?```", "", text, flags=re.S))
    missing = []
    for target in LINK.findall(prose):
        if re.match(r"[a-z]+:", target) or target.startswith("#"):
            continue  # a web address or an anchor on the page
        path = (page.parent / target.split("#")[0]).resolve()
        if not path.exists():
            missing.append(target)
    for named in MENTION.findall(text):
        if not (ROOT / named).exists() and not (page.parent / named).exists():
            missing.append(named)
    assert not missing, f"{page.relative_to(ROOT)} names files that are not there: {missing}"


def test_the_readme_teaches_in_a_few_minutes():
    assert (ROOT / "README.md").stat().st_size <= 8 * 1024


def _readme_commands() -> list[str]:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    blocks = re.findall(r"```sh\n(.*?)```", text, flags=re.S)
    commands = []
    for block in blocks:
        for line in block.splitlines():
            line = line.split("#")[0].strip()
            if line.startswith("oscillators "):
                commands.append(line)
    return commands


def test_the_readme_commands_are_the_clis():
    commands = _readme_commands()
    assert len(commands) >= 10
    parser = build_parser()
    for command in commands:
        parser.parse_args(shlex.split(command)[1:])  # SystemExit on anything it does not take
