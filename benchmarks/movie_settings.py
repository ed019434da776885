"""MP4 size against encoder settings: one run of a scene, its frames encoded by several H.264
settings at once (the movie pipeline's own painter and frame spacing), each into its own file.

    .venv/bin/python benchmarks/movie_settings.py                     # the flagship, 1280x720
    .venv/bin/python benchmarks/movie_settings.py --keep /tmp/movies  # keep the files to look at

Prints per setting the file size (MB = 10^6 bytes), the encoder's CPU seconds and the mean
PSNR (dB) of its decoded frames against the painted ones on every 50th frame (how close the
movie is to what was drawn; the fine, low-amplitude waves the adaptive colour scale shows are
what costs bits).  ``--keep DIR`` writes ``DIR/<setting>.mp4`` and each movie's last frame as
``DIR/<setting>-last.png``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

SETTINGS = {
    "veryfast-crf23": {"preset": "veryfast", "crf": "23"},
    "medium-crf28": {"preset": "medium", "crf": "28"},
    "slow-crf28": {"preset": "slow", "crf": "28"},
    "medium-crf30": {"preset": "medium", "crf": "30"},
    "medium-crf31": {"preset": "medium", "crf": "31"},
    "faster-crf30": {"preset": "faster", "crf": "30"},
    "slow-crf32": {"preset": "slow", "crf": "32"},
}
"""Name -> libx264 options (yuv420p, the index at the front, as ``app.movie.encode``)."""


class Encoder:
    def __init__(self, path: Path, options: dict, width: int, height: int, fps: float) -> None:
        import av

        self.av = av
        self.path = path
        self.container = av.open(str(path), mode="w", format="mp4",
                                 options={"movflags": "+faststart"})
        self.stream = self.container.add_stream("libx264", rate=int(fps))
        self.stream.options = dict(options)
        self.stream.width, self.stream.height = width, height
        self.stream.pix_fmt = "yuv420p"
        self.index = 0
        self.seconds = 0.0

    def write(self, frame: np.ndarray) -> None:
        started = time.process_time()
        video = self.av.VideoFrame.from_ndarray(frame, format="rgb24")
        video.pts = self.index
        self.index += 1
        self.container.mux(self.stream.encode(video))
        self.seconds += time.process_time() - started

    def close(self) -> None:
        started = time.process_time()
        self.container.mux(self.stream.encode(None))
        self.container.close()
        self.seconds += time.process_time() - started


def decoded_frames(path: Path) -> list[np.ndarray]:
    import av

    with av.open(str(path)) as container:
        return [f.to_ndarray(format="rgb24") for f in container.decode(video=0)]


def psnr(a: np.ndarray, b: np.ndarray) -> float:
    error = np.mean((a.astype(float) - b.astype(float)) ** 2)
    return 10 * np.log10(255.0 ** 2 / max(error, 1e-12))


def main() -> None:
    import tempfile

    from PIL import Image

    import sim
    from app.movie.options import MovieOptions, default_colour
    from app.movie.painter import Painter
    from app.movie.simulated import SimulationSource

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scene", default="interference")
    parser.add_argument("--size", default="1280x720")
    parser.add_argument("--settings", nargs="*", default=list(SETTINGS), choices=list(SETTINGS),
                        metavar="SETTING", help=f"some of: {', '.join(SETTINGS)}")
    parser.add_argument("--keep", type=Path, default=None)
    arguments = parser.parse_args()
    width, height = map(int, arguments.size.split("x"))
    options = MovieOptions(size=(width, height), progress=False).resolved("mp4").checked()
    scene = sim.scenes.build(arguments.scene)
    source = SimulationSource(scene, options)
    colour = default_colour(source.model)
    painter = Painter(source.scene, source.model, source.summary, colour, source.scales(colour),
                      options)
    directory = arguments.keep or Path(tempfile.mkdtemp(prefix="movie-settings-"))
    directory.mkdir(parents=True, exist_ok=True)
    encoders = {name: Encoder(directory / f"{name}.mp4", SETTINGS[name], width, height,
                              options.fps) for name in arguments.settings}
    kept: dict[int, np.ndarray] = {}
    frame = np.empty((height, width, 3), np.uint8)
    count = 0
    for state in source.states(False, False):
        painter.paint(state, frame)
        for encoder in encoders.values():
            encoder.write(frame)
        if count % 50 == 0:
            kept[count] = frame.copy()
        last = frame.copy()
        count += 1
    kept[count - 1] = last
    print(f"{arguments.scene}: {count} frames at {width}x{height}, {options.fps:g} frames/s")
    for name, encoder in encoders.items():
        encoder.close()
        frames = decoded_frames(encoder.path)
        quality = np.mean([psnr(frames[i], kept[i]) for i in kept if i < len(frames)])
        size = encoder.path.stat().st_size / 1e6
        print(f"{name:16s} {size:7.1f} MB  encoder {encoder.seconds:6.1f} s CPU  "
              f"PSNR {quality:5.1f} dB (every 50th frame)")
        if arguments.keep:
            Image.fromarray(frames[-1]).save(directory / f"{name}-last.png")


if __name__ == "__main__":
    main()
