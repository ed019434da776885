"""Hearing a probe: a probed particle's displacement played as sound (a WAV file's bytes).

The sound is the simulated signal itself, sped up: nothing is synthesised.  A lattice moves at
around a hertz, so the signal is played ``factor`` times faster, which multiplies every frequency
in it by ``factor`` and divides every duration by it; a decaying mode decays, two close modes
beat, in the sound as in the run.

**The factor rule.**  ``frequency_factor`` takes the dominant frequency f of the motion (the
largest spectral peak of the channels over the whole series,
``sim.instruments.probes.dominant_frequencies``) and
chooses the "nice" number (1, 2 or 5 times a power of ten) nearest to ``PITCH / f`` on a log
scale, ``PITCH`` = 300 Hz.  So f sounds between 190 and 475 Hz (300 Hz / sqrt(2.5) and
300 Hz * sqrt(2.5)), and the factor is a round number a reader can undo in the head:
"×500: 0.487 Hz sounds as 244 Hz".

**What is played.**  The last ``longest * factor`` seconds of simulated time (all of the series if
it is shorter), linearly interpolated onto the audio sample rate: the sound lasts the simulated
span divided by the factor.  A short run makes a short sound: 60 s of a 0.5 Hz mode at ×500 is
0.12 s (30 periods); every second of sound needs ``factor`` seconds of simulation, and nothing is
looped or stretched to make up for it (a sound under ``SHORTEST_SECONDS`` is refused).  Each
channel's mean is removed (a steady offset is silent), then one gain for all channels brings the
loudest sample to ``HEADROOM`` of full scale in 16-bit integers, so the channels keep their
relative loudness and nothing clips; a raised-cosine fade of ``FADE_SECONDS`` at each end keeps
the start and the stop from clicking.  One probe makes a mono file; two make a stereo file,
probe 1 left and probe 2 right.

Linear interpolation passes faint images of the signal around multiples of the probe's own
sampling rate (times the factor) and does not filter motion faster than half the audio rate
divided by the factor (11 kHz / 500 = 22 Hz of simulated motion at ×500 and 22050 Hz): both are
far from the lattice's own frequencies at the usual sampling of four samples per period of the
fastest mode.  Pure numpy and the standard library's ``wave``.
"""

from __future__ import annotations

import dataclasses
import io
import math
import wave

import numpy as np

from sim.instruments.probes import dominant_frequencies, uniform_series

SAMPLE_RATE = 22050
"""Audio samples per second of the WAV file (Hz)."""
PITCH = 300.0
"""Where the factor puts the dominant frequency, before rounding to a nice factor (Hz)."""
LONGEST_SECONDS = 4.0
"""The most sound made: the last ``LONGEST_SECONDS * factor`` seconds of simulated time."""
SHORTEST_SECONDS = 0.05
"""A sound shorter than this is a click: refused."""
LEAST_SECONDS = 3.0
"""The sound a run is made long enough to give (``needed_simulated_seconds``)."""
FADE_SECONDS = 0.01
"""The raised-cosine fade at each end (at most a quarter of the sound)."""
HEADROOM = 0.9
"""The loudest sample's share of 16-bit full scale."""
MAX_CHANNELS = 2
"""One probe: mono; two: stereo (probe 1 left, probe 2 right)."""
NICE_STEPS = (1.0, 2.0, 5.0)


def frequency_factor(frequency: float, pitch: float = PITCH) -> float:
    """The nice factor (1, 2 or 5 times a power of ten) nearest to ``pitch / frequency`` on a
    log scale: ``frequency`` (Hz) times it sounds within a factor sqrt(2.5) of ``pitch``."""
    if not (math.isfinite(frequency) and frequency > 0):
        raise ValueError(f"a frequency factor needs a positive frequency, got {frequency!r}")
    wanted = pitch / frequency
    decade = math.floor(math.log10(wanted))
    candidates = [step * 10.0 ** power for power in (decade, decade + 1) for step in NICE_STEPS]
    return min(candidates, key=lambda factor: abs(math.log(factor / wanted)))


def _number(value: float) -> str:
    return f"{value:.4g}"


def describe_factor(factor: float, frequency: float) -> str:
    """"×200: 1.3 Hz sounds as 260 Hz"."""
    return (f"×{_number(factor)}: {_number(frequency)} Hz sounds as "
            f"{_number(frequency * factor)} Hz")


@dataclasses.dataclass(frozen=True)
class Sound:
    """A WAV file's bytes and how it was made: ``factor`` (every frequency times it),
    ``frequency`` the dominant frequency of the motion (Hz, simulated), ``seconds`` of sound
    made from the last ``simulated`` seconds of the run, ``channels`` (1 or 2), ``rate`` (Hz)."""

    wav: bytes
    factor: float
    frequency: float
    seconds: float
    simulated: float
    channels: int
    rate: int

    def describe(self) -> str:
        """"×500: 0.487 Hz sounds as 244 Hz; 0.4 s of sound from the last 200 s simulated"."""
        return (f"{describe_factor(self.factor, self.frequency)}; {self.seconds:.3g} s of sound "
                f"from the last {self.simulated:.4g} s simulated")


