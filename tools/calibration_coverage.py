"""The calibration coverage campaign: writes docs/notes/calibration_coverage.md.

    python tools/calibration_coverage.py [--reps 50] [--out docs/notes/calibration_coverage.md] [--quick]

Each case draws synthetic static-tilt data sets at known parameters (noise-free tilts plus
normal noise), calibrates each with the closed-form model and the default posterior (MCMC,
emcee) and measures (tumblemc.lab.coverage): the share of 95% intervals holding the truth,
the share of posterior draws that tilt at every field where the data show a clear tilt
(> 3 noise sd), the share of held-out points (the truth at the midpoints between the data
fields, new noise) inside the 95% posterior predictive band, the fit time and the
autocorrelation time.

1. Three free parameters (F_elect, offset_deg, adhesion_C), simulated data: ``lab.static_tilt``
   (the simulator) of the paper cuboid at F_elect = 2.5e-6 N, offset_deg = 22, adhesion_C =
   5 N/m^2, 15 fields from 3 to 15 mT, 1 deg noise.
2. The same with adhesion_C at 1/50 of the preset's (0.0743 N/m^2): the robot lifts off
   below 4.7 mT, where the preset's adhesion holds it flat up to 7 mT; also with the
   Laplace posterior (``posterior="laplace"``), for comparison.
   Cases 1 and 2 are also run with the field grid shifted by a uniform offset (up to one
   field spacing) per replicate, closed-form data: a parameter that only the lift-off
   determines (adhesion_C) has a posterior flat between the last flat and the first lifted
   field, so the coverage of its intervals depends on where the truth's lift-off falls
   between two fields; shifting the grid averages over that.
3. Two free parameters (F_elect, offset_deg), closed-form data, 13 fields, 0.5 deg noise.
4. One replicate of case 1 with the simulator as the forward model (the Laplace fallback), timed.
5. Truths drawn from the prior (simulation-based calibration, ``--sbc`` replicates, first):
   each replicate's F_elect, offset_deg and adhesion_C drawn from the calibration's prior on
   :data:`PRIOR` (also its bounds), closed-form data, 1 deg noise. Averaged over the prior an
   exact posterior's 95% intervals hold the truth 95% of the time and the truth's rank among
   the draws is uniform, whatever the likelihood's shape; at a fixed truth (cases 1 and 2)
   a cliff-shaped likelihood promises neither. Figure: the ranks' histograms
   (``<out stem>_ranks.png``).

``--quick`` runs case 2 alone on closed-form data with 5 replicates (tests/lab/test_calibrate.py).
"""

from __future__ import annotations

import argparse
import platform
import time
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from tumblemc import lab
from tumblemc.lab.calibrate import BenchData, calibrate
from tumblemc.lab.coverage import coverage
from tumblemc.lab.mcmc import tilt_balance_batch
from tumblemc.model.params import get_preset

TRUTH: dict[str, Any] = {"F_elect": 2.5e-6, "offset_deg": 22.0, "adhesion_C": 5.0}
CLIFF: dict[str, Any] = {"F_elect": 2.5e-6, "offset_deg": 22.0, "adhesion_C": get_preset("paper").adhesion_C / 50}
FIELDS = [float(v) for v in np.linspace(3.0, 15.0, 15)]
SPACING = FIELDS[1] - FIELDS[0]
PRIOR: dict[str, tuple[float, float]] = {"F_elect": (1e-6, 1e-5), "offset_deg": (10.0, 35.0), "adhesion_C": (0.03, 30.0)}
HELDOUT = [float(v) for v in 0.5 * (np.asarray(FIELDS[1:]) + np.asarray(FIELDS[:-1]))]


