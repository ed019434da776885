"""Which picture format carries the web page's field image best: bytes per picture against its
fidelity (peak signal-to-noise ratio against the uncompressed picture, dB) and encoding time.

It runs the 682x383 interference scene for a few simulated seconds (waves spreading from the two
sources), colours the displacement field as the page does (``app.colours`` magnitude map, scale at
the 99.5th percentile) and encodes the picture as JPEG and WebP at several qualities and as PNG
(``app.web.frames.encode``).  ``app.web.frames.FORMAT`` / ``QUALITY`` are chosen from this table.

    .venv/bin/python benchmarks/frame_formats.py              # after 8 s and 20 s of simulation
    .venv/bin/python benchmarks/frame_formats.py --times 5 30
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import sim
from app import colours
from app.web.frames import encode, field_picture

CHOICES = [(image_format, quality) for image_format in ("jpeg", "jpeg444", "webp")
           for quality in (60, 70, 80, 90)] + [("jpeg444", quality) for quality in (40, 50, 75)] + [
    ("jpeg", 40), ("jpeg", 50), ("png", 0)]


def psnr(reference: np.ndarray, decoded: np.ndarray) -> float:
    error = np.mean((reference.astype(float) - decoded.astype(float)) ** 2)
    return float("inf") if error == 0 else 10 * np.log10(255.0**2 / error)


def decode(data: bytes) -> np.ndarray:
    import io

    from PIL import Image

    return np.asarray(Image.open(io.BytesIO(data)).convert("RGB"))


def picture_at(simulation: sim.Simulation, seconds: float) -> np.ndarray:
    steps = max(0, round((seconds - simulation.time) / simulation.dt))
    simulation.step(steps)
    model = simulation.model
    values = np.linalg.norm(simulation.positions - model.rest_positions, axis=1)
    scale = max(float(np.percentile(values, 99.5)), 1e-12)
    return field_picture(model, colours.MAGNITUDE.map(values, scale))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--times", type=float, nargs="*", default=[8.0, 20.0],
                        help="simulated seconds at which the field is pictured")
    arguments = parser.parse_args()
    simulation = sim.Simulation(sim.scenes.build("interference"))
    print(f"{'t (s)':>6s} {'format':>7s} {'quality':>7s} {'kB':>7s} {'PSNR dB':>8s} "
          f"{'encode ms':>9s}")
    for seconds in arguments.times:
        picture = picture_at(simulation, seconds)
        for image_format, quality in CHOICES:
            started = time.perf_counter()
            for _ in range(5):
                data = encode(picture, image_format, quality)
            elapsed = (time.perf_counter() - started) / 5
            fidelity = psnr(picture, decode(data))
            print(f"{seconds:6.1f} {image_format:>7s} {quality:7d} {len(data) / 1e3:7.1f} "
                  f"{fidelity:8.1f} {1e3 * elapsed:9.1f}")


if __name__ == "__main__":
    main()
