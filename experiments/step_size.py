"""The default step size against finer steps (issue 45): ensembles, ladders and twins.

Three cells beyond the paper's operating points:

1. paper cuboid, flat, ``Rotating(20, 200)``, 0.5 s;
2. aluminum cuboid, flat, ``Rotating(100, 50)``, offset 45 deg about z, 0.4 s;
3. aluminum cuboid, flat, ``Rotating(100, 100)``, offset 30 deg about z, 0.5 s.

``ensemble``: 100 robots per cell with the default uncertainties (mu truncnormal 15%,
adhesion_C lognormal CV 30%, offset_deg normal sd 5 deg about the cell's nominal,
magnetization normal 10%), each at the default step, at 4x finer and at 5e-5 s: the mean
progress ratio and P(success) (ratio >= 0.5) with Wilson 95% intervals, over the valid runs.
A run ends at its first failed step, as in a study: it is invalid either way.

``ladder``: the nominal robot of each cell at h, h/4, h/16, h/64 (h the default), and two
twins at h with the magnetisation x (1 +- 1e-6): a run is *converged* when the ladder's
spread is within 0.05, *sensitive* when the twins move it as much as the ladder does.

    python experiments/step_size.py ensemble [--robots 100] [--workers 2] [--steps default,default/4,default/16,5e-5]
    python experiments/step_size.py ladder
    python experiments/step_size.py twins       # the twins at h, h/4, h/16
    python experiments/step_size.py swarm [--twins 32] [--save PREFIX]  # 32 twins per rung, 1e-6 in random directions
    python experiments/step_size.py stepout     # paper cuboid, flat, 20 mT: default, /4, /16
    python experiments/step_size.py spin        # free-spin energy drift per integrator option
    python experiments/step_size.py check       # tumblemc.check_step on each cell's nominal robot, at the default and 5e-5 s
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np
from scipy import stats

CELLS = {
    "paper_200Hz": dict(shape="cuboid", preset="paper", mT=20.0, hz=200.0, offset=None, duration_s=0.5),
    "al_100mT_50Hz_off45z": dict(shape="cuboid", preset="aluminum", mT=100.0, hz=50.0, offset=45.0, duration_s=0.4),
    "al_100mT_100Hz_off30z": dict(shape="cuboid", preset="aluminum", mT=100.0, hz=100.0, offset=30.0, duration_s=0.5),
}
#: further from step-out (the paper cuboid's natural frequency at 20 mT is 311 Hz): where the
#: default's 1000 steps per turn start to bias the ensemble (``ensemble --cells paper_150Hz,...``)
EXTRA_CELLS = {
    "paper_100Hz": dict(shape="cuboid", preset="paper", mT=20.0, hz=100.0, offset=None, duration_s=0.5),
    "paper_150Hz": dict(shape="cuboid", preset="paper", mT=20.0, hz=150.0, offset=None, duration_s=0.5),
}
ISSUE_CELLS = list(CELLS)
CELLS.update(EXTRA_CELLS)  # after the issue's three: their seeds (the index in CELLS) unchanged


def robots(cell: str, n: int, seed: int = 45) -> list[dict[str, float]]:
    """The default uncertainties (study/distributions.py: DEFAULT_UNCERTAIN) about the cell's nominal."""
    from tumblemc.model.params import get_preset

    c = CELLS[cell]
    p = get_preset(c["preset"])
    rng = np.random.default_rng([seed, list(CELLS).index(cell)])
    off0 = p.offset_deg if c["offset"] is None else c["offset"]
    cv = 0.3
    s2 = math.log(1 + cv**2)
    out = []
    for _ in range(n):
        mu = stats.truncnorm.rvs(-1 / 0.15, np.inf, loc=p.mu, scale=0.15 * p.mu, random_state=rng)
        out.append(
            dict(
                mu=float(mu),
                adhesion_C=float(p.adhesion_C * math.exp(rng.normal(-s2 / 2, math.sqrt(s2)))),
                offset_deg=float(rng.normal(off0, 5.0)),
                magnetization=float(rng.normal(p.magnetization, 0.1 * p.magnetization)),
            )
        )
    return out


