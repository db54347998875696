"""Study analysis: binomial intervals against scipy, maps against a naive loop, figures and their legibility."""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from scipy.stats import binomtest

from tumblemc.analysis.maps import maps, proportion_ci
from tumblemc.analysis.words import check_summary
from tumblemc.viz.ratio import RATIO_LINEAR
from tumblemc.viz.study import plot_ratio_distribution, plot_study, plot_success_curves, plot_success_heatmap
from tumblemc.viz.style import MAX_FIG_W, format_penetration
from tumblemc.viz.validation import plot_adhesion_series, plot_convergence, plot_paper_inclines

# regression tolerances: closed form (Wilson) and beta quantiles (Clopper-Pearson) against
# scipy's formula and root finding (measured: at most 5e-13 apart).
WILSON_ATOL = 1e-13
EXACT_ATOL = 1e-11

SHAPES = ("cuboid", "cylinder", "spiky")
SUBSTRATES = ("paper", "aluminum")
INCLINES = (0.0, 15.0, 30.0, 45.0)


def synthetic_runs(seed: int = 7, per_cell: int = 12, fields: tuple[float, ...] = (10.0,), check: bool = True) -> xr.Dataset:
    """Build a runs Dataset with the study's schema.

    Outcomes depend on incline and substrate, some runs fail (status 1..3), one cell has
    no valid run, one cell is all successes.
    """
    rng = np.random.default_rng(seed)
    rows = list(itertools.product(SHAPES, SUBSTRATES, INCLINES, fields, range(per_cell)))
    n = len(rows)
    shape = np.array([r[0] for r in rows])
    substrate = np.array([r[1] for r in rows])
    incline = np.array([r[2] for r in rows])
    field = np.array([r[3] for r in rows])
    sample = np.array([r[4] for r in rows], dtype=np.int64)
    mu = rng.uniform(0.2, 0.6, n)
    base = 1.0 - incline / 60.0 - (substrate == "aluminum") * 0.2 + (field - 10.0) * 0.01
    ratio = np.clip(base + rng.normal(0.0, 0.2, n), -0.5, 1.2)
    status = rng.choice([0, 1, 2, 3], size=n, p=[0.85, 0.07, 0.05, 0.03]).astype(np.int8)
    dead = (shape == "spiky") & (substrate == "aluminum") & (incline == 45.0)
    status[dead] = 2  # a cell with no valid runs
    easy = (shape == "cuboid") & (substrate == "paper") & (incline == 0.0)
    status[easy] = 0
    ratio[easy] = 0.95  # k = n
    ratio[status != 0] = np.nan
    climbed = ((ratio >= 0.5) & (status == 0)).astype(np.int8)
    ds = xr.Dataset(
        {
            "shape": ("run", shape),
            "substrate": ("run", substrate),
            "incline_deg": ("run", incline),
            "field_mT": ("run", field),
            "freq_hz": ("run", np.full(n, 5.0)),
            "sample": ("run", sample),
            "mu": ("run", mu, {"units": "1", "long_name": "friction coefficient"}),
            "progress_ratio": ("run", ratio),
            "mean_speed": ("run", np.where(status == 0, ratio * 1e-3, np.nan)),
            "climbed": ("run", climbed),
            "status": ("run", status),
            "newton_iterations": ("run", rng.uniform(2, 4, n)),
            "substeps": ("run", rng.integers(0, 3, n)),
            "failed_steps": ("run", np.where(status == 1, 2, 0).astype(np.int64)),
            "max_penetration": ("run", rng.uniform(0, 1e-9, n)),
        },
        attrs={"uncertain": "mu", "success_ratio": 0.5},
    )
    if check:
        sel = np.sort(rng.choice(n, size=20, replace=False)).astype(np.int64)
        fine = ratio[sel] + rng.normal(0.0, 0.01, sel.size)
        climbed_fine = ((fine >= 0.5) & np.isfinite(fine)).astype(np.int8)
        ds["check_run"] = ("check", sel)
        ds["check_progress_ratio_fine"] = ("check", fine)
        ds["check_climbed_fine"] = ("check", climbed_fine)
        ds["check_agree"] = ("check", (climbed_fine == climbed[sel]).astype(np.int8))
        ds["check_status_fine"] = ("check", np.where(np.arange(sel.size) == 3, 1, 0).astype(np.int8))
        ds.attrs["check_dt_factor"] = 2.0  # fine step dt / 2
    return ds


