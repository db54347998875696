"""Figures of one run and of the shape library (viz layer).

Matplotlib without pyplot state: every function builds its own
:class:`matplotlib.figure.Figure`, so it is safe under Agg, in threads and in tests.

:func:`plot_run` draws the standard three-panel summary of a :func:`tumblemc.simulate`
Dataset; :func:`plot_shapes` draws the shape library; :func:`side_view_outline` gives the
robot's outline in plane coordinates at one recorded instant (reused by the animations of
:mod:`tumblemc.viz.scene`).

Plane coordinates: ``s = p . u`` (uphill distance along the plane) and ``h = p . n``
(height above the plane), with ``u`` and ``n`` from :func:`tumblemc.model.frames.plane_frame`.
The robot tumbles about world x (= the plane's tangent ``t``), so the body's y-z outline
projects onto the (s, h) plane without distortion.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from typing import Any

import numpy as np
import xarray as xr
from matplotlib.collections import PolyCollection
from matplotlib.colors import Normalize
from matplotlib.figure import Figure

from tumblemc.analysis.words import verdict_name
from tumblemc.model.frames import plane_frame, quat_to_matrix
from tumblemc.model.shapes.library import SHAPES, get_shape
from tumblemc.model.shapes.types import Shape
from tumblemc.model.step_check import StepCheck
from tumblemc.viz.style import format_penetration

UM = 1e6  # metres -> micrometres


UN = 1e6  # newtons -> micronewtons


MODE_LABELS = ("none", "point/line", "face")


def shape_of(ds: xr.Dataset, shape: str | Shape | None) -> Shape:
    """The shape of a run: ``shape`` if given, else the library shape named in its attrs.

    Parameters
    ----------
    ds : Dataset
        A run from :func:`tumblemc.simulate`.
    shape : str or Shape or None
        The run's shape or its name; None takes ``ds.attrs["shape"]`` (a shape built
        with non-default dimensions must be passed).

    Returns
    -------
    Shape
    """
    return get_shape(ds.attrs.get("shape", "cuboid") if shape is None else shape)


def side_view_outline(ds: xr.Dataset, shape: str | Shape | None, i: int) -> tuple[np.ndarray, np.ndarray]:
    """Outline of the robot at record ``i`` in plane coordinates.

    Parameters
    ----------
    ds : Dataset
        A run from :func:`tumblemc.simulate`.
    shape : str or Shape or None
        The run's :class:`~tumblemc.model.shapes.Shape` or its name; None takes
        ``ds.attrs["shape"]`` (a shape built with non-default dimensions must be passed).
    i : int
        Index along ``time`` (negative counts from the end).

    Returns
    -------
    s : (m,) float64 array
        Uphill coordinate along the plane of each outline point, m, measured from the
        centre of mass at ``time[0]``.
    h : (m,) float64 array
        Height above the plane, m (0 on the plane).
    """
    shp = shape_of(ds, shape)
    fr = plane_frame(float(ds.attrs.get("incline_deg", 0.0)))
    outline = np.asarray(shp.outline, dtype=float)
    body = np.column_stack([np.zeros(len(outline)), outline[:, 0], outline[:, 1]])
    R = quat_to_matrix(ds["quaternion"].values[i])
    pos = ds["position"].values
    pts = pos[i] + body @ R.T
    s = (pts - pos[0]) @ fr["u"]
    h = pts @ fr["n"]
    return s, h


def run_label(ds: xr.Dataset) -> str:
    """One-line description of a run's settings from its attrs (figure titles).

    Parameters
    ----------
    ds : Dataset
        A run from :func:`tumblemc.simulate`.

    Returns
    -------
    str
        E.g. ``"cuboid robot, mu=0.3, incline=30 deg, B=20 mT, f=1 Hz"``.
    """
    a = ds.attrs
    parts = [f"{a.get('shape', '?')} robot"]
    if "mu" in a:
        parts.append(f"mu={float(a['mu']):g}")
    if "offset_deg" in a:
        parts.append(f"phi={float(a['offset_deg']):g} deg")
    parts.append(f"incline={float(a.get('incline_deg', 0.0)):g} deg")
    parts.append(f"B={float(a.get('field_mT', float('nan'))):g} mT")
    parts.append(f"f={float(a.get('freq_hz', float('nan'))):g} Hz")
    if "dt" in a:
        parts.append(f"dt={float(a['dt']):g} s")
    if "torque" in a:
        parts.append(f"torque@{a['torque']}")
    return ", ".join(parts)


def _summary_label(ds: xr.Dataset) -> str:
    from tumblemc.model.outcome import summarize

    try:
        sm = summarize(ds)
    except (ValueError, KeyError) as exc:
        msg = str(exc).split("(")[0].strip()
        return f"no summary: {msg}"
    verdict = verdict_name(float(ds.attrs.get("incline_deg", 0.0)))  # "descended" on a downhill slope
    said = verdict if sm["climbed"] else {"climbed": "did not climb", "descended": "did not descend"}[verdict]
    return (
        f"mean speed {sm['mean_speed'] * 1e3:.3g} mm/s of ideal {sm['ideal_speed'] * 1e3:.3g} mm/s "
        f"(ratio {sm['progress_ratio']:.3f}, {said}); "
        f"failed steps {sm['failed_steps']}, max penetration {format_penetration(sm['max_penetration'])}, status {sm['status']}"
    )


def _anchor_time(t: np.ndarray, freq: float) -> float:
    """Start of the no-slip reference line: one field period in, or t[0] if the run is shorter."""
    if freq > 0 and t[-1] > t[0] + 1.0 / freq:
        return float(t[0] + 1.0 / freq)
    return float(t[0])


def _panel_progress(ax: Any, ds: xr.Dataset) -> None:
    t = ds["time"].values
    prog = ds["progress"].values * UM
    ax.plot(t, prog, color="C0", lw=1.5, label="simulated")
    freq = float(ds.attrs.get("freq_hz", 0.0))
    ideal = float(ds.attrs.get("ideal_speed", 0.0))
    if freq > 0 and ideal > 0 and len(t) > 1:
        t0 = _anchor_time(t, freq)
        p0 = float(np.interp(t0, t, prog))
        tt = np.array([t0, t[-1]])
        ax.plot(tt, p0 + ideal * UM * (tt - t0), "k--", lw=1, label=f"no slip ({ideal * 1e3:.3g} mm/s, from t={t0:g} s)")
        for k in range(1, int(np.floor((t[-1] - t[0]) * freq)) + 1):  # field periods
            ax.axvline(t[0] + k / freq, color="0.85", lw=0.6, zorder=0)
    ax.set_xlabel("time (s)")
    ax.set_ylabel(f"{'downhill' if float(ds.attrs.get('incline_deg', 0.0)) < 0 else 'uphill'} progress (µm)")
    ax.set_title("(a) progress along the plane", loc="left", fontsize=10)
    ax.grid(True, alpha=0.3)
    ax.legend(loc="upper left", fontsize=8, frameon=False)


def _panel_contact(ax_mode: Any, ax_adh: Any, ds: xr.Dataset) -> None:
    """Contact mode (upper strip) and adhesion force (lower) on their own axes, sharing time."""
    t = ds["time"].values
    mode = ds["contact_mode"].values.astype(float)
    ax_mode.step(t, mode, where="post", color="C2", lw=1.0)
    ax_mode.set_yticks([0, 1, 2], list(MODE_LABELS))
    ax_mode.set_ylim(-0.3, 2.3)
    ax_mode.set_ylabel("contact\nmode", fontsize=9)
    ax_mode.tick_params(axis="x", labelbottom=False)
    ax_mode.tick_params(axis="y", labelsize=8)
    ax_mode.set_title("(b) contact mode and adhesion", loc="left", fontsize=10)
    ax_mode.grid(True, alpha=0.3)
    adh = ds["adhesion_force"].values * UN
    ax_adh.plot(t, adh, color="C3", lw=1.0)
    ax_adh.set_ylabel("adhesion force (µN)")
    ax_adh.set_xlabel("time (s)")
    ax_adh.set_ylim(bottom=min(0.0, float(np.nanmin(adh, initial=0.0))))
    ax_adh.grid(True, alpha=0.3)


def _snapshot_indices(n: int, count: int) -> np.ndarray:
    return np.unique(np.round(np.linspace(0, n - 1, min(count, n))).astype(int))


def strip_offsets(outlines: list[tuple[np.ndarray, np.ndarray]], length: float) -> tuple[np.ndarray, str, float]:
    """Horizontal shifts (m) of the snapshots of the side-view strip, and the layout used.

    ``"true"``: no shift needed, the outlines do not overlap at their true positions.
    ``"spread"``: snapshot k shifted by ``k * extra`` (extra may be negative when the robot
    moves downhill), the smallest uniform shift that keeps the outlines and their labels
    apart; relative positions stay true up to that linear shift.
    ``"slots"``: when the true travel dwarfs the body (a fast slide), equal slots in time
    order; the true positions are printed under each snapshot.
    """
    n = len(outlines)
    size = max([float(np.ptp(s)) for s, _ in outlines] + [length])
    gap, label_w = 0.15 * size, 0.9 * size
    lo = np.array([s.min() for s, _ in outlines])
    hi = np.array([s.max() for s, _ in outlines])
    mid = 0.5 * (lo + hi)
    if n < 2:
        return np.zeros(n), "true", 0.0
    # rightward spread: lo[k+1] + e >= hi[k] + gap and mid[k+1] + e >= mid[k] + label_w
    right = max(0.0, float(np.max(np.maximum(hi[:-1] - lo[1:] + gap, mid[:-1] - mid[1:] + label_w))))
    # leftward spread (downhill motion): hi[k+1] + e <= lo[k] - gap, mid[k+1] + e <= mid[k] - label_w
    left = min(0.0, float(np.min(np.minimum(lo[:-1] - hi[1:] - gap, mid[:-1] - mid[1:] - label_w))))
    # spread in the direction of the net motion, so that time runs the way the robot goes
    extra = right if mid[-1] >= mid[0] else left
    k = np.arange(n)
    span = float(np.ptp(np.concatenate([lo + k * extra, hi + k * extra])))
    pitch = max(size + gap, label_w)
    if span > 2.5 * n * pitch:
        return k * pitch - mid, "slots", pitch
    if extra == 0.0:
        return np.zeros(n), "true", 0.0
    return k * extra, "spread", extra


def _strip_data(ds: xr.Dataset, shape: str | Shape | None, count: int) -> dict[str, Any]:
    """Outlines (µm, spread along s), centre-of-mass and contact points of the strip."""
    t = ds["time"].values
    idx = _snapshot_indices(len(t), count)
    shp = shape_of(ds, shape)  # built once, not per snapshot
    outlines = [side_view_outline(ds, shp, int(i)) for i in idx]
    length = float(np.ptp(np.asarray(shp.outline)[:, 0]))
    offsets, layout, extra = strip_offsets(outlines, length)
    size = max([float(np.ptp(s)) for s, _ in outlines] + [length])
    fr = plane_frame(float(ds.attrs.get("incline_deg", 0.0)))
    pos = ds["position"].values
    ecp = ds["ecp"].values if "ecp" in ds else np.full_like(pos, np.nan)
    polys, cm, cp, labels = [], [], [], []
    for k, (i, (s, h)) in enumerate(zip(idx, outlines, strict=True)):
        off = offsets[k]
        polys.append(np.column_stack([(s + off) * UM, h * UM]))
        s_cm = float((pos[i] - pos[0]) @ fr["u"])
        cm.append(((s_cm + off) * UM, float(pos[i] @ fr["n"]) * UM))
        if np.all(np.isfinite(ecp[i])):
            cp.append((float((ecp[i] - pos[0]) @ fr["u"] + off) * UM, float(ecp[i] @ fr["n"]) * UM))
        labels.append(((s.min() + s.max()) / 2 * UM + off * UM, f"{t[i]:.3g} s\ns={s_cm * UM:.0f} µm"))
    allxy = np.concatenate(polys)
    pad = 0.12 * size * UM
    # the labels under the outlines are about 0.9 body sizes wide (strip_offsets' label_w)
    xs = np.array([x for x, _ in labels])
    xlim = (
        min(float(allxy[:, 0].min()), float(xs.min()) - 0.5 * size * UM) - pad,
        max(float(allxy[:, 0].max()), float(xs.max()) + 0.5 * size * UM) + pad,
    )
    ylim = (min(0.0, float(allxy[:, 1].min())) - 0.9 * size * UM, float(allxy[:, 1].max()) + 0.5 * size * UM)
    return {
        "t": t[idx],
        "polys": polys,
        "cm": np.array(cm),
        "cp": np.array(cp).reshape(-1, 2),
        "labels": labels,
        "layout": layout,
        "extra": extra,
        "xlim": xlim,
        "ylim": ylim,
    }


def _panel_strip(ax: Any, ds: xr.Dataset, data: dict[str, Any], colorbar: bool = True) -> None:
    t = ds["time"].values
    norm = Normalize(vmin=float(t[0]), vmax=float(t[-1]) if t[-1] > t[0] else float(t[0]) + 1.0)
    coll = PolyCollection(data["polys"], array=data["t"], cmap="viridis", norm=norm, alpha=0.6, edgecolors="k", linewidths=0.6, zorder=2)
    ax.add_collection(coll)
    ax.axhline(0.0, color="0.35", lw=1.5, zorder=1)
    ax.plot(data["cm"][:, 0], data["cm"][:, 1], "k.", ms=3, zorder=3, label="centre of mass")
    if len(data["cp"]):
        ax.plot(data["cp"][:, 0], data["cp"][:, 1], "rx", ms=4, mew=1.0, zorder=3, label="equivalent contact point")
    for x, text in data["labels"]:
        ax.annotate(text, (x, 0.0), xytext=(0, -3), textcoords="offset points", ha="center", va="top", fontsize=6.5)
    ax.set_xlim(*data["xlim"])
    ax.set_ylim(*data["ylim"])
    ax.set_aspect("equal", adjustable="box")
    ax.set_ylabel("height (µm)")
    if data["layout"] == "spread":
        shift = f"{data['extra'] * UM:+.0f} µm"
        ax.set_xlabel(f"along the plane, uphill (µm); snapshot k is shifted by k x {shift} so outlines do not overlap (true s under each)")
    elif data["layout"] == "slots":
        slot = f"{data['extra'] * UM:.0f} µm"
        ax.set_xlabel(f"snapshots in equal slots of {slot} in time order (true uphill position s under each; travel >> body size)")
        ax.tick_params(axis="x", bottom=False, labelbottom=False)
    else:
        ax.set_xlabel("uphill position s along the plane (µm)")
    n = len(data["t"])
    ax.set_title(f"(c) side view at {n} instants (plane coordinates, plane at height 0, equal aspect)", loc="left", fontsize=10)
    ax.legend(loc="upper left", fontsize=7, frameon=False, ncol=2)
    if colorbar:
        cb = ax.figure.colorbar(coll, cax=ax.inset_axes((1.008, 0.0, 0.012, 1.0)))
        cb.set_label("time (s)", fontsize=8)
        cb.ax.tick_params(labelsize=7)


def plot_run(
    ds: xr.Dataset,
    path: str | os.PathLike[str] | None = None,
    *,
    shape: str | Shape | None = None,
    snapshots: int = 12,
    dpi: int = 150,
) -> Figure:
    """Three-panel figure of one run; saved as PNG (or any matplotlib format) if ``path``.

    (a) uphill progress vs time with the no-slip line ``ideal_speed * (t - t0)`` anchored
    one field period in; (b) contact mode (step, upper strip) and adhesion force (below) vs time;
    (c) side-view strip of the body outline at ``snapshots`` regular instants in plane
    coordinates, coloured by time, spread along the plane so that they do not overlap.

    ``shape`` is needed only for a shape built with non-default dimensions (the Dataset
    stores the shape's name). Returns the Figure (no pyplot state is touched).
    """
    if ds.sizes.get("time", 0) < 1:
        raise ValueError("plot_run needs a Dataset with at least one time record")
    strip = _strip_data(ds, shape, snapshots)
    width_in, top_in = 12.0, 3.6
    (x0, x1), (y0, y1) = strip["xlim"], strip["ylim"]
    strip_in = float(np.clip((width_in - 1.6) * (y1 - y0) / (x1 - x0), 1.0, 5.0)) + 0.7
    fig = Figure(figsize=(width_in, top_in + strip_in + 0.6), layout="constrained")
    gs = fig.add_gridspec(2, 2, height_ratios=[top_in, strip_in])
    ax_a = fig.add_subplot(gs[0, 0])
    gs_b = gs[0, 1].subgridspec(2, 1, height_ratios=[1.0, 2.0])
    ax_b = fig.add_subplot(gs_b[0])
    ax_b2 = fig.add_subplot(gs_b[1], sharex=ax_b)
    ax_c = fig.add_subplot(gs[1, :])
    _panel_progress(ax_a, ds)
    _panel_contact(ax_b, ax_b2, ds)
    _panel_strip(ax_c, ds, strip)
    fig.suptitle(f"{run_label(ds)}\n{_summary_label(ds)}", fontsize=10)
    if path is not None:
        fig.savefig(path, dpi=dpi)
    return fig


def plot_step_check(check: StepCheck, path: str | os.PathLike[str] | None = None, *, dpi: int = 150) -> Figure:
    """Two panels of a :func:`tumblemc.check_step`: the runs' progress, and their ratios against the tolerance.

    (a) progress along the plane against time: the run at its step, the run at the finer
    step and the twins, with the no-slip line one field period in (where the ratio's window
    starts); (b) each run's progress ratio on one axis, the tolerance band about the finer
    step's ratio shaded and the climb threshold marked. The title gives the class.
    """
    ds = check.run
    fig = Figure(figsize=(12.0, 4.4), layout="constrained")
    ax_a, ax_b = fig.subplots(1, 2, width_ratios=[2.0, 1.0])
    fine = f"dt / {check.factor}"
    span = max((float(np.ptp(p)) for _, p in check.curves.values()), default=0.0)
    scale, unit = (1e3, "mm") if span > 2e-3 else (UM, "µm")
    for name, (t, p) in check.curves.items():
        if name.startswith("twin"):
            ax_a.plot(t, p * scale, color="0.6", lw=0.8, label="twins (magnetisation x 1e-6)" if name.startswith("twin 1 ") else None)
    if fine in check.curves:
        t, p = check.curves[fine]
        ax_a.plot(t, p * scale, color="C3", lw=1.4, label=f"{fine} ({check.dt / check.factor:.3g} s)")
    t, p = check.curves.get("the run", (ds["time"].values, ds["progress"].values))
    ax_a.plot(t, p * scale, color="C0", lw=1.6, label=f"the run (dt {check.dt:.3g} s)")
    freq, ideal = float(ds.attrs.get("freq_hz", 0.0)), float(ds.attrs.get("ideal_speed", 0.0))
    if freq > 0 and ideal > 0 and len(t) > 1:
        t0 = _anchor_time(t, freq)
        p0 = float(np.interp(t0, t, p * scale))
        tt = np.array([t0, t[-1]])
        ax_a.plot(tt, p0 + ideal * scale * (tt - t0), "k--", lw=1, label=f"no slip, from t={t0:.3g} s (the ratio's window)")
    ax_a.set_xlabel("time (s)")
    ax_a.set_ylabel(f"progress along the plane ({unit})")
    ax_a.set_title("(a) progress of each run", loc="left", fontsize=10)
    ax_a.grid(True, alpha=0.3)
    ax_a.legend(loc="upper left", fontsize=8, frameon=False)
    rows = [("the run", check.ratio, check.status, "C0"), (fine, check.fine_ratio, check.fine_status, "C3")]
    twins = zip(check.twin_ratios, check.twin_statuses, strict=True)
    rows += [(f"twin {i + 1}", float(r), int(s), "0.45") for i, (r, s) in enumerate(twins)]
    y = np.arange(len(rows))[::-1]
    if np.isfinite(check.tol) and np.isfinite(check.fine_ratio):
        lo, hi = check.fine_ratio - check.tol, check.fine_ratio + check.tol
        ax_b.axvspan(lo, hi, color="C3", alpha=0.12, lw=0, label=f"tolerance about {fine}: ± {check.tol:.3g}")
    ax_b.axvline(check.threshold, color="k", lw=0.8, ls=":", label=f"climb threshold {check.threshold:g}")
    for yi, (_, r, st, color) in zip(y, rows, strict=True):
        ax_b.plot([r], [yi], "o" if st == 0 else "x", color=color, ms=7)
        ax_b.annotate(f"{r:.3f}" + ("" if st == 0 else f" (status {st})"), (r, yi), xytext=(6, 4), textcoords="offset points", fontsize=8)
    ax_b.set_yticks(y, [r[0] for r in rows])
    ax_b.set_ylim(-0.7, len(rows) - 0.3)
    ax_b.set_xlabel("progress ratio")
    ax_b.set_title("(b) progress ratios", loc="left", fontsize=10)
    ax_b.grid(True, axis="x", alpha=0.3)
    ax_b.legend(loc="upper center", fontsize=8, frameon=False, ncols=1, bbox_to_anchor=(0.5, -0.16))  # below the axis
    said = f"the finer step moves the ratio by {check.move:.3g}, the twins by up to {check.twin_spread:.3g}; tolerance {check.tol:.3g}"
    if check.cls == "not checked":
        which, bad = ("the run", check.status) if check.status != 0 else (f"the run at {fine}", check.fine_status)
        said = f"{which} is not valid, status {bad}: no comparison"
    fig.suptitle(f"{run_label(ds)}" + "\n" + f"step check: {check.cls} ({said})", fontsize=10)
    if path is not None:
        fig.savefig(path, dpi=dpi)
    return fig


def plot_shapes(
    shapes: Sequence[str | Shape] | None = None,
    path: str | os.PathLike[str] | None = None,
    *,
    dpi: int = 150,
) -> Figure:
    """Draw the shape library in the body y-z plane, one panel per shape.

    Each panel fills the real outline, draws the hull faces of the profile (blue: real
    face, labelled with its adhering area in µm²; red: line contact, labelled "line"),
    marks the centre of mass (the body origin) and gives the thickness, the area of the
    ±x faces and the hull perimeter (the no-slip distance per field revolution), all in µm.

    Parameters
    ----------
    shapes : sequence of str or Shape, optional
        Names in :data:`tumblemc.model.shapes.SHAPES` or Shape objects; default: every shape
        of the library.
    path : path-like, optional
        Where to save the figure (any matplotlib format; PNG by its suffix).
    dpi : int
        Resolution of the saved figure.

    Returns
    -------
    matplotlib.figure.Figure
        A figure not registered with pyplot (nothing global to close).
    """
    names = list(SHAPES) if shapes is None else list(shapes)
    if not names:
        raise ValueError("shapes=[] is not allowed (allowed: None for all, or at least one shape)")
    shps = [get_shape(s) for s in names]
    ncols = min(2, len(shps))
    nrows = -(-len(shps) // ncols)
    fig = Figure(figsize=(6.4 * ncols, 3.9 * nrows + 0.4), layout="constrained")
    axes = fig.subplots(nrows, ncols, squeeze=False)
    for ax, shp in zip(axes.flat, shps, strict=False):
        out = np.asarray(shp.outline) * UM
        ax.fill(out[:, 0], out[:, 1], facecolor="0.85", edgecolor="k", lw=0.8, zorder=1)
        for c, pts in shp.hull_faces():
            xy = pts * UM
            color = "C3" if c.line else "C0"
            ax.plot(xy[:, 0], xy[:, 1], color=color, lw=1.8, zorder=2, solid_capstyle="round")
            if c.kind == "plane":
                mid = 0.5 * (xy[0] + xy[-1])
                nrm = np.array(c.data[1:3])
            else:
                mid = xy[len(xy) // 2]
                nrm = mid - np.array(c.data[:2]) * UM
                nrm = nrm / np.linalg.norm(nrm)
            text = "line" if c.line else f"{c.area * UM**2:.0f} µm²"
            ha = "left" if nrm[0] > 0.3 else "right" if nrm[0] < -0.3 else "center"
            va = "bottom" if nrm[1] > 0.3 else "top" if nrm[1] < -0.3 else "center"
            ax.annotate(text, mid, xytext=tuple(8 * nrm), textcoords="offset points", ha=ha, va=va, fontsize=7, color=color)
        ax.plot([0.0], [0.0], "k+", ms=8, zorder=3)
        pad = 0.3 * float(np.ptp(out, axis=0).max())  # room for the labels
        ax.set_xlim(out[:, 0].min() - 1.4 * pad, out[:, 0].max() + 1.4 * pad)
        ax.set_ylim(out[:, 1].min() - pad, out[:, 1].max() + pad)
        ax.set_aspect("equal", adjustable="box")
        ax.set_xlabel("body y (µm)")
        ax.set_ylabel("body z (µm)")
        ax.grid(True, alpha=0.25)
        side = shp.pieces[0].constraints[0].area if shp.pieces and shp.pieces[0].constraints else float("nan")
        ax.set_title(
            f"{shp.name}: thickness {shp.thickness * UM:.0f} µm, ±x faces {side * UM**2:.0f} µm²\n"
            f"hull perimeter {shp.hull_perimeter * UM:.0f} µm, inertia: {shp.mass_model}",
            fontsize=9,
        )
    for ax in axes.flat[len(shps) :]:
        ax.set_visible(False)
    fig.suptitle(
        "Shapes (body frame, + = centre of mass; the robot starts with body +z on the plane)\n"
        "blue: real hull face and its adhering area; red: line contact",
        fontsize=10,
    )
    if path is not None:
        fig.savefig(path, dpi=dpi)
    return fig