def one(cell: str, over: dict[str, float], dt: float | None, stop_at_failure: bool = False) -> tuple[float, int, float, str]:
    """(progress ratio, status, dt used, dt rule) of one run; dt None: the default.

    ``stop_at_failure``: end the run at its first failed step, as a study does
    (``max_failed_steps=1``); such a run is invalid either way, and a path that fails step
    after step would otherwise cost minutes a step (docs/notes/step_size.md, cell 1).
    """
    import tumblemc as tm
    from tumblemc.model.fields import Rotating
    from tumblemc.model.step_size import CEILING_S

    c = CELLS[cell]
    kw = dict(over)
    if c["offset"] is not None:
        kw["offset_axis"] = (0.0, 0.0, 1.0)
    step = dt
    if step is None:
        from tumblemc.model.run import run_inputs

        step = run_inputs(c["shape"], c["preset"], field=Rotating(c["mT"], c["hz"]), duration_s=c["duration_s"], **kw).dt
    every = max(1, round(CEILING_S / 10 / step))  # a record every 5 us whatever the step
    solver = tm.SolverOptions(max_failed_steps=1 if stop_at_failure else 0)
    ds = tm.simulate(
        c["shape"],
        c["preset"],
        field=Rotating(c["mT"], c["hz"]),
        duration_s=c["duration_s"],
        dt=dt,
        record_every=every,
        solver=solver,
        max_wall_s=None,  # the finest rungs take minutes a run, on purpose
        **kw,
    )
    s = tm.summarize(ds)
    return float(s["progress_ratio"]), int(s["status"]), float(ds.attrs["dt"]), str(ds.attrs["dt_rule"])


def wilson(k: int, n: int, z: float = 1.959964) -> tuple[float, float]:
    if n == 0:
        return (math.nan, math.nan)
    p = k / n
    d = 1 + z * z / n
    c = (p + z * z / (2 * n)) / d
    h = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / d
    return (c - h, c + h)


def ensemble(args: argparse.Namespace) -> None:
    from tumblemc.model.fields import Rotating
    from tumblemc.model.run import run_inputs

    print("| cell | step | dt (s) | valid | mean ratio | P(success) [95%] | paired with default: n, mean difference +- SE | wall (s) |")
    print("|---|---|---|---|---|---|---|---|")
    for cell in args.cells.split(","):
        c = CELLS[cell]
        rs = robots(cell, args.robots)
        h = run_inputs(c["shape"], c["preset"], field=Rotating(c["mT"], c["hz"]), duration_s=c["duration_s"]).dt
        base = None
        steps = [
            (lab, None if lab == "default" else (5e-5 if lab == "5e-5" else h / int(lab.split("/")[1]))) for lab in args.steps.split(",")
        ]
        for label, dt in steps:
            t0 = time.perf_counter()
            res = []
            with ProcessPoolExecutor(args.workers) as ex:
                for j, x in enumerate(ex.map(one, [cell] * len(rs), rs, [dt] * len(rs), [True] * len(rs))):
                    res.append(x)  # each robot on stderr as it arrives, with the time since the stage began
                    print(
                        f"    {cell} {label} robot {j}: ratio {x[0]:.3f}, status {x[1]}, {time.perf_counter() - t0:.0f} s",
                        file=sys.stderr,
                        flush=True,
                    )
            ratio = np.array([r[0] for r in res])
            ok = np.array([r[1] == 0 for r in res])
            k = int(np.sum(ratio[ok] >= 0.5))
            n = int(ok.sum())
            lo, hi = wilson(k, n)
            dts = sorted({f"{r[2]:.4g}" for r in res})
            mean = f"{ratio[ok].mean():.3f}" if n else "-"
            pint = f"{k / n:.2f} [{lo:.2f}, {hi:.2f}]" if n else "- (no valid run)"
            if base is None:
                base = (ratio, ok)
                paired = "-"
            else:
                both = ok & base[1]
                d = ratio[both] - base[0][both]
                paired = f"{both.sum()}, {d.mean():+.3f} +- {d.std(ddof=1) / math.sqrt(both.sum()):.3f}" if both.sum() > 1 else "-"
            if args.save:
                np.savez(f"{args.save}_{cell}_{label.replace('/', '_')}.npz", ratio=ratio, ok=ok)
            wall = time.perf_counter() - t0
            print(f"| {cell} | {label} | {','.join(dts)} | {n}/{len(rs)} | {mean} | {pint} | {paired} | {wall:.0f} |", flush=True)


