"""A camera image sampled and held at the camera rate, rendered only for the frames read.

Drake's ``RgbdSensor`` renders an image when its output port is evaluated. A
``ZeroOrderHold`` on that port evaluates it at every sample, so a 30 Hz camera
costs 30 renders a second even when nothing reads its image. :class:`FrameHold`
keeps Gazebo's frame timing (the frame of time ``k / rate`` is what the readers
of the period ``[k / rate, (k + 1) / rate)`` see) but samples a frame only when a
reader reads in its period:

- each reader says at which rate and offset it reads (:meth:`FrameHold.add_reader`,
  e.g. a detector at the camera rate, a point-cloud pipeline at 10 Hz, the frame
  saver at its save rate), optionally only while ``active()`` says so;
- with ``on_demand=False`` (the default for a hold built alone) every frame is
  sampled, as a ``ZeroOrderHold`` would.

The sample events stay at every ``1 / rate`` either way (a frame nobody reads is
skipped, the event does nothing), so the simulation's step boundaries, and with
them its results, do not depend on which frames are read. A read the hold was not
told of, in a period whose frame was not sampled (a test or a script evaluating
the port after a run), renders the scene of that instant instead.

A frame whose scene is the one of the frame held is not rendered again: given the
poses of the camera's scene (``watch_scene``: an input of every frame's pose, e.g. the
cameras' own scene graph's, :mod:`~armando_drake.sensors.camera_scene`), a sample
whose poses are, bit for bit, those of the frame last rendered holds that frame
again. A renderer draws the same pixels from the same poses, so the frames are the
same; a camera that looks at a still scene renders once (``reuses`` counts the
frames held again).

Gazebo's camera ``<noise>`` (type ``gaussian``) is applied here, to the frames
sampled: N(mean, stddev) added to every colour channel in [0, 1] units, clamped,
alpha untouched (:func:`add_color_noise`, drawn from a table of whole levels,
:func:`noise_levels`).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass
from statistics import NormalDist

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.geometry import FramePoseVector
from pydrake.systems.framework import EventStatus, LeafSystem

# Two instants closer than this [s] are one (event times are sums of float periods).
_TIME_TOLERANCE = 1e-9


@dataclass(frozen=True)
class FrameReader:
    """One reader of a held image: it reads at ``rate`` [Hz] from ``offset`` [s], while
    ``active()`` (None: always)."""

    rate: float
    offset: float = 0.0
    active: Callable[[], bool] | None = None

    def reads_between(self, start: float, end: float) -> bool:
        """Whether it reads at an instant of ``[start, end)`` [s] (and is active)."""
        if self.active is not None and not self.active():
            return False
        first = max(0, math.ceil((start - self.offset) * self.rate - 1e-6))
        return first / self.rate + self.offset < end - _TIME_TOLERANCE


# Bins of the noise table (noise_levels): 16-bit uniform draws.
NOISE_BINS = 1 << 16


def noise_levels(mean: float, stddev: float) -> np.ndarray:
    """The noise table of N(``mean``, ``stddev``) [0..255 units] rounded to whole levels:
    entry ``i`` is ``rint(mean + stddev * z)`` at the normal quantile ``z`` of ``(i + 0.5)
    / NOISE_BINS``. A uniform 16-bit index into it draws level ``k`` with the probability
    that ``rint(mean + stddev * z)`` is ``k`` for a standard normal ``z``, to within
    ``1 / NOISE_BINS``; beyond 4.3 standard deviations (probability 1.6e-5) it draws the
    outermost levels."""
    return np.rint(mean + stddev * _normal_quantiles()).astype(np.int16)


@functools.cache
def _normal_quantiles() -> np.ndarray:
    """The standard normal quantiles of the centres of the NOISE_BINS equal bins of [0, 1]."""
    normal = NormalDist()
    return np.array([normal.inv_cdf((i + 0.5) / NOISE_BINS) for i in range(NOISE_BINS)])


def add_color_noise(image: np.ndarray, rng: np.random.Generator, levels: np.ndarray):
    """``image`` (H x W x 4 uint8) with a draw of the noise table ``levels``
    (:func:`noise_levels`) added to each of R, G and B, clamped; alpha untouched. Adding
    a whole level to a whole level is what rounding the sum of the image and continuous
    noise gives (Gazebo's noise, added in [0, 1] units, then stored in 8 bits), at a
    third of the cost of drawing normal deviates (23 ms for an 800 x 800 frame here,
    against 72)."""
    noise = levels[rng.integers(0, NOISE_BINS, image.shape[:2] + (3,), dtype=np.uint16)]
    noise += image[:, :, :3]
    np.clip(noise, 0, 255, out=noise)
    noisy = image.copy()
    noisy[:, :, :3] = noise
    return noisy


class FrameHold(LeafSystem):
    """Holds an image sampled every ``1 / frame_rate`` seconds (from time 0).

    ``model``: the image type (an ``ImageRgba8U`` or ``ImageDepth32F`` of the camera's
    size). With ``on_demand`` a frame is sampled only when a reader of
    :meth:`add_reader` reads in its period; without, every frame (a zero-order hold).
    ``stddev`` > 0: Gaussian colour noise (``mean``, ``stddev`` in [0, 1] colour units,
    random generator seeded with ``seed``) on each frame sampled (colour images only).
    With ``watch_scene`` a sample whose scene poses equal those of the frame last taken
    from the input holds that frame again instead of rendering it (noise drawn anew).

    Ports:
      - input ``image``
      - input ``scene_poses`` (FramePoseVector; only with ``watch_scene``): every pose
        the image depends on
      - output ``image``: the frame of the latest sample time
    """

    def __init__(
        self,
        model,
        *,
        frame_rate: float,
        on_demand: bool = False,
        mean: float = 0.0,
        stddev: float = 0.0,
        seed: int = 0,
        watch_scene: bool = False,
    ):
        super().__init__()
        if not (math.isfinite(frame_rate) and frame_rate > 0):
            raise ValueError(f"frame_rate={frame_rate!r} must be positive")
        if not stddev >= 0:
            raise ValueError(f"stddev={stddev!r} must be >= 0")
        self._rate = float(frame_rate)
        self._on_demand = on_demand
        self._readers: list[FrameReader] = []
        self._mean = 255.0 * mean
        self._stddev = 255.0 * stddev
        self._seed = seed
        self._rng = np.random.default_rng(seed)
        noisy = self._stddev > 0 or self._mean != 0
        self._levels = noise_levels(self._mean, self._stddev) if noisy else None
        value = AbstractValue.Make(model)
        self._input = self.DeclareAbstractInputPort("image", value)
        self._image = self.DeclareAbstractState(value)
        self._tick = self.DeclareAbstractState(AbstractValue.Make(-1))  # frame held; -1 none
        self._scene = self._key = self._clean = None
        if watch_scene:
            self._scene = self.DeclareAbstractInputPort(
                "scene_poses", AbstractValue.Make(FramePoseVector())
            )
            self._key = self.DeclareAbstractState(AbstractValue.Make(b""))  # poses rendered
            if self._stddev > 0 or self._mean != 0:
                self._clean = self.DeclareAbstractState(value)  # the frame before the noise
        self.DeclarePeriodicUnrestrictedUpdateEvent(1.0 / frame_rate, 0.0, self._Sample)
        self.DeclareAbstractOutputPort("image", lambda: value.Clone(), self._CalcImage)
        # Frames taken from the input (each a render): sampled, and rendered for a read
        # the hold was not told of; for tests and benchmarks.
        self.samples = 0
        self.renders_on_read = 0
        # Samples that held the frame last taken again, its scene unchanged (no render).
        self.reuses = 0

    @property
    def frame_rate(self) -> float:
        return self._rate

    @property
    def on_demand(self) -> bool:
        return self._on_demand

    @property
    def readers(self) -> tuple[FrameReader, ...]:
        return tuple(self._readers)

    def add_reader(
        self, rate: float, offset: float = 0.0, active: Callable[[], bool] | None = None
    ) -> None:
        """Tells the hold of a reader at ``rate`` [Hz] from ``offset`` [s] (while
        ``active()``, if given): the frames of the periods it reads in are sampled."""
        if not (math.isfinite(rate) and rate > 0):
            raise ValueError(f"rate={rate!r} must be positive [Hz]")
        if not (math.isfinite(offset) and offset >= 0):
            raise ValueError(f"offset={offset!r} must be >= 0 [s]")
        self._readers.append(FrameReader(float(rate), float(offset), active))

    def wanted(self, tick: int) -> bool:
        """Whether the frame of ``tick`` (time ``tick / frame_rate``) is sampled."""
        if not self._on_demand:
            return True
        start, end = tick / self._rate, (tick + 1) / self._rate
        return any(reader.reads_between(start, end) for reader in self._readers)

    def _frame(self, image, rng: np.random.Generator):
        if self._stddev <= 0 and self._mean == 0:
            return image
        noisy = type(image)(image.width(), image.height())
        noisy.mutable_data[:] = add_color_noise(image.data, rng, self._levels)
        return noisy

    def _scene_key(self, context) -> bytes:
        """The poses of the scene, as bytes: equal bytes, the same image."""
        poses = self._scene.Eval(context)
        return b"".join(
            poses.value(frame).GetAsMatrix34().tobytes()
            for frame in sorted(poses.ids(), key=lambda f: f.get_value())
        )

    def _clean_frame(self, context, state):
        """The frame of this sample before the noise: rendered, or the one last rendered
        when the scene is the same."""
        if self._scene is None:
            return self._input.Eval(context)
        key = self._scene_key(context)
        if context.get_abstract_state(self._tick).get_value() >= 0:
            if key == context.get_abstract_state(self._key).get_value():
                self.reuses += 1
                held = self._clean if self._clean is not None else self._image
                return context.get_abstract_state(held).get_value()
        image = self._input.Eval(context)
        state.get_mutable_abstract_state(self._key).set_value(key)
        if self._clean is not None:
            state.get_mutable_abstract_state(self._clean).set_value(image)
        return image

    def _Sample(self, context, state) -> EventStatus:
        tick = round(context.get_time() * self._rate)
        if not self.wanted(tick):
            return EventStatus.DidNothing()
        image = self._frame(self._clean_frame(context, state), self._rng)
        state.get_mutable_abstract_state(self._image).set_value(image)
        state.get_mutable_abstract_state(self._tick).set_value(tick)
        self.samples += 1
        return EventStatus.Succeeded()

    def _CalcImage(self, context, output) -> None:
        held = context.get_abstract_state(self._tick).get_value()
        scaled = context.get_time() * self._rate
        latest = math.floor(scaled + _TIME_TOLERANCE)
        on_tick = abs(scaled - round(scaled)) < _TIME_TOLERANCE * self._rate
        # The frame of the latest sample; at a sample instant, before its event, the one
        # before (a zero-order hold's value then).
        if held >= 0 and (held == latest or (on_tick and held == latest - 1)):
            output.set_value(context.get_abstract_state(self._image).get_value())
            return
        # A read the hold was not told of: the scene of this instant.
        rng = np.random.default_rng([self._seed, latest])
        self.renders_on_read += 1
        output.set_value(self._frame(self._input.Eval(context), rng))
