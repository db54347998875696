"""The calibration sampler against an independent exact posterior, on the coverage campaign's prior-drawn data sets.

The coverage campaign's simulation-based calibration (``tools/calibration_coverage.py --sbc
N --sbc-nc FILE``) draws N truths from the prior (seed 451) and calibrates each data set.
This script rebuilds the same data sets and computes each truth's rank under an
independent importance sampler started from the prior (three rounds of 50,000 points, a
Student-t refitted to the weighted points mixed with 10% of the prior; the effective sample
size is reported): the exact posterior, up to Monte Carlo error. It then compares the
coverage of the 95% intervals, and the ranks, with each netCDF file given (the campaign's
``--sbc-nc`` output, for example before and after a change of the sampler).

    python experiments/calibration_sampler.py --reps 400 --nc new.nc [--nc old.nc] [--save ref.npy] [--out FILE]

Its table goes to ``--out`` (default docs/notes/calibration_sampler.md) after ``--intro``'s text.
"""

from __future__ import annotations

import argparse
import shlex
import sys
import time
from pathlib import Path

import numpy as np
from scipy import stats

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tools"))

from calibration_coverage import FIELDS, PRIOR  # noqa: E402

from tumblemc.lab.bounds import check_free  # noqa: E402
from tumblemc.lab.mcmc import tilt_balance_batch  # noqa: E402


def reference_ranks(n_rep: int, seed: int = 451, points: int = 50000) -> np.ndarray:
    """(n_rep, p + 1): each truth's rank per parameter under importance sampling, and the effective sample size."""
    x = np.asarray(FIELDS)
    xh = 0.5 * (x[1:] + x[:-1])
    names = list(PRIOR)
    sc = check_free(names, PRIOR, "paper")
    rng, r2 = np.random.default_rng(seed), np.random.default_rng(99)
    p = len(names)

    def log_post(u: np.ndarray, y: np.ndarray) -> np.ndarray:
        inside = np.all((u >= 0) & (u <= 1), axis=1)
        out = np.full(len(u), -np.inf)
        v = sc.to_values(u[inside])
        pred = tilt_balance_batch(x, "paper", None, **{nm: v[:, j : j + 1] for j, nm in enumerate(names)})
        out[inside] = -0.5 * x.size * np.log(np.sum((pred - y) ** 2, axis=1))
        return out

    rows = []
    for i in range(n_rep):  # the same draws as lab.coverage.coverage(prior=...)
        truth = sc.to_values(rng.uniform(0.0, 1.0, p))
        y = tilt_balance_batch(x, "paper", None, **dict(zip(names, truth, strict=True))) + rng.normal(0.0, 1.0, x.size)
        rng.normal(0.0, 1.0, xh.size)  # the held-out noise
        zt = sc.to_z(truth)
        u = r2.uniform(size=(points, p))
        log_q = np.zeros(points)
        lp = log_post(u, y)
        for _ in range(3):
            w = np.exp(lp - log_q - np.max(lp - log_q))
            w /= w.sum()
            m = w @ u
            cov = 4.0 * ((u - m).T * w) @ (u - m) + 1e-10 * np.eye(p)
            t = stats.multivariate_t(m, cov, df=4, seed=r2)
            n_t = int(0.9 * points)
            u = np.vstack([t.rvs(n_t), r2.uniform(size=(points - n_t, p))])
            inside = np.all((u >= 0) & (u <= 1), axis=1)
            log_q = np.log(0.9 * np.exp(t.logpdf(u)) + 0.1 * inside)
            lp = log_post(u, y)
        w = np.exp(lp - log_q - np.max(lp - log_q))
        w /= w.sum()
        rows.append([float(w[u[:, j] < zt[j]].sum()) for j in range(p)] + [float(1.0 / np.sum(w**2))])
        if i % 50 == 0:
            print(f"reference {i + 1}/{n_rep}", file=sys.stderr, flush=True)
    return np.array(rows)


def main(argv: list[str] | None = None) -> None:
    import xarray as xr

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reps", type=int, default=400)
    ap.add_argument("--nc", action="append", default=[], help="a campaign's --sbc-nc file to compare (repeatable)")
    ap.add_argument("--save", default="", help="write the reference ranks to this .npy")
    ap.add_argument("--load", default="", help="read the reference ranks from this .npy instead of computing them")
    ap.add_argument("--out", default="docs/notes/calibration_sampler.md")
    ap.add_argument("--label", action="append", default=[], help="a name per --nc file, in order")
    ap.add_argument("--intro", default="", help="a file whose text goes above the table")
    args = ap.parse_args(argv)
    ref = np.load(args.load) if args.load else reference_ranks(args.reps)
    if args.save:
        np.save(args.save, ref)
    names = list(PRIOR)
    n = len(ref)
    rk = ref[:, : len(names)]
    cov_ref = (rk > 0.025) & (rk < 0.975)
    cmd = shlex.join(["python", "experiments/calibration_sampler.py", *(argv if argv is not None else sys.argv[1:])])
    lines = [
        "# The calibration sampler against an exact posterior",
        "",
        f"Written by `{cmd}` ({time.strftime('%Y-%m-%d')}). Method: the script's docstring.",
        "",
    ]
    if args.intro:
        lines += [Path(args.intro).read_text().rstrip(), ""]
    lines += [
        f"{n} data sets drawn from the prior (the coverage campaign's, seed 451); the reference's effective sample size: "
        f"min {ref[:, -1].min():.0f}, median {np.median(ref[:, -1]):.0f} of 50,000 points. Coverage of the 95% intervals "
        f"(binomial standard error at 0.95: {np.sqrt(0.95 * 0.05 / n):.3f}), with the number of data sets whose "
        "verdict (covered or not) differs from the reference's; and how much more extreme the ranks are than the "
        "reference's (mean |r - 1/2| minus the reference's: positive, intervals too narrow).",
        "",
        "| posterior | data sets | " + " | ".join(f"coverage {nm}" for nm in names) + " | ranks more extreme than the reference's |",
        "|---|---|" + "---|" * (len(names) + 1),
    ]
    labels = args.label + args.nc[len(args.label) :]
    for k in sorted({min(n, xr.open_dataset(path).sizes["replicate"]) for path in args.nc} | {n}):
        cov_k = cov_ref[:k].mean(0)
        lines.append(f"| exact (importance sampling from the prior) | first {k} | " + " | ".join(f"{c:.3f}" for c in cov_k) + " | 0 |")
        for label, path in zip(labels, args.nc, strict=True):
            ds = xr.open_dataset(path)
            if ds.sizes["replicate"] < k:
                continue
            m = ds["rank"].values[:k]
            covered = ds["covered"].values[:k]
            extreme = np.abs(m - 0.5).mean(0) - np.abs(rk[:k] - 0.5).mean(0)
            dis = (covered != cov_ref[:k]).sum(0)
            lines.append(
                f"| {label} | first {k} | "
                + " | ".join(f"{v:.3f} ({d} differ)" for v, d in zip(covered.mean(0), dis, strict=True))
                + " | "
                + ", ".join(f"{e:+.4f}" for e in extreme)
                + " |"
            )
    Path(args.out).write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main(sys.argv[1:])
