"""Write the notebooks in notebooks/ from the cell sources below, executed.

    pip install ".[notebooks]"
    python tools/make_notebooks.py            # write and execute all five (about 4 min)
    python tools/make_notebooks.py --no-execute

The notebooks are generated so that their text lives in one reviewable file; edit here,
regenerate, commit. They are committed with their outputs, so their figures can be read on
the repository page; tests/test_notebooks.py checks that the committed outputs come from
the current sources (fast tier) and executes them again (slow tier).
"""

from __future__ import annotations

from pathlib import Path

import nbformat
from nbformat.v4 import new_code_cell, new_markdown_cell, new_notebook

ROOT = Path(__file__).resolve().parents[1]

QUICKSTART = [
    (
        "md",
        """# 01 Quickstart: one tumbling microrobot

tumblemc simulates a rigid magnetic microrobot tumbling under a rotating magnetic field on a
flat or inclined substrate, with point, line and face contact, ellipsoidal friction and
adhesion proportional to the contact area (Xie et al., IDETC 2019; conventions in MODEL.md).

Here: simulate one robot, look at its gait, animate it, and compare the four shapes.""",
    ),
    (
        "code",
        """import matplotlib
matplotlib.use("Agg")  # plots are saved and shown inline below; works headless in CI
from pathlib import Path
from IPython.display import Image, display

import tumblemc
from tumblemc.viz.run import plot_run, plot_shapes

out = Path("notebook_outputs")
out.mkdir(exist_ok=True)""",
    ),
    (
        "md",
        """## One run

The paper robot (Table 1) on a 30 degree paper incline, 20 mT at 1 Hz, for two field
periods. Every parameter of the preset can be overridden by name (here the friction
coefficient). `simulate` returns an `xarray.Dataset` with units on every variable.""",
    ),
    (
        "code",
        """ds = tumblemc.simulate(shape="cuboid", preset="paper", incline_deg=30.0,
                       field_mT=20.0, freq_hz=1.0, duration_s=2.0, mu=0.3)
ds[["progress", "contact_mode", "adhesion_force", "newton_iterations"]]""",
    ),
    (
        "code",
        """summary = tumblemc.summarize(ds)
{k: summary[k] for k in ("mean_speed", "ideal_speed", "progress_ratio", "climbed", "failed_steps")}""",
    ),
    (
        "md",
        """`progress_ratio` is the mean uphill speed after the first period over the no-slip speed
(hull perimeter x frequency); the robot *climbs* when it is at least 0.5.

The run figure: progress against the no-slip line, the contact mode with the adhesion
force (face contact adheres with the face's area, line contact with a small fraction),
and side-view snapshots of the tumble.""",
    ),
    (
        "code",
        """fig = plot_run(ds, out / "run.png")
display(Image(filename=out / "run.png", width=800))""",
    ),
    (
        "md",
        """## Animate the tumble

A GIF side view: body outline, field direction, equivalent contact point and whether the
contact adheres. (`tumblemc animate run.nc` does the same from a saved run.)""",
    ),
    (
        "code",
        """from tumblemc.viz.animation import animate_run

gif = animate_run(ds, out / "tumble.gif", max_frames=40, fps=10)
display(Image(filename=gif))""",
    ),
    (
        "md",
        """## Compare the four shapes

The shape library holds the paper's four robots (MODEL.md dimensions); each is its convex
hull with the real material area of each hull face (line contact where a hull face only
bridges edges). By default the new shapes take the aluminum robot's mass, inertia and
magnetisation, as in the paper.""",
    ),
    (
        "code",
        """plot_shapes(path=out / "shapes.png")
display(Image(filename=out / "shapes.png", width=800))""",
    ),
    (
        "code",
        """rows = []
for shape in tumblemc.shapes.SHAPES:
    s = tumblemc.summarize(tumblemc.simulate(shape=shape, preset="aluminum", freq_hz=10.0, duration_s=0.4))
    rows.append((shape, round(s["mean_speed"] * 1e3, 2), round(s["progress_ratio"], 3)))
print(f"{'shape':12s} {'mm/s':>6s} {'ratio':>6s}")
for r in rows:
    print(f"{r[0]:12s} {r[1]:6.2f} {r[2]:6.3f}")""",
    ),
    (
        "md",
        """At 10 Hz on flat aluminum the larger hull perimeters of the spiked and curved shapes
give them more distance per revolution; `tumblemc validate` reproduces the paper's whole
shape comparison with longer runs (docs/guide/validation.md).""",
    ),
]

