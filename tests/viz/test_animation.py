"""Animations of one run (``tumblemc.viz.animation`` and ``tumblemc.viz.scene``)."""

from __future__ import annotations

from io import BytesIO
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import pytest
import xarray as xr
from matplotlib.animation import AbstractMovieWriter
from matplotlib.figure import Figure
from PIL import Image

import tumblemc
from tumblemc.cli import main
from tumblemc.model.frames import plane_frame
from tumblemc.model.shapes.library import SHAPES, get_shape
from tumblemc.viz import animation, scene
from tumblemc.viz.animation import animate_result, animate_run, render_frame


@pytest.fixture(scope="module")
def flat_run() -> xr.Dataset:
    return tumblemc.simulate(duration_s=0.1, freq_hz=10.0)


@pytest.fixture(scope="module")
def inclined_curved_run() -> xr.Dataset:
    assert "curved" in SHAPES
    return tumblemc.simulate("curved", incline_deg=20.0, duration_s=0.1, freq_hz=10.0)


def _gif_frames(path: Path) -> tuple[int, tuple[int, int], list[int]]:
    """Frame count, size and per-frame delays (ms) of a GIF, read back with Pillow."""
    with Image.open(path) as im:
        assert im.format == "GIF"
        n = int(getattr(im, "n_frames", 1))
        durations = []
        for k in range(n):
            im.seek(k)
            durations.append(int(im.info["duration"]))
        return n, im.size, durations


def _slide(ds: xr.Dataset, distance_m: float) -> xr.Dataset:
    """``ds`` with a uniform downhill drift of ``distance_m`` added over the run.

    A robot that slides metres, without simulating one.
    """
    u = plane_frame(float(ds.attrs["incline_deg"]))["u"]
    t = ds["time"].values
    shift = -distance_m * (t - t[0]) / (t[-1] - t[0])
    out = ds.copy(deep=True)
    out["position"].values += shift[:, None] * u
    out["ecp"].values += shift[:, None] * u
    out["progress"].values += shift
    return out


def test_gif_cuboid_flat(flat_run: xr.Dataset, tmp_path: Path) -> None:
    out = animate_run(flat_run, tmp_path / "cuboid.gif", max_frames=10, dpi=50)
    assert out == tmp_path / "cuboid.gif" and out.is_file()
    n, size, durations = _gif_frames(out)
    assert n == 10
    assert size == (400, 300)
    assert durations == [40] * 10  # default fps 25


def test_gif_other_shape_inclined(inclined_curved_run: xr.Dataset, tmp_path: Path) -> None:
    out = animate_run(inclined_curved_run, tmp_path / "curved.GIF", max_frames=7, dpi=40, trail=False)
    n, size, _ = _gif_frames(out)
    assert n == 7
    assert size == (320, 240)


def test_speed_sets_the_frame_delays(flat_run: xr.Dataset, tmp_path: Path) -> None:
    # 0.1 s simulated at 0.02 simulated s per wall s: 5 s of animation; 25 fps would need
    # 126 frames, at most 8 are allowed, so the frame rate drops to 7 / 5 s
    out = animate_run(flat_run, tmp_path / "slow.gif", max_frames=8, speed=0.02, dpi=30)
    n, _, durations = _gif_frames(out)
    assert n == 8
    assert sum(durations[:-1]) == pytest.approx(5000.0, abs=10.0)
    assert max(durations) - min(durations) <= 10
    # fast: a few frames suffice, at the requested frame rate
    out = animate_run(flat_run, tmp_path / "fast.gif", max_frames=50, speed=1.0, fps=20, dpi=30)
    n, _, durations = _gif_frames(out)
    assert n == 3  # 0.1 s at 1 s/s and 20 fps: 2 intervals
    assert durations == [50, 50, 50]