def _nominal(cell: str) -> tuple[float, dict[str, float], float]:
    """The cell's nominal magnetisation, its nominal overrides (the offset) and its default step."""
    from tumblemc.model.fields import Rotating
    from tumblemc.model.params import get_preset
    from tumblemc.model.run import run_inputs

    c = CELLS[cell]
    nom = {} if c["offset"] is None else {"offset_deg": c["offset"]}
    kw = dict(nom, **({"offset_axis": (0.0, 0.0, 1.0)} if c["offset"] is not None else {}))
    h = run_inputs(c["shape"], c["preset"], field=Rotating(c["mT"], c["hz"]), duration_s=c["duration_s"], **kw).dt
    return get_preset(c["preset"]).magnetization, nom, h


def ladder(args: argparse.Namespace) -> None:
    print("| cell | h (s) | h | h/4 | h/16 | h/64 | twins at h (M x 1 -+ 1e-6) | verdict |")
    print("|---|---|---|---|---|---|---|---|")
    for cell in args.cells.split(","):
        magnetization, nom, h = _nominal(cell)
        divs = [int(x) for x in args.divs.split(",")]
        with ProcessPoolExecutor(args.workers) as ex:
            lad = list(ex.map(one, [cell] * len(divs), [nom] * len(divs), [h / k for k in divs]))
            tw = list(ex.map(one, [cell] * 2, [dict(nom, magnetization=magnetization * (1 + s)) for s in (-1e-6, 1e-6)], [h, h]))
        r = [x[0] for x in lad]
        t = [x[0] for x in tw]
        spread = max(r) - min(r)
        twin = max(abs(t[0] - r[0]), abs(t[1] - r[0]))
        verdict = "converged" if spread <= 0.05 else ("sensitive" if twin >= 0.5 * spread else "not converged")
        cells = " | ".join(f"{x:.3f}" for x in r)
        print(f"| {cell} | {h:.4g} | {cells} | {t[0]:.3f}, {t[1]:.3f} | {verdict} (spread {spread:.3f}, twins {twin:.3f}) |", flush=True)


def twins(args: argparse.Namespace) -> None:
    """The nominal robot and its two twins (magnetisation x (1 -+ 1e-6)) at each rung.

    How far a 1e-6 perturbation moves the ratio at each step size of the ladder, and :func:`classify`'s verdict.
    """
    divs = [int(x) for x in args.divs.split(",")]
    print("| cell | step | ratio | twins (M x 1 -+ 1e-6) | twins' spread |")
    print("|---|---|---|---|---|")
    for cell in args.cells.split(","):
        magnetization, nom, h = _nominal(cell)
        runs = [(dict(nom, magnetization=magnetization * (1 + s)), h / k) for k in divs for s in (0.0, -1e-6, 1e-6)]
        with ProcessPoolExecutor(args.workers) as ex:
            res = list(ex.map(one, [cell] * len(runs), [r[0] for r in runs], [r[1] for r in runs]))
        spreads, ratios = [], []
        for i, k in enumerate(divs):
            r0, r1, r2 = (x[0] for x in res[3 * i : 3 * i + 3])
            spread = max(r0, r1, r2) - min(r0, r1, r2)
            spreads.append(spread)
            ratios.append(r0)
            print(f"| {cell} | h/{k} | {r0:.3f} | {r1:.3f}, {r2:.3f} | {spread:.3f} |", flush=True)
        print(f"| {cell} | verdict | {classify(ratios, spreads)} | | |", flush=True)