EXPLORE = [
    (
        "md",
        """# 02 Explore a study's results

A robustness study (`tumblemc study run STUDY.toml`) writes one netCDF file with two groups:
`runs` (one row per simulated robot: sampled parameters, outcome, status) and `maps`
(success probability per shape x incline x substrate with confidence intervals). This
notebook opens the small study shipped in `data/example.nc` (regenerate it with
`tumblemc study run studies/example.toml --out data/example.nc --fresh`).""",
    ),
    (
        "code",
        """import matplotlib
matplotlib.use("Agg")
from pathlib import Path
from IPython.display import Image, display

import numpy as np
import xarray as xr
import tumblemc
from tumblemc.io import open_result
from tumblemc.viz.study import plot_ratio_distribution, plot_success_curves, plot_success_heatmap

DATA = Path("..") / "data" / "example.nc"
out = Path("notebook_outputs")
out.mkdir(exist_ok=True)
runs, maps = open_result(DATA)
maps""",
    ),
    (
        "md",
        """The file is plain netCDF4 with CF attributes: `xarray.open_datatree` opens both groups
at once, and every variable carries `units` and `long_name`.""",
    ),
    (
        "code",
        """tree = xr.open_datatree(DATA)
print(tree.attrs["title"], "|", tree.attrs["tumblemc_version"], "| seed", tree.attrs["seed"])
print({k: tree["maps"]["p_success"].attrs[k] for k in ("long_name", "units", "ancillary_variables")})
tree.close()""",
    ),
    (
        "md",
        """## Slicing the maps

`p_success` is the fraction of valid runs that climbed; `p_success_lower`/`_upper` are its
95% Wilson interval (never of zero width, also at 0/N and N/N).""",
    ),
    (
        "code",
        """cub = maps.sel(shape="cuboid", substrate="aluminum")
for th in cub.incline_deg.values:
    c = cub.sel(incline_deg=th)
    print(f"{th:4.0f} deg: p = {float(c.p_success):.2f}  [{float(c.p_success_lower):.2f}, {float(c.p_success_upper):.2f}]  n_valid = {int(c.n_valid)}")""",  # noqa: E501 (notebook text, kept as the reader sees it)
    ),
    (
        "code",
        """plot_success_heatmap(maps, path=out / "heatmap.png")
display(Image(filename=out / "heatmap.png", width=800))""",
    ),
    (
        "code",
        """plot_success_curves(maps, path=out / "curves.png")
display(Image(filename=out / "curves.png", width=800))""",
    ),
    (
        "md",
        """## Back to the runs

Each run keeps its sampled parameters, so any question is a selection away: for instance,
the friction coefficient of the cuboid runs on aluminum at 25 degrees that climbed and
those that did not.""",
    ),
    (
        "code",
        """sel = runs.where((runs.shape == "cuboid") & (runs.substrate == "aluminum") & (runs.incline_deg == 25), drop=True)
ok = sel.status == 0
for verdict in (1, 0):
    mu = sel.mu.where(ok & (sel.climbed == verdict), drop=True).values
    print(f"climbed={verdict}: {mu.size} runs, mu {np.round(np.sort(mu), 3)}")""",
    ),
    (
        "code",
        """plot_ratio_distribution(runs, path=out / "ratios.png")
display(Image(filename=out / "ratios.png", width=800))""",
    ),
    (
        "md",
        """## How good are the numbers?

Two things bound the confidence in a map: sampling (the intervals above) and numerics.
A random subset of runs was re-simulated at a 4x finer time step; the file stores the
verdict agreement.""",
    ),
    (
        "code",
        """from tumblemc.analysis.words import check_summary
check_summary(runs)""",
    ),
]

