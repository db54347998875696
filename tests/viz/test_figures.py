"""Every figure type of :mod:`tumblemc.viz` on small data: no text on text, none outside the figure.

Each figure is drawn (its layout engine run, warnings being errors) and the window extents
of its texts collected: the suptitle and figure texts, every axes' titles, axis labels,
visible tick labels, annotations and texts, and every legend as one box. No two boxes may
overlap (tick labels of one axis among themselves are matplotlib's business) and every box
must lie inside the figure. The data are tiny: short runs, the shipped example study,
synthetic protocol and calibration Datasets.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import xarray as xr
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.transforms import Bbox

import tumblemc
from tumblemc.analysis.maps import maps as study_maps
from tumblemc.analysis.prim import failure_region
from tumblemc.analysis.sobol import saltelli_design, sobol_indices, split_saltelli
from tumblemc.io import open_result
from tumblemc.testing import ISHIGAMI_BOUNDS, ishigami, synthetic_runs
from tumblemc.viz.calibrate import plot_calibration
from tumblemc.viz.lab import plot_critical_field, plot_static_tilt, plot_steering, plot_step_out
from tumblemc.viz.ratio import plot_ratio_distribution
from tumblemc.viz.run import plot_run, plot_shapes, plot_step_check
from tumblemc.viz.sensitivity import plot_prim, plot_sobol, plot_success_vs_parameter
from tumblemc.viz.stress import stress_figure
from tumblemc.viz.study import plot_critical_distribution, plot_success_curves, plot_success_heatmap
from tumblemc.viz.validation import plot_adhesion_series, plot_convergence, plot_frequency_sweep, plot_paper_inclines, plot_shape_speeds

ROOT = Path(__file__).resolve().parents[2]

#: pixels two boxes may share (anti-aliasing of touching glyph boxes), and by which one may
#: pass the figure's edge
OVERLAP_TOL_PX = 1.0


def text_boxes(fig: Figure) -> list[tuple[str, Bbox, str]]:
    """(text, window extent, group) of every visible text of ``fig``, after drawing it.

    The group is ``"<axes id>:x"`` / ``":y"`` for tick labels (those of one axis may touch
    each other, matplotlib thins them) and unique otherwise.
    """
    renderer = FigureCanvasAgg(fig).get_renderer()
    fig.draw_without_rendering()
    out: list[tuple[str, Bbox, str]] = []
    seen: set[int] = set()

    def add(artist: Any, group: str) -> None:
        if artist is None or not artist.get_visible() or id(artist) in seen:
            return
        seen.add(id(artist))
        text = artist.get_text() if hasattr(artist, "get_text") else "legend"
        if not text:
            return
        box = artist.get_window_extent(renderer)
        if box.width > 0 and box.height > 0:
            out.append((text, box, group))

    for k, t in enumerate(fig.texts):  # the suptitle among them
        add(t, f"fig-text-{k}")
    for k, leg in enumerate(fig.legends):
        add(leg, f"fig-legend-{k}")
    for a, ax in enumerate(fig.axes):
        if not ax.get_visible():
            continue
        for side, title in (("center", ax.title), ("left", ax._left_title), ("right", ax._right_title)):
            add(title, f"{a}-title-{side}")
        add(ax.xaxis.label, f"{a}-xlabel")
        add(ax.yaxis.label, f"{a}-ylabel")
        for name, axis in (("x", ax.xaxis), ("y", ax.yaxis)):
            for tick in axis.get_major_ticks() + axis.get_minor_ticks():
                if tick.get_visible() and axis.get_view_interval()[0] - 1e-12 <= tick.get_loc() <= axis.get_view_interval()[1] + 1e-12:
                    add(tick.label1, f"{a}:{name}")
                    add(tick.label2, f"{a}:{name}2")
            add(axis.offsetText, f"{a}-{name}-offset")
        for k, t in enumerate(ax.texts):
            add(t, f"{a}-text-{k}")
        add(ax.get_legend(), f"{a}-legend")
    return out


def layout_problems(fig: Figure) -> list[str]:
    """Texts that overlap another text or stick out of the figure, in words (empty: none)."""
    boxes = text_boxes(fig)
    frame = fig.bbox
    problems = []
    for text, box, _ in boxes:
        if (
            box.x0 < frame.x0 - OVERLAP_TOL_PX
            or box.y0 < frame.y0 - OVERLAP_TOL_PX
            or box.x1 > frame.x1 + OVERLAP_TOL_PX
            or box.y1 > frame.y1 + OVERLAP_TOL_PX
        ):
            problems.append(f"outside the figure: {text!r}")
    for (t1, b1, g1), (t2, b2, g2) in itertools.combinations(boxes, 2):
        if g1 == g2 and ":" in g1:
            continue
        w = min(b1.x1, b2.x1) - max(b1.x0, b2.x0)
        h = min(b1.y1, b2.y1) - max(b1.y0, b2.y0)
        if w > OVERLAP_TOL_PX and h > OVERLAP_TOL_PX:
            problems.append(f"overlap: {t1!r} and {t2!r}")
    return problems


def assert_clean_layout(fig: Figure) -> None:
    problems = layout_problems(fig)
    assert not problems, "\n".join(problems)


# ------------------------------------------------------------------------- the helper itself


def test_the_checker_sees_overlaps_and_texts_outside() -> None:
    fig = Figure(figsize=(3, 2))
    ax = fig.add_subplot()
    ax.text(0.5, 0.5, "one label", transform=ax.transAxes)
    ax.text(0.52, 0.5, "another", transform=ax.transAxes)
    ax.text(1.5, 0.5, "far right", transform=ax.transAxes)
    problems = layout_problems(fig)
    assert any("overlap" in p and "one label" in p for p in problems)
    assert any("outside" in p and "far right" in p for p in problems)
    clean = Figure(figsize=(3, 2), layout="constrained")
    clean.add_subplot().set(title="t", xlabel="x", ylabel="y")
    assert layout_problems(clean) == []


# ------------------------------------------------------------------------- data


@pytest.fixture(scope="module")
def runs_1() -> list[xr.Dataset]:
    """A short flat run and a short one on an incline (the strip's two layouts)."""
    return [
        tumblemc.simulate(duration_s=0.1, freq_hz=10.0),
        tumblemc.simulate("spiked", preset="aluminum", incline_deg=40.0, duration_s=0.2, freq_hz=10.0),
    ]


@pytest.fixture(scope="module")
def example() -> tuple[xr.Dataset, xr.Dataset]:
    return open_result(ROOT / "data" / "example.nc")


@pytest.fixture(scope="module")
def example_critical() -> tuple[xr.Dataset, xr.Dataset]:
    return open_result(ROOT / "data" / "example_critical.nc")


def _static_tilt() -> xr.Dataset:
    b = np.arange(3.0, 15.5, 2.0)
    tilt = np.where(b > 5.0, 65.0 - 120.0 / b, 0.0)
    fine = np.linspace(2.0, 16.0, 50)
    return xr.Dataset(
        {
            "tilt_deg": ("field_mT", tilt),
            "tilt_min_deg": ("field_mT", tilt - 1.0),
            "tilt_max_deg": ("field_mT", tilt + 1.0),
            "tilt_spread_deg": ("field_mT", np.full(b.size, 0.5)),
            "tilt_closed_form_curve_deg": ("field_fine_mT", np.where(fine > 5.0, 65.0 - 120.0 / fine, 0.0)),
        },
        coords={"field_mT": b, "field_fine_mT": fine},
        attrs={"protocol": "static_tilt", "shape": "cuboid", "preset": "paper"},
    )


def _step_out() -> xr.Dataset:
    f = np.array([1.0, 10.0, 25.0, 50.0, 100.0, 150.0, 200.0, 225.0, 250.0, 275.0, 300.0])
    ratio = np.r_[np.linspace(1.0, 0.25, 8), 0.03, 0.02, 0.02]
    return xr.Dataset(
        {
            "speed": ("freq_hz", 1.8 * f * ratio),
            "progress_ratio": ("freq_hz", ratio),
            "phase_lag_deg": ("freq_hz", np.r_[np.linspace(0.0, -15.0, 8), 135.0, 153.0, 146.0]),
            "following_share": ("freq_hz", np.r_[np.ones(6), 0.81, 0.86, 0.01, -0.01, 0.0]),
            "step_out_hz": 238.3,
        },
        coords={"freq_hz": f},
        attrs={"protocol": "step_out", "shape": "cuboid", "preset": "paper", "field_mT": 20.0, "step_out_share": 0.5},
    )


def _steering() -> xr.Dataset:
    t = np.linspace(0.0, 2.0, 81)
    x = np.where(t <= 1.0, 0.0, 1.8e-3 * (t - 1.0))
    y = np.where(t <= 1.0, 1.8e-3 * t, 1.8e-3)
    pos = np.column_stack([x, y, np.full(t.size, 5e-5)])
    return xr.Dataset(
        {"position": (("time", "xyz"), pos), "turn_deg": 88.5, "field_jump_deg": 90.0},
        coords={"time": t},
        attrs={"protocol": "steering", "shape": "cuboid", "preset": "paper", "duration_s": 2.0},
    )


def _critical_field(samples: bool) -> xr.Dataset:
    attrs = {"shape": "cuboid", "preset": "paper", "freq_hz": 1.0, "incline_deg": 0.0}
    if samples:
        crit = np.random.default_rng(0).normal(6.0, 0.8, 12)
        return xr.Dataset(
            {"critical_mT": ("sample", crit), "critical_mT_median": float(np.median(crit))},
            attrs={**attrs, "protocol": "critical_field_samples"},
        )
    tested = np.array([10.0, 5.0, 7.5, 6.25, 5.625, 5.9375])
    return xr.Dataset(
        {"tested_mT": ("trial", tested), "tumbled": ("trial", tested > 5.9), "critical_mT": 5.95},
        coords={"trial": np.arange(tested.size)},
        attrs={**attrs, "protocol": "critical_field"},
    )


def _calibration(grid: bool, n_param: int) -> xr.Dataset:
    rng = np.random.default_rng(1)
    x = np.arange(3.0, 15.5, 1.0)

    def curve(b: np.ndarray) -> np.ndarray:
        return np.where(b > 5.2, 65.0 - 120.0 / b, 0.0)

    y = curve(x) + rng.normal(0.0, 0.4, x.size)
    names = ["F_elect", "offset_deg", "adhesion_C"][:n_param]
    draws = {
        "F_elect": rng.normal(2.5e-6, 8e-8, 300),
        "offset_deg": rng.normal(22.0, 0.3, 300),
        "adhesion_C": rng.lognormal(-1.0, 1.5, 300),
    }
    ds = xr.Dataset(
        {
            "x": ("point", x, {"long_name": "field_mT"}),
            "y": ("point", y, {"long_name": "tilt_deg", "units": "degree"}),
            "fit": ("point", curve(x)),
            "band_lo": ("point", curve(x) - 0.3),
            "band_hi": ("point", curve(x) + 0.3),
            "predictive_lo": ("point", curve(x) - 1.0),
            "predictive_hi": ("point", curve(x) + 1.0),
        },
        coords={"point": np.arange(x.size), "param": names, "sample": np.arange(300)},
        attrs={
            "test": "static_tilt",
            "shape": "cuboid",
            "preset": "paper",
            "rms_residual": 0.438,
            "predictive_share": 1.0,
            "sampling_scale": ",".join(["log", "linear", "log"][:n_param]),
            "posterior_method": "mcmc",
            "undetermined": "adhesion_C" if n_param == 3 else "",
        },
    )
    for nm in names:
        ds[nm] = ("sample", draws[nm], {"units": {"F_elect": "N", "offset_deg": "degree", "adhesion_C": "N m-2"}[nm]})
        ds[f"estimate_{nm}"] = float(np.median(draws[nm]))
    if grid:
        xg = np.linspace(1.8, 15.6, 120)
        ds = ds.assign_coords(x_grid=xg)
        for k, d in (("fit", 0.0), ("band_lo", -0.3), ("band_hi", 0.3), ("predictive_lo", -1.0), ("predictive_hi", 1.0)):
            ds[f"grid_{k}"] = ("x_grid", curve(xg) + d)
    return ds


def _convergence_table() -> list[dict[str, Any]]:
    """The shape of the committed table: four climbing cases near 1, one sliding to -25 whose threshold is near the top."""
    dts = (5e-4, 2.5e-4, 1e-4, 5e-5, 2.5e-5, 1.25e-5)
    cases = (
        ("flat paper 1 Hz", 1.0),
        ("flat paper 10 Hz", 1.03),
        ("paper 45 deg", 0.93),
        ("aluminum 20 deg", 0.88),
        ("aluminum 30 deg", -25.0),
    )
    return [
        {"case": c, "torque": q, "dt": dt, "progress_ratio": base * (1.0 + 40.0 * dt) if base < 0 else base - 60.0 * dt}
        for c, base in cases
        for q in ("start", "end")
        for dt in dts
    ]


def _stress_runs() -> xr.Dataset:
    rng = np.random.default_rng(2)
    n = 40
    ratio = np.r_[rng.normal(1.0, 0.05, 30), -rng.lognormal(4.0, 1.0, 10)]
    idx = np.arange(0, n, 5)
    return xr.Dataset(
        {
            "status": ("run", np.r_[np.zeros(n - 2, int), 3, 3]),
            "energy_gain_ratio": ("run", rng.lognormal(-12.0, 3.0, n)),
            "progress_ratio": ("run", ratio),
            "check_run": ("check", idx),
            "check_progress_ratio_fine": ("check", ratio[idx] * 1.01),
            "check_status_fine": ("check", np.zeros(idx.size, int)),
        }
    )


# ------------------------------------------------------------------------- figures

FIGURES: dict[str, Callable[..., Figure]] = {
    "static_tilt": lambda: plot_static_tilt(_static_tilt()),
    "step_out": lambda: plot_step_out(_step_out()),
    "steering": lambda: plot_steering(_steering()),
    "critical_field": lambda: plot_critical_field(_critical_field(False)),
    "critical_field_samples": lambda: plot_critical_field(_critical_field(True)),
    "calibration_closed_form": lambda: plot_calibration(_calibration(True, 2)),
    "calibration_simulator": lambda: plot_calibration(_calibration(False, 2)),
    "calibration_three": lambda: plot_calibration(_calibration(True, 3)),
    "calibration_one": lambda: plot_calibration(_calibration(True, 1)),
    "convergence": lambda: plot_convergence(
        _convergence_table(), list(dict.fromkeys(r["case"] for r in _convergence_table())), mark_dt=5e-5
    ),
    "paper_inclines": lambda: plot_paper_inclines(
        [("5 deg", np.linspace(0, 2, 50), 1e-3 * np.linspace(0, 2, 50)), ("60 deg", np.linspace(0, 2, 50), -np.linspace(0, 2, 50))],
        "inclines",
    ),
    "frequency_sweep": lambda: plot_frequency_sweep(
        np.array([1.0, 5.0, 10.0]),
        np.array([1.8, 8.0, 12.0]) * 1e-3,
        np.array([1.7, 7.5, 11.0]) * 1e-3,
        np.array([1.8, 9.0, 18.0]) * 1e-3,
        "sweep",
    ),
    "shape_speeds": lambda: plot_shape_speeds(
        {"paper": {"cuboid": 1.8e-3, "curved": 1.5e-3}, "aluminum": {"cuboid": 1.6e-3, "curved": 1.2e-3}},
        {"cuboid": 1.8e-3, "curved": 1.6e-3},
        "speeds",
    ),
    "adhesion_series": lambda: plot_adhesion_series(
        np.linspace(0, 2, 200),
        np.where(np.sin(2 * np.pi * np.linspace(0, 2, 200)) > 0.5, 1.19e-6, 1e-8),
        {"face, C L W": 1.19e-6, "end, C W H": 1.49e-7},
        "adhesion",
    ),
    "stress": lambda: stress_figure(_stress_runs(), [{"energy_gain_ratio": 1e-7}]),
    "shapes": lambda: plot_shapes(),
}


@pytest.mark.parametrize("name", list(FIGURES))
def test_figure_has_no_text_on_text(name: str) -> None:
    assert_clean_layout(FIGURES[name]())


@pytest.mark.parametrize(
    "case",
    [
        dict(preset="paper", field=(20.0, 150.0), dt=5e-5),  # limited by dt
        dict(preset="aluminum", field=(100.0, 100.0), dt=5e-5, offset_deg=30.0, offset_axis=(0.0, 0.0, 1.0)),  # not checked
    ],
    ids=["limited", "not_checked"],
)
def test_step_check_figure(case: dict[str, Any], tmp_path: Path) -> None:
    kw = dict(case)
    res = tumblemc.check_step("cuboid", kw.pop("preset"), field=tumblemc.fields.Rotating(*kw.pop("field")), duration_s=0.2, **kw)
    fig = plot_step_check(res, tmp_path / "check.png")
    assert_clean_layout(fig)
    assert (tmp_path / "check.png").stat().st_size > 10_000
    assert res.cls in fig.texts[0].get_text() and "nan" not in fig.texts[0].get_text()
    assert len(fig.axes[0].lines) == 2 + res.twin_ratios.size + 1  # the run, the finer run, the twins, the no-slip line


@pytest.mark.parametrize("k", [0, 1], ids=["flat", "incline"])
def test_run_figure(runs_1: list[xr.Dataset], k: int) -> None:
    assert_clean_layout(plot_run(runs_1[k]))


def test_study_figures(example: tuple[xr.Dataset, xr.Dataset]) -> None:
    runs, maps = example
    for fig in (plot_success_heatmap(maps), plot_success_curves(maps), plot_ratio_distribution(runs)):
        assert_clean_layout(fig)


def test_critical_study_figures(example_critical: tuple[xr.Dataset, xr.Dataset]) -> None:
    runs, maps = example_critical
    assert_clean_layout(plot_critical_distribution(runs))
    assert_clean_layout(plot_success_curves(maps))


def test_success_curves_keep_every_interval_visible() -> None:
    """Shapes are offset along x and drawn as bars, so no interval hides behind another."""
    runs = synthetic_runs(per_cell=30)
    fig = plot_success_curves(study_maps(runs))
    ax = fig.axes[0]
    assert not ax.collections or all(type(c).__name__ == "LineCollection" for c in ax.collections)  # bars, no filled bands
    xs = [np.asarray(ln.get_xdata(), dtype=float) for ln in ax.get_lines() if len(ln.get_xdata()) > 1 and ln.get_linestyle() != "None"]
    assert len(xs) >= 2 and not np.allclose(xs[0], xs[1])


def test_sensitivity_figures() -> None:
    des = saltelli_design(2**6, 3, seed=4)
    lo, hi = np.array(ISHIGAMI_BOUNDS).T
    ind = sobol_indices(*split_saltelli(ishigami(lo + des.stack() * (hi - lo)), 3), n_boot=20)
    runs = synthetic_runs(per_cell=30)
    figs = [
        plot_sobol(ind),
        plot_success_vs_parameter(runs, "curved", "paper", 0.0),
        plot_success_vs_parameter(runs, "cuboid", "paper"),
        plot_prim(failure_region(runs, "curved", "paper", 0.0).trajectory),
    ]
    for fig in figs:
        assert_clean_layout(fig)