def table(cov: xr.Dataset) -> list[str]:
    """The per-parameter coverage table and the prediction summary of one case."""
    lines = ["| parameter | coverage of the 95% intervals | mean width | flagged undetermined |", "|---|---|---|---|"]
    for p in cov["param"].values:
        c = cov.sel(param=p)
        lines.append(f"| {p} | {float(c['coverage']):.3f} | {float(c['mean_width']):.4g} | {float(c['undetermined_share']):.0%} |")
    lift = cov["liftoff_share"].values
    tau = cov["tau_max"].values
    lines += [
        "",
        "| measure | mean | min | max |",
        "|---|---|---|---|",
        f"| share of draws reproducing the lift-off the data show | {np.nanmean(lift):.3f} | {np.nanmin(lift):.3f} | "
        f"{np.nanmax(lift):.3f} |",
        f"| share of held-out points in the 95% predictive band | {cov['heldout_share'].mean():.3f} | "
        f"{cov['heldout_share'].min():.3f} | {cov['heldout_share'].max():.3f} |",
        f"| share of the data in their 95% predictive band | {cov['predictive_share'].mean():.3f} | "
        f"{cov['predictive_share'].min():.3f} | {cov['predictive_share'].max():.3f} |",
        f"| fit time (s, one core) | {cov['fit_s'].mean():.2f} | {cov['fit_s'].min():.2f} | {cov['fit_s'].max():.2f} |",
    ]
    if np.isfinite(tau).any():
        lines.append(f"| largest autocorrelation time (steps) | {np.nanmean(tau):.1f} | {np.nanmin(tau):.1f} | {np.nanmax(tau):.1f} |")
    n_lift, se = int(np.sum(np.isfinite(lift))), (0.95 * 0.05 / cov.attrs["n_rep"]) ** 0.5
    lines += [
        "",
        f"Replicates whose draws reproduce the lift-off in at least 90%: {int(np.sum(lift >= 0.9))} of {n_lift}. "
        f"Binomial standard error of a coverage at 95% with {cov.attrs['n_rep']} replicates: {se:.3f}.",
    ]
    return lines


def indistinguishable(truth: dict[str, Any], fields: Any, noise_deg: float, name: str = "adhesion_C") -> str:
    """The range of ``name`` (the others at the truth) whose noise-free tilts stay within noise/5 of the truth's, in words.

    Data from any truth in that range are alike to within a fifth of the noise, so no interval
    computed from them can hold one of those truths and not its neighbours; where the truth
    sits in the range sets the coverage of a central interval at that one truth.
    """
    from tumblemc.lab.bounds import default_bounds

    lo, hi, _ = default_bounds(name, "paper")
    x = np.asarray(fields, float)
    t0 = tilt_balance_batch(x, "paper", None, **truth)
    g = np.geomspace(lo, hi, 4001)
    t = tilt_balance_batch(x, "paper", None, **dict(truth, **{name: g[:, None]}))
    alike = np.abs(t - t0).max(axis=1) < noise_deg / 5.0
    i = int(np.clip(np.searchsorted(g, truth[name]), 0, g.size - 1))
    a, b = i, i
    while a > 0 and alike[a - 1]:
        a -= 1
    while b < g.size - 1 and alike[b + 1]:
        b += 1
    where = np.log(truth[name] / g[a]) / np.log(g[b] / g[a])
    edge = " (the lower bound)" if a == 0 else ""
    return (
        f"The data cannot tell {name} = {truth[name]:.4g} from any value in {g[a]:.4g}{edge} .. {g[b]:.4g}: the noise-free tilts "
        f"of the whole range stay within {noise_deg / 5:g} deg (a fifth of the noise) of the truth's, the other parameters "
        f"at the truth. The truth sits at {where:.0%} of that range on the log scale; a central interval at this one "
        "truth covers it as often as that place allows, not at its level."
    )


def sbc_lines(cov: xr.Dataset) -> list[str]:
    """Coverage, its binomial interval, and the uniformity of the truth's ranks, per parameter."""
    from scipy import stats

    n = cov.attrs["n_rep"]
    lines = [
        "| parameter | coverage of the 95% intervals | binomial 95% range at a true 0.95 | ranks uniform: KS p | chi-square p (10 bins) |",
        "|---|---|---|---|---|",
    ]
    lo, hi = stats.binom.ppf([0.025, 0.975], n, 0.95) / n
    for p in cov["param"].values:
        r = cov["rank"].sel(param=p).values
        ks = stats.kstest(r, "uniform").pvalue
        chi = stats.chisquare(np.histogram(r, bins=10, range=(0.0, 1.0))[0]).pvalue
        lines.append(f"| {p} | {float(cov['coverage'].sel(param=p)):.3f} | {lo:.3f} .. {hi:.3f} | {ks:.2f} | {chi:.2f} |")
    return lines


