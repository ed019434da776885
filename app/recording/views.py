"""The one small interface every view of a recording's tree has; ``app.recording.track.Track``
loops over its views through it and knows none of them in particular.

A view logs what it shows once (``log_static``), on each frame (``log_frame``: the frame and how
many frames the tree logged before it, for views that log every k-th frame), hears of new
parameters (``model_changed``: a reason to stop, or None to go on), and ends
(``finish``: markdown lines for the recording's read-me, often none).  A view that gives a
reason to stop is finished at once and dropped; the tree logs the reason as a warning.
"""

from __future__ import annotations

from typing import Protocol

import rerun as rr

from sim.model.lattice import Model
from sim.runtime.runner import Frame


class RecordingView(Protocol):
    """What a tree of a recording shows, one thing each: the lattice, the energy plots, the
    field image, the probes, the screen, the mode energies."""

    def log_static(self, stream: rr.RecordingStream) -> None:
        """What does not change in time (names, colours, legends), once, at the start."""

    def log_frame(self, stream: rr.RecordingStream, frame: Frame, index: int) -> None:
        """One frame; ``index`` frames of this tree were logged before it."""

    def model_changed(self, stream: rr.RecordingStream, model: Model,
                      same_lattice: bool) -> str | None:
        """New parameters (``same_lattice``: the same sites and spacing); a reason to stop this
        view (it is then finished and dropped), or None."""

    def finish(self, stream: rr.RecordingStream) -> list[str]:
        """The end of the recording (or of this view): markdown lines for the read-me."""
