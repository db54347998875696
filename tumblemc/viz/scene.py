"""The side view of one run that the animations draw, frame by frame (viz layer).

:func:`frames_data` turns a run Dataset into what is drawn at each selected record;
:class:`Scene` builds the figure once and updates its artists per frame. Nothing here
touches pyplot: the figure is a :class:`matplotlib.figure.Figure` on its own Agg canvas.
:mod:`tumblemc.viz.animation` chooses the frames and writes them as a GIF or an MP4.

The view is the plane's frame: ``s`` (uphill distance along the plane, from the centre
of mass at ``time[0]``) to the right and ``h`` (height above the plane) up, so the
substrate is always horizontal and equal lengths look equal; a small arrow ``g`` gives the
true vertical, i.e. shows the incline. The window follows the robot: a fixed size of about
three body diameters, centred on the centre of mass averaged over one field period (the
robot is seen tumbling forward inside a window that glides smoothly), always containing
the whole body. The same window works for a robot that climbs a few mm and for one that
slides down metres; the overall motion is read from the progress text and the small
progress-versus-time panel under the side view.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import xarray as xr
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import FancyArrowPatch, Polygon
from matplotlib.ticker import FuncFormatter
from PIL import Image

from tumblemc.model.frames import plane_frame, quat_to_matrix
from tumblemc.model.params import magnetisation_dir
from tumblemc.model.shapes.types import Shape
from tumblemc.viz.run import MODE_LABELS, UM, run_label, side_view_outline

#: travel (m) above which lengths along the plane are written in mm instead of µm
MM_ABOVE_M = 20e-3


#: largest offset of the window's centre from the centre of mass, in window widths
DEAD_ZONE = 0.15


#: lowest point of the body above the plane, in body diameters, to call it "in flight"
FLIGHT_GAP = 2e-3


#: most points of the centre-of-mass trail
TRAIL_POINTS = 5000


_BODY_FACE = "#b8cde0"


_FIELD_COLOR = "C2"


_MAG_COLOR = "C4"


_MODE_COLORS = ("0.45", "C1", "C3")  # none, point/line, face


_FIG_SIZE_IN = (8.0, 6.0)


_TAG_BOX = {"boxstyle": "round,pad=0.1", "facecolor": "white", "edgecolor": "none", "alpha": 0.75}


def _centred_mean(t: np.ndarray, y: np.ndarray, at: np.ndarray, period: float) -> np.ndarray:
    """Mean of ``y(t)`` over ``[at - w, at + w]``.

    ``w = period / 2``, shrunk at the ends so that the interval stays symmetric (no lag,
    no end bias).
    """
    if len(t) < 2 or not period > 0:
        return np.interp(at, t, y)
    cum = np.concatenate([[0.0], np.cumsum(0.5 * (y[1:] + y[:-1]) * np.diff(t))])
    half = np.minimum.reduce([np.full_like(at, 0.5 * period), at - t[0], t[-1] - at])
    lo, hi = at - half, at + half
    ok = half > 1e-12 * max(period, 1.0)
    mean = np.interp(at, t, y)
    mean[ok] = (np.interp(hi[ok], t, cum) - np.interp(lo[ok], t, cum)) / (hi[ok] - lo[ok])
    return mean


def _magnetisation_body(attrs: dict[str, Any]) -> np.ndarray | None:
    """Body-frame unit magnetisation from the run's attrs (see Params.magnetisation_dir)."""
    if "offset_deg" not in attrs:
        return None
    k = np.asarray(attrs.get("offset_axis", (1.0, 0.0, 0.0)), dtype=float).reshape(3)
    return magnetisation_dir(float(attrs["offset_deg"]), k / np.linalg.norm(k))


def _length_text(x_m: float, mm: bool) -> str:
    return f"{x_m * 1e3:+.3f} mm" if mm else f"{x_m * UM:+.1f} µm"