def _twin_overrides(nom: dict[str, float], magnetization: float, offset0: float, n: int, seed: int) -> list[dict[str, float]]:
    """``n`` twins of the nominal robot, each a change of relative size 1e-6 of its magnetisation vector.

    Twin i moves the magnitude by 1e-6 cos(t_i) of itself and turns the direction by 1e-6 sin(t_i) rad
    in the offset plane (the offset angle), t_i uniform on the circle: |dm| / |m| = 1e-6 for every twin.
    """
    t = np.random.default_rng(seed).uniform(0.0, 2.0 * math.pi, n)
    return [
        dict(nom, magnetization=magnetization * (1.0 + 1e-6 * math.cos(a)), offset_deg=offset0 + math.degrees(1e-6 * math.sin(a)))
        for a in t
    ]


def swarm(args: argparse.Namespace) -> None:
    """The nominal robot and ``--twins`` twins (each a 1e-6 change of the magnetisation vector) at each rung.

    Two twins (the magnitude x (1 -+ 1e-6), stage ``twins``) sample the ratio's response to a
    1e-6 change at two points; a chaotic run's response is a distribution, and this stage
    samples it: per rung the nominal ratio, the twins' median and range, and the verdict of
    :func:`classify_swarm`. ``--save`` writes the ratios to ``<save>_<cell>.npz``.
    """
    from tumblemc.model.params import get_preset

    divs = [int(x) for x in args.divs.split(",")]
    print(f"| cell | step | nominal ratio | {args.twins} twins: median | twins: range | twins' spread (with the nominal) | invalid |")
    print("|---|---|---|---|---|---|---|")
    for cell in args.cells.split(","):
        magnetization, nom, h = _nominal(cell)
        if args.midpoint:
            nom = dict(nom, rotation="midpoint", torque="mid")
        offset0 = nom.get("offset_deg", get_preset(CELLS[cell]["preset"]).offset_deg)
        tw = _twin_overrides(nom, magnetization, offset0, args.twins, seed=list(CELLS).index(cell))
        runs = [(o, h / k) for k in divs for o in [nom, *tw]]
        t0 = time.perf_counter()
        res = []
        with ProcessPoolExecutor(args.workers) as ex:
            for j, x in enumerate(ex.map(one, [cell] * len(runs), [r[0] for r in runs], [r[1] for r in runs])):
                res.append(x)  # each run on stderr as it arrives (the finest rungs take minutes each)
                msg = f"    {cell} dt {runs[j][1]:.3g} s run {j % (args.twins + 1)}: ratio {x[0]:.3f}, status {x[1]}"
                print(msg, file=sys.stderr, flush=True)
        m = args.twins + 1
        ratio = np.array([x[0] for x in res]).reshape(len(divs), m)
        status = np.array([x[1] for x in res]).reshape(len(divs), m)
        for i, k in enumerate(divs):
            r = ratio[i]
            print(
                f"| {cell} | h/{k} ({h / k:.3g} s) | {r[0]:.3f} | {np.median(r[1:]):.3f} | {r[1:].min():.3f} .. {r[1:].max():.3f} "
                f"| {r.max() - r.min():.3f} | {int(np.sum(status[i] != 0))} |",
                flush=True,
            )
        print(f"| {cell} | verdict | {classify_swarm(ratio)} | | | | {time.perf_counter() - t0:.0f} s |", flush=True)
        if args.save:
            np.savez(f"{args.save}_{cell}.npz", ratio=ratio, status=status, divs=np.array(divs), h=h)


def classify_swarm(ratio: np.ndarray, tol: float = 0.05) -> str:
    """Converged, sensitive or not converged from rungs x (nominal, twins...) ratios.

    *converged*: the nominal ratios of the rungs within ``tol`` of each other. *sensitive*
    (the issue's test, read literally): a 1e-6 change of the magnetisation moves the ratio
    as much as the ladder does, i.e. at some rung the spread of the nominal and its twins is
    at least the spread of the nominal ratios over the rungs. Else *not converged*. Also
    says how many rungs' nominal ratios fall inside the finest rung's twins' range.
    """
    nominal = ratio[:, 0]
    ladder_spread = float(nominal.max() - nominal.min())
    twin = float((ratio.max(axis=1) - ratio.min(axis=1)).max())
    lo, hi = ratio[-1].min(), ratio[-1].max()
    inside = int(np.sum((nominal >= lo) & (nominal <= hi)))
    tail = f"{inside} of {len(nominal)} rungs' ratios inside the finest rung's twins' range {lo:.3f} .. {hi:.3f}"
    if ladder_spread <= tol:
        return f"converged (ladder spread {ladder_spread:.3f}); {tail}"
    word = "sensitive" if twin >= ladder_spread else "not converged"
    return f"{word} (ladder spread {ladder_spread:.3f}, twins' spread up to {twin:.3f}); {tail}"