def rank_figure(cov: xr.Dataset, path: Path) -> None:
    """Histograms of the truth's rank among the posterior draws, one panel per parameter, with the uniform's 95% band."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from scipy import stats

    names = [str(p) for p in cov["param"].values]
    n, bins = cov.attrs["n_rep"], 10
    lo, hi = stats.binom.ppf([0.025, 0.975], n, 1 / bins)
    fig, axes = plt.subplots(1, len(names), figsize=(3.2 * len(names), 2.9), sharey=True, layout="constrained")
    for ax, p in zip(np.atleast_1d(axes), names, strict=True):
        ax.axhspan(lo, hi, color="0.85", label="uniform: 95% range per bin")
        ax.hist(cov["rank"].sel(param=p).values, bins=bins, range=(0.0, 1.0), color="C0", edgecolor="white")
        ax.set_xlabel(f"share of draws below the true {p}")
        ax.set_xlim(0.0, 1.0)
    np.atleast_1d(axes)[0].set_ylabel(f"replicates (of {n})")
    np.atleast_1d(axes)[0].legend(loc="lower left", fontsize=8)
    fig.suptitle("Truths drawn from the prior: an exact posterior ranks them uniformly", fontsize=10)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reps", type=int, default=50)
    ap.add_argument("--out", default="docs/notes/calibration_coverage.md")
    ap.add_argument("--quick", action="store_true", help="case 2 alone, closed-form data, 5 replicates")
    ap.add_argument("--sbc", type=int, default=200, help="replicates with truths drawn from the prior (0: none)")
    ap.add_argument("--sbc-nc", default="", help="also write the prior-drawn replicates (ranks, truths, coverage) to this netCDF file")
    args = ap.parse_args(argv)
    head = [
        "# Calibration coverage campaign",
        "",
        f"Written by `python tools/calibration_coverage.py {'--quick' if args.quick else f'--reps {args.reps} --sbc {args.sbc}'}` "
        f"({platform.node()}, {time.strftime('%Y-%m-%d')}). Method: [calibration.md](../guide/calibration.md). "
        "Each replicate is calibrated with the closed-form model and the default posterior (MCMC, emcee, importance-corrected); "
        "held-out points are the truth at the 14 midpoints between the data fields plus new noise.",
        "",
    ]
    if args.quick:
        t0 = time.perf_counter()
        cov = coverage(5, CLIFF, FIELDS, noise_deg=1.0, seed=21, heldout_mT=HELDOUT)
        lines = head + [f"## Adhesion 1/50 of the preset's, closed-form data ({time.perf_counter() - t0:.0f} s)", "", *table(cov)]
        Path(args.out).write_text("\n".join(lines) + "\n")
        print("\n".join(lines))
        return
    lines = list(head)
    if args.sbc:
        t0 = time.perf_counter()
        sbc = coverage(args.sbc, dict.fromkeys(PRIOR, 1.0), FIELDS, 1.0, seed=451, prior=PRIOR, progress=True)
        if args.sbc_nc:
            sbc.to_netcdf(args.sbc_nc)
        fig = Path(args.out).with_name(Path(args.out).stem + "_ranks.png")
        rank_figure(sbc, fig)
        lines += [
            "## Truths drawn from the prior (simulation-based calibration)",
            "",
            f"Each of {args.sbc} replicates draws its truth from the calibration's prior on the bounds {PRIOR} "
            "(uniform in the sampling scale: log10 for F_elect and adhesion_C), which are also its bounds; "
            f"closed-form tilts at the 15 fields, 1 deg noise ({time.perf_counter() - t0:.0f} s). Averaged over the prior, "
            "an exact posterior's 95% intervals hold the truth 95% of the time and the truth's rank among the draws "
            "is uniform, whatever the likelihood's shape; the fixed truths below test one point each, where a "
            "cliff-shaped likelihood (a lift-off between two data fields) promises neither.",
            "",
            *sbc_lines(sbc),
            "",
            f"![ranks]({fig.name})",
            "",
            *table(sbc)[sbc.sizes["param"] + 3 :],
            "",
        ]
    for title, truth, seed in (
        ("Three free parameters, simulated data, 1 deg noise", TRUTH, 11),
        ("Adhesion 1/50 of the preset's", CLIFF, 21),
    ):
        t0 = time.perf_counter()
        sim = lab.static_tilt(FIELDS, **truth)
        held = lab.static_tilt(HELDOUT, **truth)["tilt_deg"].values
        t_sim = time.perf_counter() - t0
        clean = sim["tilt_deg"].values
        cf_err = float(np.nanmax(np.abs(sim["tilt_deg"] - sim["tilt_closed_form_deg"])))
        t0 = time.perf_counter()
        cov = coverage(args.reps, truth, FIELDS, 1.0, seed=seed, clean=clean, heldout_mT=HELDOUT, heldout_clean=held, progress=True)
        t_cov = time.perf_counter() - t0
        lines += [
            f"## {title}",
            "",
            f"Truth {truth}; 15 fields from 3 to 15 mT; `lab.static_tilt` of the truth ({t_sim:.0f} s for the data and held-out "
            f"fields; it differs from the closed form by at most {cf_err:.4f} deg); clean tilts {np.round(clean, 1).tolist()} deg; "
            f"{args.reps} replicates of 1-deg noise, F_elect, offset_deg and adhesion_C free (default bounds), {t_cov:.0f} s in all.",
            "",
            indistinguishable(truth, FIELDS, 1.0),
            "",
            *table(cov),
            "",
        ]
        t0 = time.perf_counter()
        shifted = coverage(args.reps, truth, FIELDS, 1.0, seed=seed + 1, heldout_mT=HELDOUT, shift_mT=SPACING)
        lines += [
            f"**The field grid shifted** by a uniform offset in [0, {SPACING:.3f}) mT per replicate (closed-form data; where "
            f"the data fall relative to the lift-off varies as between labs; {time.perf_counter() - t0:.0f} s):",
            "",
            *table(shifted),
            "",
        ]
        if truth is CLIFF:
            t0 = time.perf_counter()
            lap = coverage(
                args.reps, truth, FIELDS, 1.0, seed=seed, clean=clean, heldout_mT=HELDOUT, heldout_clean=held, posterior="laplace"
            )
            lines += [
                f'**The same data sets with the Laplace posterior** (`posterior="laplace"`, {time.perf_counter() - t0:.0f} s):',
                "",
                *table(lap),
                "",
            ]
    t0 = time.perf_counter()
    cov2 = coverage(2 * args.reps, seed=1)
    lines += [
        "## Two free parameters, closed-form data, 0.5 deg noise",
        "",
        f"F_elect = 2.5e-6 N, offset_deg = 22; 13 fields (3 to 15 mT), {2 * args.reps} replicates ({time.perf_counter() - t0:.0f} s):",
        "",
        *table(cov2),
        "",
    ]
    rng = np.random.default_rng(11)
    clean = lab.static_tilt(FIELDS, **TRUTH)["tilt_deg"].values
    data = BenchData("static_tilt", "field_mT", "tilt_deg", "degree", np.asarray(FIELDS), clean + rng.normal(0.0, 1.0, clean.size), "rep 0")
    t0 = time.perf_counter()
    post = calibrate(data, list(TRUTH), model="simulate")
    t_fit = time.perf_counter() - t0
    t0 = time.perf_counter()
    auto = calibrate(data, list(TRUTH))
    t_auto = time.perf_counter() - t0
    lines += [
        "## The simulator as the forward model (the Laplace fallback)",
        "",
        f"Case 1, replicate 0: {t_fit:.0f} s, {post.attrs['n_evaluations']} model evaluations of 15 static-tilt runs after a "
        "Latin-hypercube screen, estimates "
        + ", ".join(f"{p} = {float(post['estimate_' + p]):.5g}" for p in TRUTH)
        + ", 95% intervals "
        + ", ".join(f"{np.quantile(post[p].values, 0.025):.4g}..{np.quantile(post[p].values, 0.975):.4g}" for p in TRUTH)
        + f"; undetermined: {post.attrs['undetermined'] or 'none'}; rough: {post.attrs['rough'] or 'none'}; "
        f"posterior: {post.attrs['posterior']}.",
        "",
        f"**The default (`model='auto'`)** on the same data: {t_auto:.1f} s (closed-form fit and MCMC, one simulator check "
        f"differing by {auto.attrs['simulator_check_rms']:.2g} deg rms), estimates "
        + ", ".join(f"{p} = {float(auto['estimate_' + p]):.5g}" for p in TRUTH)
        + ", 95% intervals "
        + ", ".join(f"{np.quantile(auto[p].values, 0.025):.4g}..{np.quantile(auto[p].values, 0.975):.4g}" for p in TRUTH)
        + f"; autocorrelation time {', '.join(f'{t:.0f}' for t in auto.attrs['autocorr_steps'])} steps.",
    ]
    Path(args.out).write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
