"""tumblemc's hand-written Sobol and logistic code against SALib, statsmodels and scikit-learn.

    python benchmarks/libraries.py [--quick] [sobol|coverage|binary|screening ...]

Needs ``salib``, ``statsmodels`` and ``scikit-learn`` (a scratch venv is enough:
``pip install -e . salib statsmodels scikit-learn``). Prints the markdown tables of
docs/guide/libraries.md:

- ``sobol``: Ishigami at N = 2^8 .. 2^14 (10 seeds each), error of S1/ST against the closed
  form (RMS over seeds), agreement of the two estimators on the same sample, wall time;
- ``coverage``: 100 seeds at N = 2^10, coverage and mean width of the 95% intervals
  (tumblemc: bootstrap percentile; SALib: normal, +-1.96 bootstrap SD);
- ``binary``: the same on a 0/1 output (:func:`tumblemc.testing.box_failure`, indices
  closed form), and what each does with a failed run (NaN output);
- ``screening``: logistic coefficients and standard errors of tumblemc, statsmodels
  Logit and scikit-learn, on ordinary, near-separable, rare-success and separated cells.

``--quick`` uses fewer seeds (a smoke test, not the published numbers).
"""

from __future__ import annotations

import argparse
import time
import warnings
from collections.abc import Callable
from typing import Any

import numpy as np
import xarray as xr
from scipy.special import expit

from tumblemc.analysis.screening import logistic_summary
from tumblemc.analysis.sobol import saltelli_design, sobol_indices, split_saltelli
from tumblemc.testing import ISHIGAMI_BOUNDS, box_failure, box_failure_indices, ishigami, ishigami_indices

LEVEL = 0.95
N_BOOT = 1000


def _timed(f: Callable[[], Any]) -> tuple[Any, float]:
    t0 = time.perf_counter()
    out = f()
    return out, time.perf_counter() - t0


def _ishigami_unit(U: np.ndarray) -> np.ndarray:
    lo, hi = np.array(ISHIGAMI_BOUNDS).T
    return ishigami(lo + (hi - lo) * U)


def _box3(U: np.ndarray) -> np.ndarray:
    return box_failure(U).astype(np.float64)


PROBLEM = {"num_vars": 3, "names": ["x1", "x2", "x3"], "bounds": [[0.0, 1.0]] * 3}


def _tumblemc(f: Callable[[np.ndarray], np.ndarray], n: int, seed: int) -> tuple[xr.Dataset, float, float]:
    U, t_s = _timed(lambda: saltelli_design(n, 3, seed).stack())
    y = f(U)
    ind, t_a = _timed(lambda: sobol_indices(*split_saltelli(y, 3), n_boot=N_BOOT, level=LEVEL, seed=seed))
    return ind, t_s, t_a


def _salib(
    f: Callable[[np.ndarray], np.ndarray], n: int, seed: int, y_edit: Callable[[np.ndarray], None] | None = None
) -> tuple[Any, float, float]:
    from SALib.analyze import sobol as sa
    from SALib.sample import sobol as ss

    # a Generator seed gives exactly tumblemc's design (an int seed goes through RandomState)
    X, t_s = _timed(lambda: ss.sample(PROBLEM, n, calc_second_order=False, seed=np.random.default_rng(seed)))
    y = f(X)
    if y_edit is not None:
        y_edit(y)
    # SALib's analyze treats seed=0 as "no seed" (``if seed:``), hence seed + 1
    Si, t_a = _timed(lambda: sa.analyze(PROBLEM, y, calc_second_order=False, num_resamples=N_BOOT, conf_level=LEVEL, seed=seed + 1))
    return Si, t_s, t_a


def _s1_uncentred(ind_y: tuple[np.ndarray, np.ndarray, np.ndarray]) -> np.ndarray:
    """S1 of tumblemc before the centring (mean(yB (yAB_i - yA)) / V): the old column."""
    yA, yB, yAB = ind_y
    return np.mean(yB * (yAB - yA), axis=-1) / np.var(np.r_[yA, yB])