@pytest.fixture(scope="module")
def runs() -> xr.Dataset:
    return synthetic_runs()


@pytest.fixture(scope="module")
def study_maps(runs: xr.Dataset) -> xr.Dataset:
    return maps(runs)


KN = [(k, n) for n in (1, 2, 3, 5, 10, 17, 50, 200) for k in sorted({0, 1, n // 3, n // 2, n - 1, n})]


@pytest.mark.parametrize("level", [0.9, 0.95, 0.99])
@pytest.mark.parametrize(("method", "scipy_method", "atol"), [("wilson", "wilson", WILSON_ATOL), ("clopper-pearson", "exact", EXACT_ATOL)])
def test_proportion_ci_matches_scipy(level: float, method: str, scipy_method: str, atol: float) -> None:
    k = np.array([kn[0] for kn in KN])
    n = np.array([kn[1] for kn in KN])
    lo, hi = proportion_ci(k, n, level, method)
    assert lo.shape == hi.shape == k.shape
    for i, (kk, nn) in enumerate(KN):
        ref = binomtest(int(kk), int(nn)).proportion_ci(confidence_level=level, method=scipy_method)
        np.testing.assert_allclose([lo[i], hi[i]], [ref.low, ref.high], rtol=0, atol=atol, err_msg=f"k={kk}, n={nn}")
    zero, full = k == 0, k == n
    assert np.all(lo[zero] == 0.0) and np.all((hi[zero] > 0.0) & (hi[zero] < 1.0))
    assert np.all(hi[full] == 1.0) and np.all((lo[full] > 0.0) & (lo[full] < 1.0))
    assert np.all(hi - lo > 0.0)


@pytest.mark.parametrize("method", ["wilson", "clopper-pearson"])
def test_proportion_ci_edge_cases(method: str) -> None:
    lo, hi = proportion_ci(np.array([0, 0, 3]), np.array([0, 4, 3]), method=method)
    assert np.isnan(lo[0]) and np.isnan(hi[0])
    assert lo[1] == 0.0 and hi[2] == 1.0
    slo, shi = proportion_ci(2, 5, method=method)  # scalars in, scalars out
    assert np.ndim(slo) == 0 and 0.0 < slo < 0.4 < shi < 1.0
    lo2, _ = proportion_ci(np.array([[1], [2]]), np.array([4, 8]), method=method)  # broadcasting
    assert lo2.shape == (2, 2)
    for k, n in [(3, 2), (-1, 2), (0.5, 2)]:
        with pytest.raises(ValueError, match="k"):
            proportion_ci(k, n, method=method)
    with pytest.raises(ValueError, match="level"):
        proportion_ci(1, 2, level=1.0, method=method)
    with pytest.raises(ValueError, match="method"):
        proportion_ci(1, 2, method="wald")


def test_maps_layout_and_metadata(study_maps: xr.Dataset) -> None:
    m = study_maps
    assert m["p_success"].dims == ("shape", "incline_deg", "substrate")
    assert list(m["shape"].values) == sorted(SHAPES)
    assert list(m["substrate"].values) == sorted(SUBSTRATES)
    assert list(m["incline_deg"].values) == sorted(INCLINES)
    assert m["field_mT"].ndim == 0 and float(m["field_mT"]) == 10.0  # not swept: scalar coord
    assert m["freq_hz"].ndim == 0
    assert m["progress_ratio_quantile"].dims == ("shape", "incline_deg", "substrate", "quantile")
    for name in list(m.data_vars) + list(m.coords):
        if name in ("shape", "substrate"):
            assert "long_name" in m[name].attrs
            continue
        assert "units" in m[name].attrs and "long_name" in m[name].attrs, name
    assert m["p_success"].attrs["ancillary_variables"] == "p_success_lower p_success_upper n_valid n_failed"
    for name in ("p_success_lower", "p_success_upper"):
        assert m[name].attrs["ci_method"] == "wilson" and m[name].attrs["confidence_level"] == 0.95
    for name in ("n_success", "n_valid", "n_failed", "n_runs"):
        assert m[name].dtype == np.int64


def test_maps_counts_match_naive_loop(runs: xr.Dataset, study_maps: xr.Dataset) -> None:
    m = study_maps
    status = runs["status"].values
    for shp, inc, sub in itertools.product(SHAPES, INCLINES, SUBSTRATES):
        n_runs = n_valid = n_succ = 0
        ratios, speeds = [], []
        for i in range(runs.sizes["run"]):
            if runs["shape"].values[i] != shp or runs["substrate"].values[i] != sub or runs["incline_deg"].values[i] != inc:
                continue
            n_runs += 1
            if status[i] == 0:
                n_valid += 1
                n_succ += int(runs["climbed"].values[i] == 1)
                ratios.append(float(runs["progress_ratio"].values[i]))
                speeds.append(float(runs["mean_speed"].values[i]))
        c = m.sel(shape=shp, incline_deg=inc, substrate=sub)
        assert int(c["n_runs"]) == n_runs
        assert int(c["n_valid"]) == n_valid
        assert int(c["n_failed"]) == n_runs - n_valid
        assert int(c["n_success"]) == n_succ
        if n_valid == 0:
            for name in ("p_success", "p_success_lower", "p_success_upper", "progress_ratio_mean", "mean_speed_mean"):
                assert np.isnan(float(c[name])), name
            assert np.all(np.isnan(c["progress_ratio_quantile"].values))
            continue
        assert float(c["p_success"]) == n_succ / n_valid
        ref = binomtest(n_succ, n_valid).proportion_ci(confidence_level=0.95, method="wilson")
        np.testing.assert_allclose([float(c["p_success_lower"]), float(c["p_success_upper"])], [ref.low, ref.high], atol=WILSON_ATOL)
        np.testing.assert_allclose(float(c["progress_ratio_mean"]), np.mean(ratios), rtol=1e-12)
        np.testing.assert_allclose(float(c["mean_speed_mean"]), np.mean(speeds), rtol=1e-12)
        np.testing.assert_array_equal(c["progress_ratio_quantile"].values, np.quantile(ratios, m["quantile"].values))
    # the synthetic study has its edge cells
    assert int(m["n_valid"].sel(shape="spiky", substrate="aluminum", incline_deg=45.0)) == 0
    easy = m.sel(shape="cuboid", substrate="paper", incline_deg=0.0)
    assert float(easy["p_success"]) == 1.0 and float(easy["p_success_upper"]) == 1.0


def test_maps_order_invariant(runs: xr.Dataset, study_maps: xr.Dataset) -> None:
    perm = np.random.default_rng(123).permutation(runs.sizes["run"])
    assert maps(runs.isel(run=perm)).identical(study_maps)


def test_maps_clopper_pearson_and_quantiles(runs: xr.Dataset) -> None:
    m = maps(runs, level=0.9, method="clopper-pearson", quantiles=(0.9, 0.1))
    assert list(m["quantile"].values) == [0.1, 0.9]
    assert m["p_success_lower"].attrs["ci_method"] == "clopper-pearson"
    ok = m["n_valid"] > 0
    assert bool(((m["p_success_lower"] <= m["p_success"]) & (m["p_success"] <= m["p_success_upper"])).where(ok, True).all())
    with pytest.raises(ValueError, match="quantiles"):
        maps(runs, quantiles=(0.5, 1.5))
    with pytest.raises(ValueError, match="climbed"):
        maps(runs.drop_vars("climbed"))


def test_swept_field_adds_a_dim() -> None:
    r = synthetic_runs(seed=3, per_cell=4, fields=(5.0, 10.0), check=False)
    m = maps(r)
    assert m["p_success"].dims == ("shape", "incline_deg", "substrate", "field_mT")
    assert list(m["field_mT"].values) == [5.0, 10.0]
    assert m["field_mT"].attrs["units"] == "mT"
    assert m["freq_hz"].ndim == 0
    assert int(m["n_runs"].sum()) == r.sizes["run"]
    assert np.all(m["n_runs"].values == 4)


def test_check_summary(runs: xr.Dataset) -> None:
    sm = check_summary(runs)
    assert sm["n_checked"] == 20 and sm["dt_factor"] == 2.0 and sm["n_fine_not_ok"] == 1
    assert sm["agreement_rate"] == float(runs["check_agree"].values.mean())
    delta = np.abs(runs["check_progress_ratio_fine"].values - runs["progress_ratio"].values[runs["check_run"].values])
    delta = delta[np.isfinite(delta)]
    assert sm["n_compared"] == delta.size
    assert sm["median_abs_delta_ratio"] == np.median(delta)
    assert sm["max_abs_delta_ratio"] == np.max(delta)
    none = check_summary(runs.drop_vars([v for v in runs.variables if str(v).startswith("check_")]))
    assert none["n_checked"] == 0 and none["agreement_rate"] is None and none["median_abs_delta_ratio"] is None


def test_plots_write_pngs(runs: xr.Dataset, study_maps: xr.Dataset, tmp_path: Path) -> None:
    paths = plot_study(runs, study_maps, tmp_path / "fig")
    assert [p.name for p in paths] == ["success_heatmap.png", "success_curves.png", "ratio_distribution.png"]
    for p in paths:
        assert p.is_file() and p.stat().st_size > 1000
    one = plot_success_heatmap(study_maps, substrate="paper", path=tmp_path / "paper.png")
    assert len([ax for ax in one.axes if ax.get_title()]) == 1 and (tmp_path / "paper.png").stat().st_size > 0
    with pytest.raises(ValueError, match="glass"):
        plot_success_heatmap(study_maps, substrate="glass")


def test_plots_with_swept_field(tmp_path: Path) -> None:
    r = synthetic_runs(seed=5, per_cell=3, fields=(5.0, 10.0), check=False)
    m = maps(r)
    for func, arg in ((plot_success_heatmap, m), (plot_success_curves, m), (plot_ratio_distribution, r)):
        fig = func(arg, path=tmp_path / f"{func.__name__}.png")
        assert len([ax for ax in fig.axes if ax.get_title()]) == 2 * len(SUBSTRATES)
        assert (tmp_path / f"{func.__name__}.png").stat().st_size > 0


def test_bounds_with_invalid_runs() -> None:
    """One cell of 10 runs: 6 valid of which 4 climbed, 4 invalid (statuses 1-3)."""
    status = np.array([0, 0, 0, 0, 0, 0, 1, 2, 3, 1], dtype=np.int8)
    climbed = np.array([1, 1, 1, 1, 0, 0, 0, 0, 0, 0], dtype=np.int8)
    n = status.size
    runs = xr.Dataset(
        {
            "status": ("run", status),
            "climbed": ("run", climbed),
            "progress_ratio": ("run", np.linspace(-1, 1, n)),
            "mean_speed": ("run", np.zeros(n)),
        },
        coords={"shape": ("run", ["cuboid"] * n), "substrate": ("run", ["paper"] * n), "incline_deg": ("run", np.full(n, 10.0))},
    )
    c = maps(runs).isel(shape=0, substrate=0, incline_deg=0)
    assert (int(c["n_success"]), int(c["n_valid"]), int(c["n_failed"])) == (4, 6, 4)
    assert float(c["p_success"]) == 4 / 6
    assert float(c["p_success_invalid_as_failure"]) == 4 / 10
    assert float(c["p_success_invalid_as_success"]) == 8 / 10


# --- legibility of the study and validation figures ---------------------------


def _sliding_runs() -> xr.Dataset:
    """Synthetic runs where a third of the valid runs slide far down (ratios to -5000)."""
    r = synthetic_runs(seed=3, per_cell=6, check=False)
    ratio = r["progress_ratio"].values.copy()
    slide = np.isfinite(ratio) & (np.arange(ratio.size) % 3 == 0)
    ratio[slide] = -np.geomspace(3.0, 5000.0, int(slide.sum()))
    return r.assign(progress_ratio=("run", ratio))


def _axes_frac(ax: Axes, y: float) -> float:
    return float(ax.transAxes.inverted().transform(ax.transData.transform((0.0, y)))[1])


def test_ratio_axis_keeps_threshold_readable_when_runs_slide_away() -> None:
    fig = plot_ratio_distribution(_sliding_runs())
    panels = [ax for ax in fig.axes if ax.get_title()]
    assert len(panels) == len(SUBSTRATES)
    for ax in panels:
        lo, hi = ax.get_ylim()
        assert ax.get_yscale() == "symlog" and lo <= -5000.0 and lo < 0.5 < hi
        # the linear band around the threshold takes at least 40% of the height
        assert _axes_frac(ax, RATIO_LINEAR) - _axes_frac(ax, -RATIO_LINEAR) >= 0.4
        assert any(np.allclose(ln.get_ydata(), 0.5) for ln in ax.get_lines())  # the threshold line
        labels = [t.get_text() for t in ax.get_yticklabels()]
        assert "0" in labels and "1" in labels and "-1000" in labels


def test_ratio_axis_linear_when_ratios_are_small(runs: xr.Dataset) -> None:
    fig = plot_ratio_distribution(runs)
    for ax in (ax for ax in fig.axes if ax.get_title()):
        lo, hi = ax.get_ylim()
        assert ax.get_yscale() == "linear" and lo < 0.5 < hi


def _wide_maps(copies: int) -> xr.Dataset:
    """Maps with ``copies`` x 4 inclines: the synthetic runs repeated at shifted inclines."""
    r = synthetic_runs(seed=11, per_cell=4, check=False)
    parts = [r.assign(incline_deg=("run", r["incline_deg"].values + 0.25 * k)) for k in range(copies)]
    return maps(xr.concat(parts, dim="run"))


@pytest.mark.parametrize("copies", [1, 4, 12])
def test_heatmap_text_legible_and_inside_cells(copies: int) -> None:
    m = _wide_maps(copies)
    fig = plot_success_heatmap(m)
    assert fig.get_figwidth() <= MAX_FIG_W + 1.5
    renderer = FigureCanvasAgg(fig).get_renderer()
    fig.draw_without_rendering()
    nx, ny = m.sizes["incline_deg"], m.sizes["shape"]
    n_texts = 0
    for ax in (ax for ax in fig.axes if ax.get_title()):
        box = ax.get_window_extent()
        for t in ax.texts:
            n_texts += 1
            assert t.get_fontsize() >= 8.0
            assert t.get_window_extent(renderer).width <= box.width / nx  # within its cell's width
    if copies == 1:  # big cells: probability, interval and invalid count
        assert n_texts > nx * ny * len(SUBSTRATES)
        assert any("\u2013" in t.get_text() for ax in fig.axes for t in ax.texts)


def test_format_penetration_hides_round_off() -> None:
    assert format_penetration(7.11e-19) == "< 0.001 nm"
    assert format_penetration(0.0) == "< 0.001 nm"
    assert format_penetration(1.234e-8) == "12.3 nm"
    assert format_penetration(float("nan")) == "n/a"


def _texts_inside_figure(fig: Figure) -> None:
    """Nothing drawn (labels, titles, legends) sticks out of the figure."""
    renderer = FigureCanvasAgg(fig).get_renderer()
    fig.draw_without_rendering()  # the constrained layout
    tight = fig.get_tightbbox(renderer)
    frame = fig.bbox_inches
    assert tight.x0 >= frame.x0 - 0.01 and tight.y0 >= frame.y0 - 0.01
    assert tight.x1 <= frame.x1 + 0.01 and tight.y1 <= frame.y1 + 0.01


def test_convergence_figure_ticks_apart_and_every_case_on_scale() -> None:
    dts = (5e-4, 2.5e-4, 1e-4, 5e-5, 2.5e-5, 1.25e-5)
    table = [
        {"case": case, "torque": torque, "dt": dt, "progress_ratio": base + 100 * dt}
        for case, base in (("climbs", 1.0), ("slides", -40.0))
        for torque in ("start", "end")
        for dt in dts
    ]
    fig = plot_convergence(table, ["climbs", "slides"], mark_dt=5e-5)
    _texts_inside_figure(fig)
    renderer = FigureCanvasAgg(fig).get_renderer()
    for ax in fig.axes:
        lo, hi = ax.get_ylim()
        for ln in ax.get_lines():
            y = np.asarray(ln.get_ydata(), dtype=float)
            if y.size > 2:
                assert lo <= y.min() and y.max() <= hi
        boxes = sorted((t.get_window_extent(renderer) for t in ax.get_xticklabels() if t.get_text()), key=lambda b: b.x0)
        assert all(a.x1 < b.x0 for a, b in itertools.pairwise(boxes))


def test_validation_figures_keep_labels_inside() -> None:
    t = np.linspace(0.0, 2.0, 200)
    adh = np.where(np.sin(2 * np.pi * t) > 0.5, 1.19e-6, 1e-8)
    _texts_inside_figure(plot_adhesion_series(t, adh, {"face, C L W": 1.19e-6, "end, C W H": 1.49e-7}, "adhesion"))
    fig = plot_paper_inclines([("5 deg", t, 1e-3 * t), ("60 deg", t, -1.0 * t)], "inclines")
    _texts_inside_figure(fig)
    labels = [x.get_text() for x in fig.axes[0].get_legend().get_texts()]
    assert labels[0] == "5 deg" and "off the plot: -2,000 mm at 2 s" in labels[1]