def classify(ratios: list[float], spreads: list[float], tol: float = 0.05) -> str:
    """Converged, sensitive or not converged: a single run's ratio along a ladder of steps, with its twins at each rung.

    *converged*: the ratios of the rungs within ``tol`` of each other. *sensitive*: the
    twins (a 1e-6 change of the magnetisation) at the rungs move the ratio at least half as
    much as the ladder's largest move between successive rungs: what is left of the step's
    effect is the model's own sensitivity, which no step removes. Else *not converged*.
    """
    ladder_spread = max(ratios) - min(ratios)
    if ladder_spread <= tol:
        return f"converged (spread {ladder_spread:.3f})"
    move = max(abs(b - a) for a, b in zip(ratios, ratios[1:], strict=False))
    twin = max(spreads)
    word = "sensitive" if twin >= 0.5 * move else "not converged"
    return f"{word} (ladder spread {ladder_spread:.3f}, largest move between rungs {move:.3f}, twins up to {twin:.3f})"


def _follows(f: float, div: int) -> bool:
    import tumblemc as tm
    from tumblemc.lab.protocols import STEP_OUT_SHARE, following_share
    from tumblemc.model.run import run_inputs

    h = run_inputs("cuboid", "paper", 0.0, 20.0, f, periods=8.0).dt
    t0 = time.perf_counter()
    # the default's record density
    ds = tm.simulate("cuboid", "paper", 0.0, 20.0, f, periods=8.0, dt=h / div, record_every=div, max_wall_s=None)
    share = following_share(ds, 1.0 / f)
    print(
        f"    {f:.3f} Hz at default/{div}: follows {share:.3f} of the turns, status {ds.attrs['status']}, "
        f"failed steps {ds.attrs['failed_steps']}, loose {int(ds['loose'].sum())}, {time.perf_counter() - t0:.1f} s",
        file=sys.stderr,
        flush=True,
    )
    return bool(share >= STEP_OUT_SHARE)


def _bisect(div: int, lo: float = 150.0, hi: float = 400.0, rel_tol: float = 0.002) -> float:
    if not (_follows(lo, div) and not _follows(hi, div)):
        return math.nan
    while hi - lo > rel_tol * hi:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if _follows(mid, div) else (lo, mid)
    return hi


def stepout(args: argparse.Namespace) -> None:
    """The step-out frequency of the paper cuboid at 20 mT at the default step and finer.

    lab.step_out's criterion (the magnet makes half the field's turns), at the default step
    of each frequency divided by each of ``--divs``.
    """
    divs = [int(x) for x in args.divs.split(",")]
    print("| step | step-out frequency (Hz) | wall (s) |")
    print("|---|---|---|")
    for k in divs:
        t0 = time.perf_counter()
        print(f"| default/{k} | {_bisect(k):.1f} | {time.perf_counter() - t0:.0f} |", flush=True)