def table_sobol(reps: int) -> None:
    ref = ishigami_indices()
    print(f"Ishigami, {reps} seeds per N, {N_BOOT} bootstrap replicates; error = RMS over seeds and the 6 indices")
    print("S1 error: RMS over seeds and the 3 first-order indices (uncentred: tumblemc's estimator before this change)")
    print(
        "| N | runs | RMS error tumblemc | RMS error SALib | S1 error: tumblemc / uncentred / SALib "
        "| max abs(tumblemc - SALib), same sample | sample ms (t / S) | analyse ms (t / S) |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for m in range(8, 15):
        n = 1 << m
        et, es, diff, ts, ta, ss_, sa_, e1 = [], [], [], [], [], [], [], []
        for seed in range(reps):
            ind, t_s, t_a = _tumblemc(_ishigami_unit, n, seed)
            Si, s_s, s_a = _salib(_ishigami_unit, n, seed)
            t = np.r_[ind["S1"].values, ind["ST"].values]
            s = np.r_[Si["S1"], Si["ST"]]
            r = np.r_[ref["S1"], ref["ST"]]
            y_same = _ishigami_unit(saltelli_design(n, 3, seed).stack())
            old = _s1_uncentred(split_saltelli(y_same, 3))
            e1.append(np.array([(t[:3] - r[:3]) ** 2, (old - r[:3]) ** 2, (s[:3] - r[:3]) ** 2]))
            et.append((t - r) ** 2)
            es.append((s - r) ** 2)
            diff.append(np.max(np.abs(t - s)))
            ts.append(t_s)
            ta.append(t_a)
            ss_.append(s_s)
            sa_.append(s_a)

        def ms(v: list[float]) -> str:
            return f"{1e3 * float(np.median(v)):.1f}"

        rms1 = np.sqrt(np.mean(np.array(e1), axis=(0, 2)))
        print(
            f"| 2^{m} | {n * 5} | {np.sqrt(np.mean(et)):.4f} | {np.sqrt(np.mean(es)):.4f} "
            f"| {rms1[0]:.4f} / {rms1[1]:.4f} / {rms1[2]:.4f} | {max(diff):.1e} "
            f"| {ms(ts)} / {ms(ss_)} | {ms(ta)} / {ms(sa_)} |"
        )


def _coverage(f: Callable[[np.ndarray], np.ndarray], ref: dict[str, np.ndarray], n: int, reps: int, title: str) -> None:
    keys = ("S1", "ST")
    hit_t = {k: np.zeros(3) for k in keys}
    hit_s = {k: np.zeros(3) for k in keys}
    wid_t = {k: np.zeros(3) for k in keys}
    wid_s = {k: np.zeros(3) for k in keys}
    for seed in range(reps):
        ind, _, _ = _tumblemc(f, n, seed)
        Si, _, _ = _salib(f, n, seed)
        for k in keys:
            lo, hi = ind[f"{k}_lower"].values, ind[f"{k}_upper"].values
            hit_t[k] += (lo <= ref[k]) & (ref[k] <= hi)
            wid_t[k] += hi - lo
            half = np.asarray(Si[f"{k}_conf"])
            hit_s[k] += np.abs(np.asarray(Si[k]) - ref[k]) <= half
            wid_s[k] += 2 * half
    print(f"{title}: N = {n}, {reps} seeds, nominal {LEVEL:.0%}; coverage (mean width)")
    print("| index | true | tumblemc percentile | SALib normal |")
    print("|---|---|---|---|")
    for k in keys:
        for i in range(3):
            print(
                f"| {k}_x{i + 1} | {ref[k][i]:.4f} | {hit_t[k][i] / reps:.2f} ({wid_t[k][i] / reps:.3f}) "
                f"| {hit_s[k][i] / reps:.2f} ({wid_s[k][i] / reps:.3f}) |"
            )


def table_coverage(reps: int) -> None:
    _coverage(_ishigami_unit, ishigami_indices(), 1 << 10, reps, "Ishigami")


def table_binary(reps: int) -> None:
    _coverage(_box3, box_failure_indices(), 1 << 10, reps, "box_failure (0/1 output, x3 has no effect)")
    n = 1 << 10

    def one_nan(y: np.ndarray) -> None:
        y[7] = np.nan

    U = saltelli_design(n, 3, 0).stack()
    y = _box3(U)
    y[7] = np.nan
    ind = sobol_indices(*split_saltelli(y, 3), n_boot=200)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        Si, _, _ = _salib(_box3, n, 0, one_nan)
    print()
    print("One failed run (NaN output) in the design:")
    print(f"- tumblemc: drops its row block (n_dropped = {ind.attrs['n_dropped']}), S1 = {np.round(ind['S1'].values, 3)}")
    print(f"- SALib: S1 = {np.round(Si['S1'], 3)}, ST = {np.round(Si['ST'], 3)}")


# ----------------------------------------------------------------------------- screening


def _runs(z: np.ndarray, y: np.ndarray) -> xr.Dataset:
    n, d = z.shape
    names = [f"p{j}" for j in range(d)]
    data = {nm: ("run", z[:, j]) for j, nm in enumerate(names)}
    data.update({"climbed": ("run", y.astype(np.int8)), "status": ("run", np.zeros(n, dtype=np.int8))})
    coords = {"shape": ("run", np.full(n, "s")), "substrate": ("run", np.full(n, "p")), "incline_deg": ("run", np.zeros(n))}
    return xr.Dataset(data, coords=coords, attrs={"uncertain": ",".join(names)})


def _scenarios(seed: int = 0, n: int = 400) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    rng = np.random.default_rng(seed)
    out: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    for label, slope, icpt in (
        ("ordinary (slope 3)", 3.0, 0.0),
        ("steep (slope 12, near-separable)", 12.0, 0.0),
        ("rare success (p ~ 0.02)", 1.0, -4.5),
    ):
        x = rng.standard_normal((n, 4))
        y = (rng.uniform(size=n) < expit(icpt + slope * x[:, 0])).astype(np.float64)
        out[label] = (x, y)
    x = rng.standard_normal((n, 4))
    out["separated (y = x1 > 0)"] = (x, (x[:, 0] > 0).astype(np.float64))
    return out


def _standardize(x: np.ndarray) -> np.ndarray:
    return (x - x.mean(axis=0)) / x.std(axis=0)


def table_screening(reps: int) -> None:
    import statsmodels.api as sm
    from sklearn.linear_model import LogisticRegression

    print("Logistic coefficient of x1 (per SD; true slope where given) and its standard error; n = 400, 4 parameters")
    print(
        "| cell | tumblemc ridge 0.01 | tumblemc ridge 1e-9 | statsmodels Logit | sklearn C=inf | sklearn C=100 "
        "| ms per cell (t / sm / sk) |"
    )
    print("|---|---|---|---|---|---|---|")
    for label, (x, y) in _scenarios().items():
        Z = _standardize(x)
        runs = _runs(x, y)
        t0 = time.perf_counter()
        lg = logistic_summary(runs)
        t_t = time.perf_counter() - t0
        lg0 = logistic_summary(runs, ridge=1e-9)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            t0 = time.perf_counter()
            try:
                res = sm.Logit(y, sm.add_constant(Z)).fit(disp=0, maxiter=100)
                sm_txt = f"{res.params[1]:.3f} +- {res.bse[1]:.3f}" + ("" if res.mle_retvals["converged"] else " (not converged)")
            except Exception as e:  # statsmodels raises on perfect separation
                sm_txt = f"error: {type(e).__name__}"
            t_sm = time.perf_counter() - t0
            t0 = time.perf_counter()
            sk = LogisticRegression(C=np.inf, max_iter=1000).fit(Z, y)
            t_sk = time.perf_counter() - t0
            sk100 = LogisticRegression(C=100.0, max_iter=1000).fit(Z, y)

        def cell(ds: xr.Dataset) -> str:
            c = ds.isel(shape=0, substrate=0, incline_deg=0, parameter=0)
            flag = " (separated)" if bool(c["separated"]) else ""
            return f"{float(c['coef']):.3f} +- {float(c['coef_se']):.3f}{flag}"

        print(
            f"| {label} | {cell(lg)} | {cell(lg0)} | {sm_txt} | {sk.coef_[0, 0]:.3f} | {sk100.coef_[0, 0]:.3f} "
            f"| {1e3 * t_t:.1f} / {1e3 * t_sm:.1f} / {1e3 * t_sk:.1f} |"
        )
    # agreement over many ordinary cells: tumblemc's near-MLE against statsmodels
    dc, ds_ = [], []
    for seed in range(reps):
        rng = np.random.default_rng(1000 + seed)
        x = rng.standard_normal((400, 4))
        y = (rng.uniform(size=400) < expit(1.5 * x[:, 0] - 0.5 * x[:, 1])).astype(np.float64)
        lg = logistic_summary(_runs(x, y), ridge=1e-9).isel(shape=0, substrate=0, incline_deg=0)
        res = sm.Logit(y, sm.add_constant(_standardize(x))).fit(disp=0)
        dc.append(np.max(np.abs(lg["coef"].values - res.params[1:])))
        ds_.append(np.max(np.abs(lg["coef_se"].values / res.bse[1:] - 1.0)))
    print()
    print(
        f"{reps} ordinary cells (n = 400): tumblemc (ridge 1e-9) vs statsmodels Logit, "
        f"max |coef diff| = {max(dc):.1e}, max |se ratio - 1| = {max(ds_):.1e}"
    )


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("tables", nargs="*", default=["sobol", "coverage", "binary", "screening"])
    p.add_argument("--quick", action="store_true", help="few seeds: a smoke test")
    a = p.parse_args(argv)
    tables = {
        "sobol": (table_sobol, 10),
        "coverage": (table_coverage, 100),
        "binary": (table_binary, 100),
        "screening": (table_screening, 50),
    }
    for name in a.tables:
        f, reps = tables[name]
        f(3 if a.quick else reps)
        print()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