def frames_data(ds: xr.Dataset, shp: Shape, idx: np.ndarray) -> dict[str, Any]:
    """Everything drawn per frame, in µm, and the moving window of each frame.

    Parameters
    ----------
    ds : Dataset
        A run from :func:`tumblemc.simulate` (at least ``time``, ``position`` and
        ``quaternion``; ``ecp``, ``field``, ``contact_mode``, ``adhesion_force`` and
        ``progress`` are drawn when present).
    shp : Shape
        The run's shape.
    idx : (k,) int array
        The records drawn, in increasing order.

    Returns
    -------
    dict
        Per frame (first axis ``k``): ``polys`` (body outlines), ``cm``, ``ecp``,
        ``field``, ``mag``, ``mode``, ``adhesion``, the window ``xlim``/``ylim``; per
        record: ``t``, ``progress``; and the trail, the body diameter ``diam`` and the
        run's settings used by :class:`Scene`.
    """
    attrs = ds.attrs
    t = ds["time"].values.astype(float)
    fr = plane_frame(float(attrs.get("incline_deg", 0.0)))
    u, nrm = fr["u"], fr["n"]
    pos = ds["position"].values.astype(float)
    s_cm = (pos - pos[0]) @ u
    h_cm = pos @ nrm
    outlines = [side_view_outline(ds, shp, int(i)) for i in idx]
    polys = [np.column_stack([s, h]) * UM for s, h in outlines]
    # window: about three body diameters wide, half as high
    outline = np.asarray(shp.outline, dtype=float)
    diam = 2.0 * float(np.max(np.hypot(outline[:, 0], outline[:, 1]))) * UM
    width, height, margin = 3.0 * diam, 1.5 * diam, 0.08 * diam
    freq = float(attrs.get("freq_hz", 0.0))
    field_on = float(attrs.get("field_mT", 1.0)) != 0.0 and freq > 0
    # centre: the centre of mass averaged over a field period (tumbling is smoothed out),
    # kept within DEAD_ZONE window widths of the centre of mass (an accelerating slide
    # biases the average), then shifted where needed so that the whole body is inside
    period = 1.0 / freq if field_on else 0.0
    sc = _centred_mean(t, s_cm, t[idx], period) * UM
    hc = _centred_mean(t, h_cm, t[idx], period) * UM
    sc = np.clip(sc, s_cm[idx] * UM - DEAD_ZONE * width, s_cm[idx] * UM + DEAD_ZONE * width)
    hc = np.clip(hc, h_cm[idx] * UM - DEAD_ZONE * width, h_cm[idx] * UM + DEAD_ZONE * width)
    smin = np.array([p[:, 0].min() for p in polys])
    smax = np.array([p[:, 0].max() for p in polys])
    hmin = np.array([p[:, 1].min() for p in polys])
    hmax = np.array([p[:, 1].max() for p in polys])
    xc = np.clip(sc, smax + margin - 0.5 * width, smin - margin + 0.5 * width)
    y0 = np.maximum(-0.3 * diam, hc - 0.5 * height)  # fixed unless the robot flies high
    y0 = np.clip(y0, hmax + margin - height, hmin - margin)
    ecp = ds["ecp"].values.astype(float)[idx] if "ecp" in ds else np.full((len(idx), 3), np.nan)
    R = quat_to_matrix(ds["quaternion"].values[idx])
    field = ds["field"].values.astype(float)[idx] if "field" in ds else np.full((len(idx), 3), np.nan)
    e_b = _magnetisation_body(attrs)
    mag = None if e_b is None else R @ e_b
    prog = ds["progress"].values.astype(float) if "progress" in ds else s_cm
    step = max(1, -(-len(t) // TRAIL_POINTS))
    trail_idx = np.arange(0, len(t), step)
    return {
        "t": t,
        "idx": idx,
        "polys": polys,
        "cm": np.column_stack([s_cm[idx], h_cm[idx]]) * UM,
        "ecp": np.column_stack([(ecp - pos[0]) @ u, ecp @ nrm]) * UM,
        "field": np.column_stack([field @ u, field @ nrm]),
        "mag": None if mag is None else np.column_stack([mag @ u, mag @ nrm]),
        "mode": ds["contact_mode"].values[idx].astype(int) if "contact_mode" in ds else np.zeros(len(idx), int),
        "adhesion": ds["adhesion_force"].values.astype(float)[idx] if "adhesion_force" in ds else np.zeros(len(idx)),
        "progress": prog,
        "trail_idx": trail_idx,
        "trail": np.column_stack([s_cm[trail_idx], h_cm[trail_idx]]) * UM,
        "xlim": np.column_stack([xc - 0.5 * width, xc + 0.5 * width]),
        "ylim": np.column_stack([y0, y0 + height]),
        "diam": diam,
        "mm": bool(np.max(np.abs(prog), initial=0.0) > MM_ABOVE_M),
        "freq": freq,
        "field_on": field_on,
        "incline": float(attrs.get("incline_deg", 0.0)),
        "g_dir": np.array([-fr["u"][2], -fr["n"][2]]),  # world -z in (s, h)
    }


class Scene:
    """The figure of an animation and the artists updated at each frame.

    Parameters
    ----------
    ds : Dataset
        The run (its attributes give the title).
    data : dict
        :func:`frames_data` of the run.
    trail : bool
        Draw the path of the centre of mass up to the current instant.
    dpi : float
        Resolution of the figure (800 x 600 pixels at 100).
    """

    def __init__(self, ds: xr.Dataset, data: dict[str, Any], trail: bool, dpi: float = 100.0) -> None:
        self.d = d = data
        fig = Figure(figsize=_FIG_SIZE_IN, dpi=dpi)
        self.canvas = FigureCanvasAgg(fig)
        self.fig = fig
        self._background: Any = None
        fig.text(0.5, 0.988, run_label(ds), ha="center", va="top", fontsize=9, color="0.25")
        row1, row2 = 0.935, 0.897
        self.txt_time = fig.text(0.09, row1, "", ha="left", va="center", fontsize=10.5)
        self.txt_prog = fig.text(0.96, row1, "", ha="right", va="center", fontsize=10.5, weight="bold")
        self.txt_contact = fig.text(0.09, row2, "", ha="left", va="center", fontsize=10.5)
        self.txt_adh = fig.text(0.96, row2, "", ha="right", va="center", fontsize=10.5)
        ax = fig.add_axes((0.09, 0.36, 0.87, 0.51))
        self.ax = ax
        ax.set_aspect("equal", adjustable="box")
        ax.set_xlim(*d["xlim"][0])
        ax.set_ylim(*d["ylim"][0])
        self.plane_note = ax.text(
            0.01,
            0.03,
            f"plane (incline {d['incline']:g}°), drawn horizontal; g: true vertical",
            transform=ax.transAxes,
            fontsize=7.5,
            color="0.3",
            ha="left",
            va="bottom",
            zorder=8,
        )
        unit = "mm" if d["mm"] else "µm"
        ax.xaxis.set_major_formatter(FuncFormatter(lambda x, _: f"{x / 1e3:g}" if d["mm"] else f"{x:g}"))
        ax.set_xlabel(f"uphill position s along the plane ({unit})", fontsize=9)
        ax.set_ylabel("height above plane (µm)", fontsize=9)
        ax.tick_params(labelsize=8)
        low = float(d["ylim"][:, 0].min()) - d["diam"]
        ax.axhspan(low, 0.0, facecolor="0.9", edgecolor="none", zorder=0)
        ax.axhline(0.0, color="0.3", lw=1.5, zorder=1)
        self.hatch = LineCollection([], colors="0.6", linewidths=0.8, zorder=0.5)
        ax.add_collection(self.hatch)
        self.trail = ax.plot([], [], color="0.55", lw=0.8, zorder=1.5)[0] if trail else None
        self.body = Polygon(d["polys"][0], closed=True, facecolor=_BODY_FACE, edgecolor="k", lw=1.0, zorder=3)
        ax.add_patch(self.body)
        self.cm = ax.plot([], [], "k+", ms=7, mew=1.2, zorder=5)[0]
        self.ecp = ax.plot([], [], "o", ms=8, mec="k", mew=0.8, zorder=6)[0]
        arrow: dict[str, Any] = {"arrowstyle": "-|>", "mutation_scale": 14, "lw": 2.0, "zorder": 4, "shrinkA": 0.0, "shrinkB": 0.0}
        self.b_arrow = FancyArrowPatch((0, 0), (1, 1), color=_FIELD_COLOR, **arrow)
        ax.add_patch(self.b_arrow)
        tag: dict[str, Any] = {"fontsize": 10, "weight": "bold", "ha": "center", "va": "center", "zorder": 7, "bbox": _TAG_BOX}
        self.b_label = ax.text(0, 0, "B", color=_FIELD_COLOR, **tag)
        self.m_arrow = self.m_label = None
        if d["mag"] is not None:
            self.m_arrow = FancyArrowPatch((0, 0), (1, 1), color=_MAG_COLOR, linestyle="--", **arrow)
            ax.add_patch(self.m_arrow)
            self.m_label = ax.text(0, 0, "m", color=_MAG_COLOR, **tag)
        gs, gh = d["g_dir"]
        ax.annotate(
            "g",
            xy=(0.965, 0.60),
            xycoords="axes fraction",
            xytext=(-30 * gs, -30 * gh),
            textcoords="offset points",
            ha="center",
            va="center",
            fontsize=9,
            arrowprops={"arrowstyle": "-|>", "color": "0.25", "lw": 1.2},
            zorder=8,
        )
        handles = [
            Line2D([], [], color=_FIELD_COLOR, lw=2, label="field B"),
            Line2D([], [], color="k", marker="+", ls="none", label="centre of mass"),
            Line2D([], [], color=_MODE_COLORS[2], marker="o", mec="k", ls="none", label="contact point (face)"),
            Line2D([], [], color=_MODE_COLORS[1], marker="o", mec="k", ls="none", label="contact point (point/line)"),
        ]
        if d["mag"] is not None:
            handles.insert(1, Line2D([], [], color=_MAG_COLOR, lw=2, ls="--", label="magnetisation m"))
        if trail:
            handles.append(Line2D([], [], color="0.55", lw=0.8, label="CM trail"))
        fig.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, 0.275), ncol=3, fontsize=8, frameon=False)
        # progress versus time, with the current instant
        axp = fig.add_axes((0.09, 0.06, 0.87, 0.12))
        t = d["t"]
        scale = 1e3 if d["mm"] else UM
        axp.plot(t, d["progress"] * scale, color="C0", lw=1.0)
        axp.axhline(0.0, color="0.7", lw=0.6)
        self.cursor = axp.axvline(t[0], color="C3", lw=0.8)
        self.cursor_dot = axp.plot([], [], "o", color="C3", ms=4)[0]
        axp.set_xlim(float(t[0]), float(t[-1]) if t[-1] > t[0] else float(t[0]) + 1.0)
        axp.set_xlabel("time (s)", fontsize=8, labelpad=1)
        axp.set_ylabel(f"progress ({unit})", fontsize=8)
        axp.tick_params(labelsize=7)
        axp.grid(True, alpha=0.3)
        self.axp = axp
        self.scale = scale
        sel = t[d["idx"]]
        dt_frame = float(np.mean(np.diff(sel))) if len(sel) > 1 else float(np.median(np.diff(t))) if len(t) > 1 else 0.0
        self.decimals = int(np.clip(math.ceil(-math.log10(dt_frame)) + 1, 1, 9)) if dt_frame > 0 else 3

    def _arrow(self, arrow: FancyArrowPatch, label: Any, base: np.ndarray, vec: np.ndarray, length: float, side: float) -> None:
        """Place an arrow of ``length`` diameters from ``base`` along ``vec``.

        Its label goes beside the tip (``side`` +1: to the left of the arrow, -1: to the
        right); a zero or non-finite ``vec`` hides both.
        """
        norm = float(np.hypot(*vec))
        if not np.isfinite(norm) or norm == 0.0:
            arrow.set_visible(False)
            label.set_visible(False)
            return
        e = vec / norm
        diam = self.d["diam"]
        tip = base + length * diam * e
        arrow.set_positions(tuple(base), tuple(tip))
        label.set_position(tuple(tip + 0.07 * diam * e + side * 0.07 * diam * np.array([-e[1], e[0]])))
        arrow.set_visible(True)
        label.set_visible(True)

    def update(self, k: int) -> None:
        """Draw frame ``k`` (an index into the selected records)."""
        d = self.d
        i = int(d["idx"][k])
        t = float(d["t"][i])
        (x0, x1), (y0, y1) = d["xlim"][k], d["ylim"][k]
        self.ax.set_xlim(x0, x1)
        self.ax.set_ylim(y0, y1)
        self.plane_note.set_visible(y0 < 0.0)
        # ground hatch at fixed places along the plane, so that the ground visibly moves
        pitch = 0.12 * d["diam"]
        xs = np.arange(math.floor(x0 / pitch) - 1, math.ceil(x1 / pitch) + 2) * pitch
        depth = 0.1 * d["diam"]
        self.hatch.set_segments([[(x, 0.0), (x - depth, -depth)] for x in xs])
        self.body.set_xy(d["polys"][k])
        cm = d["cm"][k]
        self.cm.set_data([cm[0]], [cm[1]])
        if self.trail is not None:
            m = int(np.searchsorted(d["trail_idx"], i, side="right"))
            tr = d["trail"][:m]
            self.trail.set_data(np.append(tr[:, 0], cm[0]), np.append(tr[:, 1], cm[1]))
        mode = int(d["mode"][k])
        ecp = d["ecp"][k]
        in_contact = bool(np.all(np.isfinite(ecp)))
        if in_contact:
            self.ecp.set_data([ecp[0]], [ecp[1]])
        else:
            self.ecp.set_data([], [])
        color = _MODE_COLORS[mode] if 0 <= mode < len(_MODE_COLORS) else "0.45"
        self.ecp.set_markerfacecolor(color)
        self._arrow(self.b_arrow, self.b_label, cm, d["field"][k], 0.45, 1.0)
        if self.m_arrow is not None:
            self._arrow(self.m_arrow, self.m_label, cm, d["mag"][k], 0.33, -1.0)
        phase = f"field phase {(360.0 * d['freq'] * t) % 360.0:.0f}°" if d["field_on"] else "field off"
        self.txt_time.set_text(f"t = {t:.{self.decimals}f} s   ({phase})")
        self.txt_prog.set_text(f"uphill progress s = {_length_text(float(d['progress'][i]), d['mm'])}")
        label = MODE_LABELS[mode] if 0 <= mode < len(MODE_LABELS) else str(mode)
        gap = float(d["polys"][k][:, 1].min())  # lowest point of the body above the plane
        flying = gap > FLIGHT_GAP * d["diam"]
        self.txt_contact.set_text(f"contact: {label}" if mode > 0 else f"contact: none{' (in flight)' if flying else ''}")
        self.txt_contact.set_color(color if mode > 0 else "0.2")
        adh = float(d["adhesion"][k])
        self.txt_adh.set_text(f"adhesion {adh:.2e} N" if adh > 0 else "adhesion off")
        self.txt_adh.set_color("C3" if adh > 0 else "0.2")
        self.cursor.set_xdata([t, t])
        self.cursor_dot.set_data([t], [float(d["progress"][i]) * self.scale])

    def _dynamic(self) -> list[Any]:
        return [self.ax, self.txt_time, self.txt_prog, self.txt_contact, self.txt_adh, self.cursor, self.cursor_dot]

    def render(self, k: int) -> Image.Image:
        """Frame ``k`` as an RGB image.

        The static parts (title, legend, progress panel) are drawn once and blitted; the
        side view and the texts are redrawn.
        """
        self.update(k)
        if self._background is None:
            for a in self._dynamic():
                a.set_animated(True)
            self.canvas.draw()
            self._background = self.canvas.copy_from_bbox(self.fig.bbox)
        self.canvas.restore_region(self._background)
        for a in self._dynamic():
            self.fig.draw_artist(a)
        return Image.fromarray(np.asarray(self.canvas.buffer_rgba())[..., :3])

    def close(self) -> None:
        """Free the figure's artists and the cached background."""
        self._background = None
        self.fig.clear()