SENSITIVITY = [
    (
        "md",
        """# 03 Sensitivity: where does each shape stop climbing, and why?

Three questions on the shipped study files (`data/`, regenerated by the commands in
`data/README.md`):

1. **Where** does a robot stop climbing? The critical incline of every parameter sample,
   found by bisection on the incline, gives P(climb theta) as a whole curve.
2. **Which** uncertain parameter decides it? Rank correlations and a logistic regression
   on any study; Sobol indices, checked first on a function with a known answer.
3. **In what region** of parameter space does it fail? A PRIM box search.""",
    ),
    (
        "code",
        """import matplotlib
matplotlib.use("Agg")
from pathlib import Path
from IPython.display import Image, display

import numpy as np
import tumblemc
from tumblemc.io import open_result
from tumblemc.analysis import prim, screening, sobol
from tumblemc.testing import ishigami, ishigami_indices
from tumblemc.viz.sensitivity import plot_prim, plot_sobol, plot_success_vs_parameter
from tumblemc.viz.study import plot_success_curves

out = Path("notebook_outputs")
out.mkdir(exist_ok=True)
runs, maps = open_result(Path("..") / "data" / "example.nc")
crit_runs, crit_maps = open_result(Path("..") / "data" / "example_critical.nc")""",
    ),
    (
        "md",
        """## 1. Critical incline per sample

In `mode = "critical_incline"` one run is one parameter sample: the engine simulates both
ends of the incline range and bisects. P(climb theta) is the fraction of samples whose
critical incline is at least theta, with a Wilson band.""",
    ),
    (
        "code",
        """print(crit_runs[["critical_incline_deg", "censored", "n_simulations"]].to_dataframe().groupby("shape").describe().T.round(2))
plot_success_curves(crit_maps, path=out / "critical_curves.png")
display(Image(filename=out / "critical_curves.png", width=700))""",
    ),
    (
        "md",
        """The bisection assumes that a sample which climbs an incline climbs every gentler one.
The engine checked it on a subset by simulating every grid incline directly:""",
    ),
    (
        "code",
        """a = crit_runs.attrs
print(f"{a['monotonicity_checked_samples']} samples checked at {crit_runs.sizes['check_incline_deg']} inclines: "
      f"disagreement rate {a['monotonicity_disagreement_rate']:.3f}, non-monotone samples {a['monotonicity_nonmonotone_samples']}")
print(f"simulations: {a['simulations_total']} for the curve vs {a['simulations_grid_equivalent']} for the grid it replaces")""",
    ),
    (
        "md",
        """## 2. Which parameter decides?

Rank correlation of each sampled parameter with the progress ratio, per cell (valid runs
only), and a logistic regression of the binary outcome on standardized parameters.""",
    ),
    (
        "code",
        """rc = screening.rank_correlation(runs)
rc["rho"].sel(substrate="aluminum").to_dataframe()["rho"].unstack("parameter").round(2)""",
    ),
    (
        "md",
        """A binary outcome carries information only where it varies: the cells where some runs
climb and some do not (the transition inclines).""",
    ),
    (
        "code",
        """mixed = [(str(s), str(p), float(t)) for s in maps.shape.values for p in maps.substrate.values for t in maps.incline_deg.values
         if 0 < float(maps.p_success.sel(shape=s, substrate=p, incline_deg=t)) < 1]
print("cells with both outcomes:", mixed)
shape, substrate, theta = mixed[0]
lg = screening.logistic_summary(runs)
lg["coef"].sel(shape=shape, substrate=substrate, incline_deg=theta).to_pandas().round(2)""",
    ),
    (
        "code",
        """plot_success_vs_parameter(runs, shape, substrate, theta, path=out / "vs_parameter.png")
display(Image(filename=out / "vs_parameter.png", width=800))""",
    ),
    (
        "md",
        """### Sobol indices, tested on a known answer first

Variance-based indices need a dedicated Saltelli design. Before trusting the estimator on
the robot, it must reproduce the closed-form indices of the Ishigami function:""",
    ),
    (
        "code",
        """d = sobol.saltelli_design(2**11, 3, seed=1)
lo, hi = -np.pi, np.pi
f = lambda U: ishigami(lo + (hi - lo) * U)
idx = sobol.sobol_indices(f(d.A), f(d.B), np.stack([f(ab) for ab in d.AB]), names=["x1", "x2", "x3"], n_boot=500)
exact = ishigami_indices()
for i, name in enumerate(["x1", "x2", "x3"]):
    print(f"{name}: S1 {float(idx.S1[i]):.3f} [{float(idx.S1_lower[i]):.3f}, {float(idx.S1_upper[i]):.3f}] exact {exact['S1'][i]:.3f};"
          f"  ST {float(idx.ST[i]):.3f} [{float(idx.ST_lower[i]):.3f}, {float(idx.ST_upper[i]):.3f}] exact {exact['ST'][i]:.3f}")
plot_sobol(idx, out / "sobol_ishigami.png")
display(Image(filename=out / "sobol_ishigami.png", width=600))""",
    ),
    (
        "md",
        """On the robot, `tumblemc.study.sobol.robot_sobol(config, shape, substrate, incline_deg, n=64)` runs such a
design (`n (d + 2)` simulations, a few minutes for n = 64 and the four default
uncertainties) and returns the indices of the progress ratio; `tumblemc.study.sobol.sobol_rows` gives the
design alone, to run it on a cluster.

## 3. Where does it fail?

PRIM peels the parameter box where the cell's valid runs failed to climb, trading
coverage (share of all failures inside) for density (share of runs inside that fail).""",
    ),
    (
        "code",
        """box = prim.failure_region(runs, shape, substrate, theta)
print(f"{shape} on {substrate} at {theta} deg fails in {box.box}: coverage {box.coverage:.2f}, density {box.density:.2f}")
plot_prim(box, out / "prim.png")
display(Image(filename=out / "prim.png", width=600))""",
    ),
]