def spin(args: argparse.Namespace) -> None:
    """A free spin off a principal axis in a static 20 mT field (paper cuboid, 50 ms).

    The mechanical energy's change (kinetic + magnetic + gravity) over |m||B|, per integrator option.
    """
    import tumblemc as tm
    from tumblemc.model.fields import Static

    print("| rotation | torque | dt | energy change at the end / most above the start (|m||B|) | status | dt rule |")
    print("|---|---|---|---|---|---|")
    options = [("momentum", "start"), ("momentum", "end"), ("paper", "start"), ("paper", "end"), ("midpoint", "mid"), ("midpoint", "start")]
    for rot, torque in options:
        for dt in (None, 5e-5 / 4, 5e-5 / 16):
            ds = tm.simulate(
                "cuboid",
                "paper",
                field=Static(20, (0, 0, -1)),
                lift_m=0.05,
                omega0=(2000.0, 1000.0, 500.0),
                duration_s=0.05,
                dt=dt,
                rotation=rot,
                torque=torque,
            )
            e = (ds.kinetic_energy + ds.magnetic_energy + ds.potential_energy).values
            mb = float(np.abs(ds.magnetic_energy).max())
            print(
                f"| {rot} | {torque} | {ds.attrs['dt']:.3g} | {(e[-1] - e[0]) / mb:+.3f} / {(e - e[0]).max() / mb:.3f} "
                f"| {ds.attrs['status']} | {ds.attrs['dt_rule']} |",
                flush=True,
            )


def check(args: argparse.Namespace) -> None:
    """``tumblemc.check_step`` on each cell's nominal robot at each of ``--steps`` (default and 5e-5 s).

    The run's own wall time (``simulate`` alone, one thread) is measured apart: the check's
    cost is its wall time (``--workers`` threads) over it.
    """
    import tumblemc as tm
    from tumblemc.model.fields import Rotating

    print("| cell | dt (s) | ratio | at dt / 4 | twins | finer step's move | twins' move | tolerance | class | run (s) | check (s) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for cell in args.cells.split(","):
        c = CELLS[cell]
        _, nom, h = _nominal(cell)
        kw = dict(nom, **({"offset_axis": (0.0, 0.0, 1.0)} if c["offset"] is not None else {}))
        kw.update(field=Rotating(c["mT"], c["hz"]), duration_s=c["duration_s"], max_wall_s=None)
        kw["record_every"] = max(1, round(5e-6 / h))  # a record every 5 us at the default step
        for step in args.steps.split(","):
            dt = None if step == "default" else float(step)
            every = kw["record_every"] if dt is None else 1
            t0 = time.perf_counter()
            tm.simulate(c["shape"], c["preset"], **dict(kw, dt=dt, record_every=every))
            t_run = time.perf_counter() - t0
            t0 = time.perf_counter()
            r = tm.check_step(c["shape"], c["preset"], **dict(kw, dt=dt, record_every=every), workers=args.workers)
            t_check = time.perf_counter() - t0
            tw = f"{r.twin_ratios.min():.3f} .. {r.twin_ratios.max():.3f}"
            print(
                f"| {cell} | {r.dt:.4g} | {r.ratio:.3f} | {r.fine_ratio:.3f} | {tw} | {r.move:.3f} | {r.twin_spread:.3f} | {r.tol:.3f} "
                f"| {r.cls} | {t_run:.1f} | {t_check:.1f} |",
                flush=True,
            )


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("stage", choices=["ensemble", "ladder", "twins", "swarm", "stepout", "spin", "check"])
    ap.add_argument("--steps", default="default,default/4,5e-5", help="ensemble: steps (default, default/K, 5e-5); the first is the base")
    ap.add_argument("--twins", type=int, default=32, help="swarm: twins per rung")
    ap.add_argument("--midpoint", action="store_true", help="swarm: the midpoint rule (rotation='midpoint', torque='mid')")
    ap.add_argument("--robots", type=int, default=100)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--cells", default=",".join(ISSUE_CELLS), help=f"any of {list(CELLS)}")
    ap.add_argument("--divs", default="1,4,16,64")
    ap.add_argument("--save", default="", help="ensemble: write each ensemble's ratios to <save>_<cell>_<step>.npz")
    args = ap.parse_args(argv)
    if args.stage == "check" and args.steps == "default,default/4,5e-5":
        args.steps = "default,5e-5"
    if args.stage == "stepout" and args.divs == "1,4,16,64":
        args.divs = "1,4,16"
    stages = {"ensemble": ensemble, "ladder": ladder, "twins": twins, "swarm": swarm, "stepout": stepout, "spin": spin, "check": check}
    stages[args.stage](args)


if __name__ == "__main__":
    main(sys.argv[1:])
