"""What every family's inputs have: frames in time, cut into trajectories, at one sample period.

A family's inputs adapter turns its recordings into arrays over all frames, stacked in time
(:doc:`/guide/architecture`). Whatever else they hold (a snake's angles and actuator tensions, a
bench's input and output signals), they share what this mixin gives: the trajectory starts
``reset``, the sample period ``dt``, derived arrays computed once (:meth:`FrameInputs.memo`),
the time since each trajectory's start, and cutting and stacking by whole trajectories, which is
how the diagnosis makes its splits.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator, Sequence
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "SLICE_FRAMES",
    "FrameInputs",
    "Stacked",
    "WindowCache",
    "adjacent_view",
    "by_slices",
    "forget",
    "frame_slices",
    "stacked",
]

#: Frames of one slice where a derived array is computed piecewise (:func:`by_slices`): its
#: temporaries stay a few MiB however long the log (an hour at 1 kHz is 3.6e6 frames).
SLICE_FRAMES = 1 << 18


def by_slices(n_frames: int, dtype, fill) -> NDArray:
    """A per-frame array of ``n_frames``, filled slice by slice of :data:`SLICE_FRAMES` frames.

    ``fill(a, b)`` returns frames ``a`` to ``b - 1``, in order, so it may carry a state from one
    slice to the next. Elementwise work gives the bits of the whole computation, with whole-length
    temporaries never built.
    """
    out = np.empty(n_frames, dtype=dtype)
    for s in frame_slices(n_frames):
        out[s] = fill(s.start, s.stop)
    return out


def frame_slices(n_frames: int) -> Iterator[slice]:
    """Consecutive slices of ``n_frames`` frames, :data:`SLICE_FRAMES` long (the last shorter)."""
    step = max(int(SLICE_FRAMES), 1)  # read when called: a test may shorten it
    for a in range(0, n_frames, step):
        yield slice(a, min(a + step, n_frames))


class WindowCache(dict):
    """The derived arrays of a window of frames: the whole inputs' arrays, sliced.

    A derived array may look back (a speed over the last frames) or ahead (a trajectory's first
    motion), so a window cannot compute its own: whatever it reads must have been computed on
    the whole inputs first, and asking for anything else is a programming error, not a result.
    """

    def __init__(self, whole: dict, start: int, stop: int, n_frames: int):
        super().__init__()
        for key, value in whole.items():
            per_frame = isinstance(value, np.ndarray) and value.ndim and value.shape[0] == n_frames
            self[key] = value[start:stop] if per_frame else value
        self.bounds = (start, stop)

    def refuse(self, key: str):
        raise RuntimeError(
            f"the derived array {key!r} was not computed on the whole inputs before frames "
            f"{self.bounds[0]}-{self.bounds[1]} were read as a window"
        )


class FrameInputs:
    """Mixin of a family's inputs, a frozen dataclass with the fields ``reset``, ``dt`` and ``cache``.

    ``reset`` (bool, shape (T,)) is True on the first frame of each trajectory, ``dt`` the
    sample period [s], ``cache`` a dict (``field(default_factory=dict, init=False)``);
    :attr:`frame_fields` names the fields that hold one value per frame.
    """

    #: The fields with one entry per frame (cut by :meth:`subset`, joined by :meth:`concat`).
    frame_fields: ClassVar[tuple[str, ...]] = ("reset",)

    reset: NDArray
    dt: float
    cache: dict

    @property
    def n_frames(self) -> int:
        """int : Frames ``T``."""
        return int(self.reset.shape[0])

    def memo(self, key: str, compute):
        """``compute()`` once per key: derived arrays read on every evaluation of a model (wraps, speeds)."""
        if key not in self.cache:
            if isinstance(self.cache, WindowCache):
                self.cache.refuse(key)
            self.cache[key] = compute()
        return self.cache[key]

    def has(self, signal: str) -> bool:
        """Whether the optional per-frame array ``signal`` is present (not None)."""
        return getattr(self, signal, None) is not None

    @property
    def first_frame(self) -> NDArray[np.integer]:
        """ndarray of int, shape (T,) : Index of the first frame of each frame's trajectory.

        int32 where the frames fit in it (an hour at 1 kHz is 3.6e6), else int64: it is kept.
        """
        last = 0  # the first frame of the trajectory running into the slice

        def fill(a, b):
            nonlocal last
            out = np.maximum.accumulate(np.where(self.reset[a:b], np.arange(a, b), last))
            last = int(out[-1])
            return out

        dtype = np.int32 if self.n_frames < 2**31 else np.int64
        return self.memo("first_frame", lambda: by_slices(self.n_frames, dtype, fill))

    @property
    def since_start(self) -> NDArray[np.float64]:
        """ndarray, shape (T,) : Time since the start of each frame's trajectory [s].

        Computed at each read, not kept: what reads it (a warm-up's mask) reads it once, and a
        float per frame is as much as a signal. A window (:meth:`window`) counts from the whole's
        frame indices.
        """
        first = self.first_frame
        offset = self.cache.bounds[0] if isinstance(self.cache, WindowCache) else 0
        return by_slices(self.n_frames, float, lambda a, b: (np.arange(offset + a, offset + b) - first[a:b]) * self.dt)

    @property
    def trajectory_bounds(self) -> list[tuple[int, int]]:
        """``(start, end)`` frame indices of each trajectory, in order."""
        starts = np.flatnonzero(self.reset)
        return list(zip(starts.tolist(), starts[1:].tolist() + [self.n_frames]))

    def subset(self, mask: NDArray):
        """The frames of ``mask`` (whole trajectories), as new inputs; the first of them starts a trajectory."""
        cut = {f: None if getattr(self, f) is None else getattr(self, f)[mask] for f in self.frame_fields}
        if cut["reset"].size:
            cut["reset"][0] = True
        return dataclasses.replace(self, **cut)

    def part(self, start: int, stop: int):
        """Frames ``start`` to ``stop - 1``, whole trajectories, as inputs of views with derived arrays of their own.

        A split of a diagnosis by file is such a part of all the files' inputs: no copy of its signals.

        Raises
        ------
        ValueError
            If ``start`` is not a trajectory's first frame.
        """
        if start < stop and not self.reset[start]:
            raise ValueError(f"frame {start} does not start a trajectory: a part holds whole trajectories")
        cut = {f: None if getattr(self, f) is None else getattr(self, f)[start:stop] for f in self.frame_fields}
        for view in cut.values():
            if view is not None:
                view.flags.writeable = False  # parts share the whole's memory: none may write to another
        return dataclasses.replace(self, **cut)

    def held_out(self, start: int, stop: int):
        """``(rest, held)``: frames ``start`` to ``stop - 1`` as a :meth:`part`, and the others.

        The others are a part too where the held-out frames are at an end, else the two parts as
        a :class:`Stacked`, copied into one only when read (:func:`stacked`): a fold of a blocked
        cross-validation whose training set exists only while it is fitted.
        """
        rest = [p for p in (self.part(0, start), self.part(stop, self.n_frames)) if p.n_frames]
        return (Stacked(tuple(rest)) if len(rest) > 1 else type(self).concat(rest)), self.part(start, stop)

    def forget(self) -> None:
        """Drop the derived arrays (:meth:`memo`): they are computed again when next read.

        A diagnosis forgets a split's after each refit, so that its splits do not keep a few
        bytes per frame each for the whole run.
        """
        self.cache.clear()

    def window(self, start: int, stop: int):
        """Frames ``start`` to ``stop - 1`` as inputs of views, without copies.

        Its derived arrays are the whole inputs' (:class:`WindowCache`): compute them on the whole
        first; frame indices in them (``first_frame``) stay the whole's. ``reset[start]`` is as
        it is: a window that starts inside a trajectory continues it, and what carries over (a
        play operator's output) is the caller's to pass on. The streamed evaluation of a passage
        model (:mod:`tendon_id.zoo.passage.model`) reads so.
        """
        cut = {f: None if getattr(self, f) is None else getattr(self, f)[start:stop] for f in self.frame_fields}
        out = dataclasses.replace(self, **cut)
        object.__setattr__(out, "cache", WindowCache(self.cache, start, stop, self.n_frames))
        return out

    @classmethod
    def concat(cls, parts: Sequence[FrameInputs]):
        """Inputs stacked in time (each part's trajectories kept apart); a per-frame array missing in one is None."""
        if len(parts) == 1:
            return parts[0]

        def joined(name):
            arrays = [getattr(p, name) for p in parts]
            if any(a is None for a in arrays):
                return None
            adjacent = adjacent_view(arrays)
            return np.concatenate(arrays) if adjacent is None else adjacent

        return dataclasses.replace(parts[0], **{f: joined(f) for f in cls.frame_fields})


@dataclasses.dataclass(frozen=True)
class Stacked:
    """Parts of one inputs (:meth:`FrameInputs.part`), to be stacked in time when read.

    The training set of a fold whose held-out frames lie in the middle is two parts; stacking
    them is a copy of most of the data, so it is made by :func:`stacked` for the refit that reads
    it and freed with it, not kept for the whole diagnosis.
    """

    parts: tuple

    @property
    def n_frames(self) -> int:
        """int : Frames ``T`` the stacked inputs will have."""
        return sum(p.n_frames for p in self.parts)


def stacked(inputs):
    """``inputs`` as a family's inputs: a :class:`Stacked` is stacked now (a copy), anything else is returned."""
    return type(inputs.parts[0]).concat(list(inputs.parts)) if isinstance(inputs, Stacked) else inputs


def forget(*inputs) -> None:
    """Drop the derived arrays of each of ``inputs`` that keeps them (:meth:`FrameInputs.forget`).

    A family's own inputs need not be :class:`FrameInputs`; those that keep nothing are left as they are.
    """
    for x in inputs:
        if isinstance(x, FrameInputs):
            x.forget()


def adjacent_view(arrays: Sequence[NDArray]) -> NDArray | None:
    """The view that ``arrays``, consecutive slices along axis 0 of one array, make together, else None.

    Parts cut from one whole (:meth:`FrameInputs.part`) and stacked back in order are that whole:
    the view costs nothing where :func:`numpy.concatenate` would copy it. Read-only if any part is.
    """
    first = arrays[0]
    base = first.base
    step = first.strides[0] if first.ndim else 0
    same = all(isinstance(a, np.ndarray) and a.base is base and a.strides == first.strides for a in arrays)
    if not isinstance(base, np.ndarray) or not same or step <= 0 or base.strides != first.strides:
        return None
    if any(a.shape[1:] != base.shape[1:] or a.dtype != base.dtype for a in arrays):
        return None
    ptr = [a.__array_interface__["data"][0] for a in arrays]
    if any(p + len(a) * step != q for p, a, q in zip(ptr, arrays, ptr[1:])):
        return None
    offset, rest = divmod(ptr[0] - base.__array_interface__["data"][0], step)
    if rest or offset < 0:
        return None
    out = base[offset : offset + sum(len(a) for a in arrays)]
    if not all(a.flags.writeable for a in arrays):
        out.flags.writeable = False
    return out