CALIBRATE = [
    (
        "md",
        """# 04 Calibrate, then study: bench data -> posterior -> robustness map

A lab measures its own robot before it trusts a simulator. Here the "lab" is synthetic: a
paper-preset cuboid whose electrostatic force and magnetisation offset differ from the
preset (F_elect = 2.5 uN instead of 3.2, offset 22 deg instead of 27), seen through a
static-tilt bench test with 0.5 deg of measurement noise. We fit both parameters to the
data, keep the posterior with its correlation, and run the same robustness study twice:
sampling the posterior, and with the preset's nominal values. Method and coverage:
`docs/guide/calibration.md`; the static-tilt test and its closed form: `docs/guide/lab.md`.""",
    ),
    (
        "code",
        """import matplotlib
matplotlib.use("Agg")  # figures are saved and shown inline; works headless in CI
from pathlib import Path
from IPython.display import Image, display
import numpy as np

from tumblemc.lab import calibrate as C
from tumblemc import lab
from tumblemc.io import open_result
from tumblemc.study.engine import run_study
from tumblemc.viz.calibrate import plot_calibration
from tumblemc.viz.lab import plot_static_tilt

out = Path("notebook_outputs")
out.mkdir(exist_ok=True)""",
    ),
    (
        "md",
        """## 1. Bench data

`lab.static_tilt` simulates the bench test: a static field straight down, 3 to 15 mT; the
robot snaps off its face above the lift-off field and rocks about its equilibrium, which
is detected where its angular acceleration changes sign. The "measured" tilts are the
simulated equilibria of the true robot plus noise, written as the CSV a lab would have.""",
    ),
    (
        "code",
        """truth = {"F_elect": 2.5e-6, "offset_deg": 22.0}
fields = np.arange(3.0, 15.5, 1.0)
bench = lab.static_tilt(fields, **truth)
measured = bench["tilt_deg"].values + np.random.default_rng(42).normal(0.0, 0.5, fields.size)
C.write_bench(out / "bench_tilt.csv", "field_mT", "tilt_deg", fields, measured)
plot_static_tilt(bench, out / "bench.png")
display(Image(filename=out / "bench.png", width=560))
print((out / "bench_tilt.csv").read_text()[:120])""",
    ),
    (
        "md",
        """## 2. Calibration

Least squares on the free fields, then the posterior sampled by MCMC (emcee) with the
exact likelihood. The closed-form edge balance is the forward model here (it matches the
simulator to 0.002 deg for this robot and costs microseconds); `model="simulate"` runs the
simulator instead, for any shape, in about two and a half minutes for this data set, with
a Laplace posterior as the fallback (MCMC would need tens of thousands of runs). The
command line does the same: `tumblemc calibrate static-tilt bench_tilt.csv --free
F_elect,offset_deg --model closed-form --out calib.nc --plot`.""",
    ),
    (
        "code",
        """post = C.calibrate(out / "bench_tilt.csv", ["F_elect", "offset_deg"], model="closed-form")
for name in ("F_elect", "offset_deg"):
    lo, hi = np.quantile(post[name].values, [0.025, 0.975])
    print(f"{name}: estimate {float(post['estimate_' + name]):.4g}, 95% [{lo:.4g}, {hi:.4g}], truth {truth[name]:g}")
print("correlation", np.corrcoef(post["F_elect"], post["offset_deg"])[0, 1].round(2))
post.to_netcdf(out / "calib.nc")
plot_calibration(post, out / "calib.png")
display(Image(filename=out / "calib.png", width=900))""",
    ),
    (
        "md",
        """Freeing the adhesion coefficient too: on the edge the robot feels `C` only through the
line adhesion `C w W`, a thousandth of its weight, so the tilts above the lift-off say
little about it; the lift-off itself brackets it (the last flat and the first lifted
field). The sampled posterior uses that step. The report gives the intervals, the
posterior predictive check, the bounds the posterior presses on and the preset values the
data rule out.""",
    ),
    (
        "code",
        """three = C.calibrate(out / "bench_tilt.csv", ["F_elect", "offset_deg", "adhesion_C"], model="closed-form")
print("\\n".join(C.report(three)))""",
    ),
    (
        "md",
        """## 3. A robustness study that samples the posterior

`[uncertain] posterior = "calib.nc"` gives each run one whole posterior draw (the
correlation is kept), chosen by the run's own seed; friction stays uncertain as usual.
The same study with the preset's nominal F_elect and offset is the comparison. 20 samples
per incline keep this notebook short; the intervals say how far to trust each cell.""",
    ),
    (
        "code",
        """base = dict(shapes=["cuboid"], presets=["paper"], incline_deg={"start": 0, "stop": 60, "step": 10},
            field_mT=[20.0], freq_hz=[1.0], samples=20, seed=4, periods=2,
            check={"fraction": 0.02, "min_runs": 1, "dt_factor": 2})
mu = {"dist": "truncnormal", "rel_sd": 0.15}
studies = {
    "calibrated": {"posterior": str((out / "calib.nc").resolve()), "mu": mu},
    "nominal": {"mu": mu},
}
maps = {}
for name, uncertain in studies.items():
    res = run_study({**base, "name": name, "uncertain": uncertain}, out=out / f"{name}.nc", progress=False, fresh=True)
    maps[name] = open_result(res.path)[1]""",
    ),
    (
        "code",
        """import matplotlib.pyplot as plt

fig, ax = plt.subplots(figsize=(6, 4))
# the two studies side by side at each incline (1 deg apart), so neither's bars hide the other's
for k, (name, m) in enumerate(maps.items()):
    sel = m.sel(shape="cuboid", substrate="paper").squeeze()
    inc = sel["incline_deg"].values + (k - 0.5) * 1.0
    p = sel["p_success"].values
    err = [p - sel["p_success_lower"].values, sel["p_success_upper"].values - p]
    ax.errorbar(inc, p, yerr=err, fmt="os"[k] + "-", capsize=3, label=name)
ax.set_xlabel("incline (deg)")
ax.set_ylabel("P(climb)")
ax.set_ylim(-0.05, 1.05)
ax.grid(alpha=0.3)
ax.legend()
ax.set_title("Paper cuboid, 20 mT, 1 Hz: calibrated vs nominal parameters")
fig.savefig(out / "compare.png", dpi=120, bbox_inches="tight")
display(Image(filename=out / "compare.png", width=560))
for name, m in maps.items():
    print(name, m["p_success"].values.ravel().round(2))""",
    ),
    (
        "md",
        """Up to 30 deg both say the robot climbs. Above, the calibrated robot climbs less than
the preset predicts (the printed maps give the numbers; with 20 samples per cell, read
them with their intervals): a map built on the nominal parameters would overstate this
robot's reach on steep inclines. Which parameters the bench test pins down, and which it
leaves to the prior, is in the calibration's diagnostics.""",
    ),
]


