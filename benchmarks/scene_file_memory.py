"""Peak memory of refused scene files: a lying ``.zip`` and a lattice too large for the page.

Writes a ``.zip`` of about 2 MB whose one TOML member inflates to ``--inflated`` bytes (2 GB)
while its zip directory says 1,000 bytes (``tests/lying_zip.py``), then measures:

* the command line: the peak resident memory (``ru_maxrss``) of ``oscillators run bomb.zip``
  and, for comparison, of ``oscillators run`` refusing a broken 16-byte ``.zip``; both exit 2;
* a page: ``oscillators serve grid`` in a subprocess; a program speaking viser's protocol
  (``tests/page_client.py``) uploads the file with *Open a scene file…*, from ``--pages``
  pages at once, then a TOML scene of 2000x1000 particles.  The server's resident memory
  when idle (``VmRSS``) and its peak while the uploads are refused (``VmHWM``, reset through
  ``/proc/PID/clear_refs`` before each upload) are printed, with what the page said.

    .venv/bin/python benchmarks/scene_file_memory.py
    .venv/bin/python benchmarks/scene_file_memory.py --inflated 500000000 --pages 1
"""

from __future__ import annotations

import argparse
import asyncio
import os
import re
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from tests.helpers import free_port  # noqa: E402
from tests.lying_zip import write_lying_zip  # noqa: E402
from tests.page_client import Page  # noqa: E402

REPO = Path(__file__).resolve().parent.parent
UPLOAD = "Open a scene file…"
LARGE_TOML = b'name = "large"\n[model]\nnx = 2000\nny = 1000\n'


def child_peak_mb(arguments: list[str], cwd: Path) -> tuple[int, float, str]:
    """Exit code, peak resident MB and last line of stderr of one command run in a child."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    result = subprocess.run(arguments, cwd=cwd, capture_output=True, text=True,
                            env={**os.environ, "PYTHONPATH": str(REPO)})
    peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    if peak <= before:  # ru_maxrss of children is the largest child so far
        peak = before
    lines = result.stderr.strip().splitlines()
    return result.returncode, peak / 1024, lines[-1] if lines else ""


def status_mb(pid: int, field: str) -> float:
    text = Path(f"/proc/{pid}/status").read_text()
    return int(re.search(rf"{field}:\s+(\d+) kB", text).group(1)) / 1024


def reset_peak(pid: int) -> None:
    Path(f"/proc/{pid}/clear_refs").write_text("5")


async def upload_from_pages(port: int, name: str, content: bytes, pages: int,
                            seconds: float = 120.0) -> list[str]:
    """Upload ``content`` from ``pages`` pages at once; what each page was told."""
    async def one() -> str:
        async with Page(port) as page:
            await page.camera()
            await page.listen(2.0)
            seen = len(page.updates)
            await page.upload(UPLOAD, name, content)
            end = time.monotonic() + seconds
            while time.monotonic() < end:
                await page.listen(0.5)
                for update in reversed(page.updates[seen:]):
                    text = str(update["updates"].get("content", ""))
                    if "could not open" in text or "opened" in text:
                        return re.sub(r"<[^>]+>", "", text)
            return "(no answer)"

    return list(await asyncio.gather(*(one() for _ in range(pages))))


def serve(folder: Path) -> tuple[subprocess.Popen, int]:
    process = subprocess.Popen(
        [sys.executable, "-m", "app.cli", "serve", "grid", "--port", str(free_port())], cwd=folder,
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
        env={**os.environ, "PYTHONPATH": str(REPO)})
    while True:
        line = process.stdout.readline()
        match = re.search(r"serving on http://127\.0\.0\.1:(\d+)", line)
        if match:
            return process, int(match.group(1))
        if not line and process.poll() is not None:
            raise SystemExit("the server did not start")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--inflated", type=int, default=2_000_000_000,
                        help="bytes the lying TOML inflates to (default 2e9)")
    parser.add_argument("--pages", type=int, default=3, help="pages uploading at once")
    arguments = parser.parse_args()
    folder = Path(tempfile.mkdtemp(prefix="scene-memory-"))
    bomb = write_lying_zip(folder / "bomb.zip", arguments.inflated)
    broken = folder / "broken.zip"
    broken.write_bytes(b"PK\x03\x04 not a zip")
    print(f"bomb.zip: {bomb.stat().st_size:,} bytes, inflates to {arguments.inflated:,}, "
          "its directory says 1,000")
    for path in (broken, bomb):
        code, peak, said = child_peak_mb([sys.executable, "-m", "app.cli", "run", path.name],
                                         folder)
        print(f"oscillators run {path.name}: exit {code}, peak {peak:.0f} MB  ({said})")

    process, port = serve(folder)
    try:
        asyncio.run(upload_from_pages(port, "warm.toml", b'name = "warm"\n[model]\nnx = 3\n', 1))
        time.sleep(2.0)
        for name, content, pages in (("bomb.zip", bomb.read_bytes(), 1),
                                     ("bomb.zip", bomb.read_bytes(), arguments.pages),
                                     ("large.toml", LARGE_TOML, 1)):
            idle = status_mb(process.pid, "VmRSS")
            reset_peak(process.pid)
            answers = asyncio.run(upload_from_pages(port, name, content, pages))
            peak = status_mb(process.pid, "VmHWM")
            print(f"page upload of {name} from {pages} page(s): server idle {idle:.0f} MB, "
                  f"peak {peak:.0f} MB (+{peak - idle:.0f} MB); the page said: {answers[0]}")
    finally:
        process.terminate()
        process.wait(timeout=30)


if __name__ == "__main__":
    main()