def test_bad_suffix_and_arguments(flat_run: xr.Dataset, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    with pytest.raises(ValueError, match=r"suffix '\.png'.*allowed: \.gif, \.mp4"):
        animate_run(flat_run, tmp_path / "run.png")
    with pytest.raises(ValueError, match="suffix ''"):
        animate_run(flat_run, tmp_path / "run")
    monkeypatch.setattr(animation.FFMpegWriter, "isAvailable", classmethod(lambda cls: False))
    with pytest.raises(ValueError, match=r"ffmpeg is not available.*\.gif"):
        animate_run(flat_run, tmp_path / "run.mp4")
    for kw in ({"fps": 0}, {"speed": -1.0}, {"max_frames": 0}, {"dpi": 0}):
        with pytest.raises(ValueError, match="is not allowed"):
            animate_run(flat_run, tmp_path / "run.gif", **kw)  # type: ignore[arg-type]
    assert not list(tmp_path.iterdir())


class _FakeFFMpeg(AbstractMovieWriter):
    """Stands in for ffmpeg (not installed everywhere): keeps the frames as PNG bytes."""

    frames: ClassVar[list[bytes]] = []

    @classmethod
    def isAvailable(cls) -> bool:
        return True

    def setup(self, fig: Any, outfile: Any, dpi: float | None = None) -> None:
        super().setup(fig, outfile, dpi=dpi)
        type(self).frames = []

    def grab_frame(self, **savefig_kwargs: Any) -> None:
        buf = BytesIO()
        self.fig.savefig(buf, format="png", dpi=self.dpi)
        type(self).frames.append(buf.getvalue())

    def finish(self) -> None:
        Path(self.outfile).write_bytes(b"fake mp4")


def test_mp4_path_draws_every_frame(flat_run: xr.Dataset, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(animation, "FFMpegWriter", _FakeFFMpeg)
    out = animate_run(flat_run, tmp_path / "run.mp4", max_frames=4, dpi=30)
    assert out.read_bytes() == b"fake mp4"
    assert len(_FakeFFMpeg.frames) == 4
    assert len(set(_FakeFFMpeg.frames)) == 4  # the frames differ (time stamp, body, window)


def test_animate_result_reads_cli_netcdf(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    nc = tmp_path / "run.nc"
    assert main(["simulate", "--duration-s", "0.05", "--freq-hz", "10", "--incline-deg", "10", "--out", str(nc)]) == 0
    capsys.readouterr()
    out = animate_result(nc, tmp_path / "run.gif", max_frames=5, dpi=30)
    assert _gif_frames(out)[0] == 5
    with pytest.raises(ValueError, match="suffix"):
        animate_result(nc, tmp_path / "run.avi")


def test_frame_indices_uniform_in_time() -> None:
    t = np.linspace(0.0, 1.0, 1001)
    idx = animation._frame_indices(t, 11)
    assert idx.tolist() == list(range(0, 1001, 100))
    assert animation._frame_indices(t, 5000).tolist() == list(range(1001))
    assert animation._frame_indices(t, 1).tolist() == [0]


@pytest.mark.parametrize("distance_m", [0.0, 3.0])
def test_window_keeps_the_body_in_view(flat_run: xr.Dataset, distance_m: float) -> None:
    ds = _slide(flat_run, distance_m)
    idx = animation._frame_indices(ds["time"].values, 40)
    shp = get_shape("cuboid")
    d = scene.frames_data(ds, shp, idx)
    length_um = float(np.ptp(np.asarray(shp.outline)[:, 0])) * 1e6
    for k, poly in enumerate(d["polys"]):
        (x0, x1), (y0, y1) = d["xlim"][k], d["ylim"][k]
        assert x0 < poly[:, 0].min() and poly[:, 0].max() < x1
        assert y0 < poly[:, 1].min() and poly[:, 1].max() < y1
        assert 2.5 * length_um < x1 - x0 < 5 * length_um  # a few body lengths: readable
    assert d["mm"] is (distance_m > 0)


def test_render_frame_png(inclined_curved_run: xr.Dataset, tmp_path: Path) -> None:
    fig = render_frame(inclined_curved_run, 100, tmp_path / "frame.png", dpi=40)
    assert isinstance(fig, Figure)
    with Image.open(tmp_path / "frame.png") as im:
        assert im.size == (320, 240)
    with pytest.raises(IndexError):
        render_frame(inclined_curved_run, 10**6)