DESIGN = [
    (
        "md",
        """# 05 Design search: which robot to build

The paper's purpose is to choose a robot's dimensions before fabricating it. tumblemc's
design families are shapes as functions of their dimensions; a design search evaluates
candidate designs on the same sampled robots (common random numbers), stops hopeless ones
early, proposes new ones from a Gaussian-process model told each estimate's noise, and
recommends the design the model believes best, re-estimated on fresh robots.

Here: a design family and its mass rules, a two-variable search end to end, and a
two-objective front. (A campaign at full size: `docs/notes/design_search.md`.)""",
    ),
    (
        "code",
        """import matplotlib
matplotlib.use("Agg")
from pathlib import Path
from IPython.display import Image, display
import xarray as xr

from tumblemc.design import build
from tumblemc.design.config import parse_design
from tumblemc.design.search import search
from tumblemc.viz.design import plot_design
from tumblemc.viz.run import plot_shapes

out = Path("notebook_outputs")
out.mkdir(exist_ok=True)""",
    ),
    (
        "md",
        """## A design family

`build(family, dims, preset, mass_rule)` gives the shape and the mass and magnetic volume its
runs use. `density` (default): the preset cuboid's density and magnetised share over the
real volume; `ends`: only the end segments magnetised; `fixed`: the authors' assumption
(mass, inertia and magnetic volume of the preset robot whatever the dimensions). A design
that cannot be built is refused with the reason.""",
    ),
    (
        "code",
        """UM = 1e-6
for dims in ({"spike_base": 100 * UM, "spike_height": 125 * UM}, {"spike_base": 350 * UM, "spike_height": 300 * UM}):
    for rule in ("fixed", "density", "ends"):
        d = build("spiked_ends", dims, "aluminum", rule)
        print(f"{dims['spike_base'] / UM:4.0f} x {dims['spike_height'] / UM:4.0f} um  {rule:8s} mass {d.mass * 1e9:6.1f} ug  "
              f"V_m {d.V_m * 1e9:.4f} mm^3  hull perimeter {d.shape.hull_perimeter / UM:.0f} um")
try:
    build("spiked_ends", {"spike_base": 500 * UM})
except ValueError as e:
    print("refused:", e)
fig = plot_shapes([build("spiked_ends", {"spike_base": 350 * UM, "spike_height": 300 * UM}).shape], out / "design_shape.png")
display(Image(out / "design_shape.png"))""",
    ),
    (
        "md",
        """## A two-variable search

Spike base and spike height of the spiked-ends robot, each 50-400 um, for the fastest
mean speed on flat paper at 10 Hz, with the studies' default uncertainties (friction,
adhesion, magnetisation offset and magnitude). Small on purpose (16 robots per design, a
budget of 400 simulations: about half a minute); `studies/design_spiked_ends.toml` is
the full-size problem. The same problem as a TOML file runs with
`tumblemc design run file.toml --plot`.""",
    ),
    (
        "code",
        """problem = {
    "name": "nb_speed", "family": "spiked_ends", "seed": 1, "strategy": "gp",
    "budget": 400, "samples": 16, "stage": 8, "initial": 6, "batch": 2, "confirm": 32,
    "variables": {"spike_base": {"bounds": [50e-6, 400e-6]}, "spike_height": {"bounds": [50e-6, 400e-6]}},
    "objectives": [{"kind": "speed", "substrate": "paper", "freq_hz": 10}],
}
path = search(parse_design(problem), out / "nb_speed.nc", fresh=True, progress=False)
tree = xr.open_datatree(path)
designs = tree["designs"].to_dataset()
rec = tree.attrs["recommended"]
print(f"{designs.sizes['design']} designs, {tree.attrs['simulations']} simulations; recommended design {rec}:")
print(designs.isel(design=rec)[["spike_base", "spike_height", "speed10Hz_paper", "model_mean"]].to_pandas() * [1e6, 1e6, 1, 1])
print("on fresh robots:", tree["confirm"].to_dataset().to_pandas())""",
    ),
    (
        "code",
        """for p in plot_design(tree, out / "nb_speed"):
    display(Image(p))""",
    ),
    (
        "md",
        """The recommended design is the model's best, not the largest raw estimate (a design can be
lucky on its few robots), and the number reported for it comes from robots the search never
saw. Every robot's value is in the `runs` group: `design`, `task` (objective), `sample`
(the robot, the same for every design) and `value`.""",
    ),
    (
        "code",
        """runs = tree["runs"].to_dataset()
search_robots = (runs.stream == 0) & (runs.task == 0)
table = runs[["design", "sample", "value"]].where(search_robots, drop=True).to_pandas()
print(table.astype({"design": int, "sample": int}).pivot(index="design", columns="sample", values="value").head(4).round(1))""",
    ),
    (
        "md",
        """## Two objectives: a Pareto front

Climbing a 20 degree aluminum incline at 10 Hz and the speed on paper pull the spikes in
different directions. With two objectives the result holds the Pareto set of the estimates
with their intervals; no single design is recommended.""",
    ),
    (
        "code",
        """front = dict(problem, name="nb_front", budget=600, confirm=0, objectives=[
    {"kind": "climb", "substrate": "aluminum", "incline_deg": 20, "freq_hz": 10},
    {"kind": "speed", "substrate": "paper", "freq_hz": 10},
])
tree2 = xr.open_datatree(search(parse_design(front), out / "nb_front.nc", fresh=True, progress=False))
d2 = tree2["designs"].to_dataset()
pareto = d2.isel(design=d2.pareto.values)[["spike_base", "spike_height", "climb20_aluminum", "speed10Hz_paper"]].to_pandas()
print(pareto.assign(spike_base=pareto.spike_base * 1e6, spike_height=pareto.spike_height * 1e6).round(3))
for p in plot_design(tree2, out / "nb_front"):
    display(Image(p))""",
    ),
]


