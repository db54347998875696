"""Animated side view of one run: a GIF, or an MP4 where ffmpeg is installed (viz layer).

:func:`animate_run` renders a :func:`tumblemc.simulate` Dataset frame by frame;
:func:`animate_result` does the same for a netCDF file written by
``tumblemc simulate --out run.nc``; :func:`render_frame` gives one frame as a Figure.
This module picks the frames (records nearest to instants uniform in time, at the frame
rate or simulated speed asked for) and writes the file; what a frame shows, and the
window that follows the robot, are in :mod:`tumblemc.viz.scene`. Like the other figures
of :mod:`tumblemc.viz`, nothing here touches pyplot.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from matplotlib.animation import FFMpegWriter
from matplotlib.figure import Figure
from PIL import Image

from tumblemc.model.shapes.types import Shape
from tumblemc.viz.run import shape_of
from tumblemc.viz.scene import Scene, frames_data

#: output formats by suffix
SUFFIXES = (".gif", ".mp4")


#: GIF frame delays are whole centiseconds and viewers slow delays under 20 ms down to
#: 100 ms, so a GIF never runs faster than this many frames per second
GIF_MAX_FPS = 50.0


def _check_suffix(path: Path) -> str:
    suffix = path.suffix.lower()
    if suffix not in SUFFIXES:
        raise ValueError(f"path={str(path)!r} has suffix {path.suffix!r}, which is not allowed (allowed: {', '.join(SUFFIXES)})")
    if suffix == ".mp4" and not FFMpegWriter.isAvailable():
        raise ValueError(f"path={str(path)!r} asks for MP4 but ffmpeg is not available on this machine; write a GIF instead (suffix .gif)")
    return suffix


def _frame_indices(t: np.ndarray, count: int) -> np.ndarray:
    """Indices of the records nearest to ``count`` instants uniform in ``[t[0], t[-1]]``."""
    n = len(t)
    if count >= n:
        return np.arange(n)
    if count == 1:
        return np.array([0])
    target = np.linspace(t[0], t[-1], count)
    j = np.clip(np.searchsorted(t, target), 1, n - 1)
    j = np.where(target - t[j - 1] <= t[j] - target, j - 1, j)
    return np.unique(j)


def _timing(t: np.ndarray, fps: float, speed: float | None, max_frames: int, fps_cap: float) -> tuple[int, float, float]:
    """Frame count, frame rate and speed (simulated s per wall s) of the animation."""
    n = len(t)
    span = float(t[-1] - t[0])
    rate = min(fps, fps_cap)
    if speed is None:
        count = min(max_frames, n)
    else:
        count = min(max_frames, n, max(2, math.floor(span / speed * rate) + 1))
    if count < 2 or span <= 0.0:
        return 1, rate, float("nan")
    if speed is not None:
        rate = (count - 1) * speed / span
    return count, rate, span / (count - 1) * rate


def _gif_durations_ms(count: int, fps: float) -> list[int]:
    """Frame delays in ms, multiples of 10 as a GIF stores them.

    Their running sum follows ``k / fps`` as closely as centiseconds allow, so that the
    speed is right on average.
    """
    ends = np.round(np.arange(1, count + 1) * 100.0 / fps) * 10.0
    return [int(v) for v in np.diff(np.concatenate([[0.0], ends]))]


def _write_gif(scene: Scene, count: int, fps: float, out: Path) -> None:
    frames = [scene.render(k).quantize(colors=256, method=Image.Quantize.FASTOCTREE, dither=Image.Dither.NONE) for k in range(count)]
    frames[0].save(out, save_all=True, append_images=frames[1:], duration=_gif_durations_ms(count, fps), loop=0)


def _write_mp4(scene: Scene, count: int, fps: float, out: Path, dpi: float) -> None:
    writer = FFMpegWriter(fps=fps, codec="libx264")  # type: ignore[arg-type]  # ffmpeg takes a non-integer rate
    with writer.saving(scene.fig, str(out), dpi):
        for k in range(count):
            scene.update(k)
            writer.grab_frame()


def animate_run(
    ds: xr.Dataset,
    path: str | os.PathLike[str],
    *,
    fps: float = 25,
    speed: float | None = None,
    max_frames: int = 300,
    dpi: int = 100,
    trail: bool = True,
    shape: str | Shape | None = None,
) -> Path:
    """Write an animated side view of one run: a GIF, or an MP4 (needs ffmpeg).

    Each frame shows, in the plane's frame (plane horizontal, uphill to the right, equal
    aspect, a window about three body diameters wide that follows the robot): the body
    outline, its centre of mass and its trail, the field direction ``B`` and the body's
    magnetisation ``m`` as arrows from the centre of mass, the equivalent contact point
    (a dot coloured by contact mode, hidden in flight), the true vertical ``g``; above it
    the time and field phase, the uphill progress and the contact mode with the adhesion
    force; under it the progress versus time with the current instant.

    Parameters
    ----------
    ds : xarray.Dataset
        A run from :func:`tumblemc.simulate` (or read back from its netCDF file).
    path : path-like
        Output file; the suffix picks the format: ``.gif`` (Pillow, always available) or
        ``.mp4`` (ffmpeg must be installed).
    fps : float
        Frames per wall-clock second (at most 50 for a GIF, whose delays are centiseconds).
    speed : float, optional
        Simulated seconds per wall-clock second. ``None`` (default): the animation lasts
        ``frames / fps`` seconds. Given, the frame rate is lowered where ``max_frames``
        would not suffice, so the speed is always the one asked for.
    max_frames : int
        Most frames; they are the records nearest to instants uniform in time (all the
        records if there are fewer).
    dpi : int
        Resolution: the frames are ``800 x 600`` pixels at ``dpi=100``.
    trail : bool
        Draw the path of the centre of mass up to the current instant.
    shape : str or Shape, optional
        The run's shape; needed only for a shape built with non-default dimensions (the
        Dataset stores the shape's name).

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    ValueError
        For a suffix other than ``.gif`` or ``.mp4``, an MP4 without ffmpeg, a Dataset
        without records or a non-positive ``fps``, ``speed``, ``max_frames`` or ``dpi``.
    """
    out = Path(path)
    suffix = _check_suffix(out)
    if not (np.isfinite(fps) and fps > 0):
        raise ValueError(f"fps={fps!r} is not allowed (allowed: a positive number)")
    if speed is not None and not (np.isfinite(speed) and speed > 0):
        raise ValueError(f"speed={speed!r} is not allowed (allowed: None or a positive number of simulated s per wall s)")
    if int(max_frames) != max_frames or max_frames < 1:
        raise ValueError(f"max_frames={max_frames!r} is not allowed (allowed: an integer >= 1)")
    if not dpi > 0:
        raise ValueError(f"dpi={dpi!r} is not allowed (allowed: a positive number)")
    if ds.sizes.get("time", 0) < 1:
        raise ValueError("animate_run needs a Dataset with at least one time record")
    t = ds["time"].values.astype(float)
    cap = GIF_MAX_FPS if suffix == ".gif" else math.inf
    count, rate, _ = _timing(t, float(fps), speed, int(max_frames), cap)
    idx = _frame_indices(t, count)
    scene = Scene(ds, frames_data(ds, shape_of(ds, shape), idx), trail, dpi)
    try:
        if suffix == ".gif":
            _write_gif(scene, len(idx), rate, out)
        else:
            _write_mp4(scene, len(idx), rate, out, dpi)
    finally:
        scene.close()
    return out


def animate_result(path_nc: str | os.PathLike[str], out: str | os.PathLike[str], **kw: Any) -> Path:
    """Animate a run saved by ``tumblemc simulate --out run.nc``.

    Parameters
    ----------
    path_nc : path-like
        The netCDF file of one run.
    out : path-like
        The animation to write (``.gif`` or ``.mp4``).
    **kw
        Keyword arguments of :func:`animate_run` (``fps``, ``speed``, ``max_frames``,
        ``dpi``, ``trail``, ``shape``).

    Returns
    -------
    pathlib.Path
        ``out``.
    """
    _check_suffix(Path(out))  # fail before reading the file
    with xr.open_dataset(path_nc) as ds:
        ds.load()
        return animate_run(ds, out, **kw)


def render_frame(
    ds: xr.Dataset,
    i: int = -1,
    path: str | os.PathLike[str] | None = None,
    *,
    dpi: int = 100,
    trail: bool = True,
    shape: str | Shape | None = None,
) -> Figure:
    """One frame of :func:`animate_run` at record ``i`` as a Figure (saved if ``path``).

    Parameters
    ----------
    ds : xarray.Dataset
        A run from :func:`tumblemc.simulate`.
    i : int
        Index along ``time`` (negative counts from the end).
    path : path-like, optional
        Where to save the frame (any matplotlib format, e.g. PNG).
    dpi : int
        Resolution of the saved frame.
    trail, shape
        As in :func:`animate_run`.

    Returns
    -------
    matplotlib.figure.Figure
        A figure not registered with pyplot.
    """
    n = ds.sizes.get("time", 0)
    if not -n <= i < n:
        raise IndexError(f"i={i} is out of range for a run of {n} records")
    idx = np.array([i % n])
    scene = Scene(ds, frames_data(ds, shape_of(ds, shape), idx), trail, dpi)
    scene.update(0)
    if path is not None:
        scene.fig.savefig(path, dpi=dpi)
    return scene.fig