def probe_sound(times: np.ndarray, values: np.ndarray, rate: int = SAMPLE_RATE,
                longest: float = LONGEST_SECONDS, factor: float | None = None) -> Sound:
    """The sound of probed displacements: ``times`` (k,) s and ``values`` (k,) for one probe or
    (k, channels) for one or two (one displacement component each, m).  ``factor`` None chooses
    it from the dominant frequency (``frequency_factor``).  Raises ValueError when there is
    nothing to hear: too few samples, no motion, values that are not finite, a sound shorter
    than ``SHORTEST_SECONDS``."""
    times = np.asarray(times, dtype=float)
    values = np.asarray(values, dtype=float)
    if values.ndim == 1:
        values = values[:, None]
    if values.ndim != 2 or values.shape[0] != times.size:
        raise ValueError("give one value per time for each probe")
    channels = values.shape[1]
    if not 1 <= channels <= MAX_CHANNELS:
        raise ValueError(f"a sound has one or two channels (probes), got {channels}")
    if times.size < 8:
        raise ValueError("too few samples to hear: probe for longer")
    if not (np.isfinite(values).all() and np.isfinite(times).all()):
        raise ValueError("the probed displacements are not finite (the run blew up)")
    frequency = _dominant(times, values)
    if factor is None:
        factor = frequency_factor(frequency)
    elif not (math.isfinite(factor) and factor > 0):
        raise ValueError(f"the frequency factor must be positive, got {factor!r}")
    simulated = min(float(times[-1] - times[0]), longest * factor)
    count = int(math.floor(simulated / factor * rate)) + 1
    seconds = count / rate
    if seconds < SHORTEST_SECONDS:
        raise ValueError(
            f"{seconds:.3g} s of sound is too short to hear (the last {simulated:.3g} s "
            f"simulated, played {_number(factor)} times faster): probe for at least "
            f"{SHORTEST_SECONDS * factor:.3g} s of simulated time")
    sampled = times[-1] - simulated + np.arange(count) * (factor / rate)
    signal = np.stack([np.interp(sampled, times, values[:, k]) for k in range(channels)],
                      axis=1)
    signal -= signal.mean(axis=0)
    signal *= _fade(count, rate)[:, None]
    loudest = float(np.abs(signal).max())
    if loudest <= 0.0:
        raise ValueError("the probes did not move: nothing to hear")
    samples = np.round(signal * (HEADROOM * 32767 / loudest)).astype("<i2")
    return Sound(wav=_wav(samples, rate), factor=float(factor), frequency=frequency,
                 seconds=seconds, simulated=simulated, channels=channels, rate=int(rate))


def needed_simulated_seconds(times: np.ndarray, values: np.ndarray,
                             seconds: float = LEAST_SECONDS) -> tuple[float, float, float]:
    """(factor, dominant frequency (Hz), simulated seconds of probe series) that ``seconds`` of
    sound need, from the series so far (``values`` as for ``probe_sound``)."""
    times = np.asarray(times, dtype=float)
    values = np.asarray(values, dtype=float)
    if values.ndim == 1:
        values = values[:, None]
    if times.size < 8 or not np.isfinite(values).all():
        raise ValueError("too few samples to hear: probe for longer")
    frequency = _dominant(times, values)
    factor = frequency_factor(frequency)
    return factor, frequency, seconds * factor


def _dominant(times: np.ndarray, values: np.ndarray) -> float:
    """The frequency (Hz) of the largest spectral peak among the channels (over the whole
    series)."""
    loudest, frequency = 0.0, 0.0
    for k in range(values.shape[1]):
        even, interval = uniform_series(times, values[:, k])
        for peak, amplitude in dominant_frequencies(even, interval, count=1):
            if amplitude > loudest and peak > 0:
                loudest, frequency = amplitude, peak
    if loudest <= 0.0:
        raise ValueError("the probes did not move: nothing to hear")
    return frequency


def _fade(count: int, rate: int) -> np.ndarray:
    """1 inside, a raised cosine from 0 over ``FADE_SECONDS`` (at most a quarter) at each end."""
    envelope = np.ones(count)
    length = min(int(FADE_SECONDS * rate), count // 4)
    if length > 0:
        ramp = 0.5 - 0.5 * np.cos(np.pi * np.arange(length) / length)
        envelope[:length] = ramp
        envelope[count - length:] = ramp[::-1]
    return envelope


def _wav(samples: np.ndarray, rate: int) -> bytes:
    """16-bit PCM WAV bytes of (count, channels) samples."""
    buffer = io.BytesIO()
    with wave.open(buffer, "wb") as output:
        output.setnchannels(samples.shape[1])
        output.setsampwidth(2)
        output.setframerate(int(rate))
        output.writeframes(np.ascontiguousarray(samples).tobytes())
    return buffer.getvalue()