def build(cells: list[tuple[str, str]]) -> nbformat.NotebookNode:
    nb = new_notebook()
    nb.cells = [new_markdown_cell(src) if kind == "md" else new_code_cell(src) for kind, src in cells]
    nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3", "language": "python"}
    nb.metadata["language_info"] = {"name": "python"}
    return nb


NOTEBOOKS = {
    "01_quickstart.ipynb": QUICKSTART,
    "02_explore_results.ipynb": EXPLORE,
    "03_sensitivity.ipynb": SENSITIVITY,
    "04_calibrate_and_study.ipynb": CALIBRATE,
    "05_design.ipynb": DESIGN,
}


def execute(nb: nbformat.NotebookNode, folder: Path, timeout: int = 900) -> nbformat.NotebookNode:
    """Run ``nb`` top to bottom in ``folder`` (nbclient); outputs without timing metadata."""
    from nbclient import NotebookClient

    NotebookClient(nb, timeout=timeout, kernel_name="python3", record_timing=False, resources={"metadata": {"path": str(folder)}}).execute()
    return nb


def main(argv: list[str] | None = None) -> None:
    import argparse
    import time

    ap = argparse.ArgumentParser(description="Write (and execute) the notebooks in notebooks/.")
    ap.add_argument("--no-execute", action="store_true", help="write them without outputs")
    ap.add_argument("names", nargs="*", help="only these notebooks (default: all)")
    args = ap.parse_args(argv)
    folder = ROOT / "notebooks"
    for name, cells in NOTEBOOKS.items():
        if args.names and name not in args.names and Path(name).stem not in args.names:
            continue
        nb = build(cells)
        t0 = time.perf_counter()
        if not args.no_execute:
            execute(nb, folder)
        nbformat.write(nb, folder / name)
        print(f"wrote notebooks/{name}" + ("" if args.no_execute else f" (executed in {time.perf_counter() - t0:.0f} s)"))


if __name__ == "__main__":
    main()
