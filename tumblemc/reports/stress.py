"""The stress campaign: a wide-range study, 3-D runs, and their report (``tumblemc stress``).

Far from the paper's two operating points a run may fail to converge, make energy, or
depend on the time step. This campaign measures how often, and explains every run that is
not valid by class:

- the study ``studies/stress.toml`` (every shape, both substrates, inclines 0/35/70 deg,
  0.5/5/20 Hz, friction, adhesion, offset and field drawn uniformly over wide ranges; 10%
  of the runs re-simulated at dt / 4, numbers compared);
- :func:`three_d_runs`: magnetisation tilted about a random axis by up to 30 deg, both
  substrates, flat and 20 deg (MODEL.md: out-of-plane offsets make the motion 3-D);
- :func:`write_report`: ``stress.md`` and a figure. CI runs the quick version
  (``studies/stress_quick.toml``, 8 3-D runs).
"""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from tumblemc.model.energy import ENERGY_GAIN_TOL
from tumblemc.model.rows import RunRow, TimeGrid, simulate_rows
from tumblemc.model.solver_options import DEFAULT_ROTATION
from tumblemc.schema import STATUS_NAMES, STATUS_TABLE
from tumblemc.testing import REPRODUCERS
from tumblemc.viz.stress import stress_figure

PAPER_CUBOID_H = 1e-4  # m (MODEL.md, "Shapes")
#: what each status means in the report, by name
STATUS_CLASSES = {name: meaning for _, name, meaning in STATUS_TABLE if name != "ok"}


def three_d_runs(n: int = 100, seed: int = 2026, rotation: str = DEFAULT_ROTATION, dt: float | None = None) -> list[dict[str, Any]]:
    """``n`` cuboid runs with the magnetisation tilted about a random axis by up to 30 deg.

    Runs cycle through (paper, aluminum) x (0, 20 deg), 20 mT, 1 Hz, 2 periods, with the
    default rotation row unless ``rotation`` says otherwise; the axis and angle of run
    ``k`` are the ``k``-th draw of ``numpy.random.default_rng(seed)``.
    Returns one dict per run: its inputs and the outcomes of
    :func:`~tumblemc.model.rows.simulate_rows`, plus ``max_penetration_H`` (over the paper
    cuboid's height).
    """
    rng = np.random.default_rng(seed)
    combos = [(p, inc) for p in ("paper", "aluminum") for inc in (0.0, 20.0)]
    rows: list[RunRow] = []
    for k in range(n):
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        angle = float(rng.uniform(0.0, 30.0))
        preset, incline = combos[k % len(combos)]
        rows.append(
            {
                "preset": preset,
                "incline_deg": incline,
                "field_mT": 20.0,
                "freq_hz": 1.0,
                "offset_deg": angle,
                "offset_axis": (float(axis[0]), float(axis[1]), float(axis[2])),
            }
        )
    grid = TimeGrid(periods=2.0, dt=dt, rotation=rotation)
    res = simulate_rows("cuboid", rows, grid)
    out = []
    for i, row in enumerate(rows):
        rec: dict[str, Any] = {"run": i, **row}
        rec["offset_axis"] = "(" + ", ".join(f"{a:.3f}" for a in row["offset_axis"]) + ")"
        for name, values in res.items():
            rec[name] = values[i].item() if hasattr(values[i], "item") else values[i]
        rec["max_penetration_H"] = rec["max_penetration"] / PAPER_CUBOID_H
        out.append(rec)
    return out


def reproducers(quick: bool = False) -> list[dict[str, Any]]:
    """The issue's reproducers under both rotation rows, at the default dt and dt / 4.

    One row per run: progress ratio, status, failed and loose steps, the ledger's gain over
    the energy scale, the centre of mass's largest height above its start (m) and the 3-D
    summaries. ``quick``: the default dt only.
    """
    from tumblemc.model.outcome import summarize
    from tumblemc.model.run import DEFAULT_DT, simulate

    out = []
    for name, case in REPRODUCERS:
        kw = dict(case)
        base = kw.pop("dt", DEFAULT_DT)  # a reproducer's own step (the snap hop's), or the default's ceiling
        for rotation in ("paper", "momentum"):
            for dt in (base,) if quick else (base, base / 4):
                t0 = time.perf_counter()
                ds = simulate(rotation=rotation, dt=dt, record_every=4 if dt < base else 1, **kw)
                s = summarize(ds)
                z = ds["position"].values @ np.array([0.0, 0.0, 1.0])
                out.append(
                    {
                        "case": name,
                        "rotation": rotation,
                        "dt": dt,
                        "progress_ratio": s["progress_ratio"],
                        "status": STATUS_NAMES[int(s["status"])],
                        "failed_steps": s["failed_steps"],
                        "loose_steps": s["loose_steps"],
                        "energy_gain_ratio": s["energy_gain_ratio"],
                        "max_rise_m": float(z.max() - z[0]),
                        "lateral_drift": s["lateral_drift"],
                        "heading_change_deg": s["heading_change_deg"],
                        "wall_s": time.perf_counter() - t0,
                    }
                )
    return out


def study_summary(runs: xr.Dataset) -> dict[str, Any]:
    """Counts of a stress study's ``runs`` group: statuses, invalid share, ledger margins and the dt check."""
    st = runs["status"].values
    n = st.size
    ok = st == 0
    gain = runs["energy_gain_ratio"].values
    out: dict[str, Any] = {
        "runs": n,
        "status_counts": {STATUS_NAMES.get(int(k), str(k)): int((st == k).sum()) for k in np.unique(st)},
        "invalid": int((~ok).sum()),
        "invalid_share": float((~ok).mean()) if n else math.nan,
        "ok_gain_ratio_max": float(np.nanmax(gain[ok])) if ok.any() else math.nan,
        "ok_gain_ratio_q99": float(np.nanquantile(gain[ok], 0.99)) if ok.any() else math.nan,
        "ok_over_energy_tol": int(np.count_nonzero(gain[ok] > ENERGY_GAIN_TOL)),
    }
    if "loose_steps" in runs.variables:
        loose = runs["loose_steps"].values
        out.update(loose_steps=int(loose.sum()), loose_runs=int(np.count_nonzero(loose)))
    if "impulse_steps" in runs.variables:
        imp = runs["impulse_steps"].values
        out.update(impulse_steps=int(imp.sum()), impulse_runs=int(np.count_nonzero(imp)))
    if "check_run" in runs.variables:
        idx = runs["check_run"].values.astype(int)
        coarse = runs["progress_ratio"].values[idx]
        fine = runs["check_progress_ratio_fine"].values
        both_ok = (st[idx] == 0) & (runs["check_status_fine"].values == 0)
        within = runs["check_ratio_within_tol"].values.astype(bool) if "check_ratio_within_tol" in runs.variables else None
        out.update(
            checked=int(idx.size),
            checked_both_ok=int(both_ok.sum()),
            check_max_abs_diff_ok=float(np.nanmax(np.abs(fine - coarse)[both_ok])) if both_ok.any() else math.nan,
        )
        if within is not None:
            out["check_ok_outside_tol"] = int(np.count_nonzero(both_ok & ~within))
        if "check_sensitive" in runs.variables:
            sens = runs["check_sensitive"].values
            out.update(check_outside_sensitive=int(np.count_nonzero(sens == 1)), check_outside_dt_limited=int(np.count_nonzero(sens == 0)))
    return out


def outside_table(runs: xr.Dataset) -> list[dict[str, Any]]:
    """One row per valid check run outside the dt tolerance: its cell, ratios at both steps, the twins' spread and class."""
    if "check_ratio_within_tol" not in runs.variables:
        return []
    idx = runs["check_run"].values.astype(int)
    sens = runs["check_sensitive"].values if "check_sensitive" in runs.variables else np.full(idx.size, -1)
    spread = runs["check_twin_spread"].values if "check_twin_spread" in runs.variables else np.full(idx.size, np.nan)
    rows = []
    for k in np.flatnonzero(runs["check_ratio_within_tol"].values == 0):
        i = int(idx[k])
        r: dict[str, Any] = {"run": i}
        for c in ("shape", "substrate", "incline_deg", "freq_hz"):
            r[c] = runs[c].values[i].item()
        r["ratio at dt"] = float(runs["progress_ratio"].values[i])
        r["ratio at dt / 4"] = float(runs["check_progress_ratio_fine"].values[k])
        r["twins' spread"] = float(spread[k])
        r["class"] = {1: "sensitive", 0: "limited by dt"}.get(int(sens[k]), "not classified")
        rows.append(r)
    return rows


def invalid_table(runs: xr.Dataset) -> list[dict[str, Any]]:
    """One row per invalid run: its cell, sampled parameters, status class and counters."""
    st = runs["status"].values
    params = [p for p in ("mu", "adhesion_C", "offset_deg", "field_mT_sampled") if p in runs.variables]
    rows = []
    for i in np.flatnonzero(st != 0):
        r: dict[str, Any] = {"run": int(i), "status": STATUS_NAMES.get(int(st[i]), str(st[i]))}
        for c in ("shape", "substrate", "incline_deg", "freq_hz"):
            r[c] = runs[c].values[i].item()
        for p in params:
            r[p] = float(runs[p].values[i])
        for c in ("failed_steps", "loose_steps", "impulse_steps", "energy_gain_ratio", "progress_ratio"):
            if c in runs.variables:
                r[c] = runs[c].values[i].item()
        rows.append(r)
    return rows


def _md_table(rows: list[dict[str, Any]], keys: list[str] | None = None) -> str:
    if not rows:
        return "(none)\n"
    keys = keys or list(rows[0])
    lines = ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    for r in rows:
        lines.append("| " + " | ".join(f"{r[k]:.4g}" if isinstance(r[k], float) else str(r[k]) for k in keys) + " |")
    return "\n".join(lines) + "\n"


def write_report(
    runs: xr.Dataset,
    three_d: list[dict[str, Any]],
    out_dir: str | Path,
    commands: list[str],
    title: str,
    repro: list[dict[str, Any]] | None = None,
) -> Path:
    """Write ``stress.md`` and ``stress.png`` under ``out_dir``; returns the report's path."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    s = study_summary(runs)
    inv = invalid_table(runs)
    stress_figure(runs, three_d, out / "stress.png")
    lines = [f"# {title}", "", "Regenerate with:", "", "```", *commands, "```", ""]
    lines += ["## Study", ""]
    lines += [
        f"- runs: {s['runs']}; statuses: {s['status_counts']}",
        f"- not valid: {s['invalid']} ({100 * s['invalid_share']:.2f}%; target at most 0.5%)",
        f"- energy ledger over the valid runs: largest gain {s['ok_gain_ratio_max']:.3g} of the energy scale"
        f" (99th percentile {s['ok_gain_ratio_q99']:.3g}; tolerance {ENERGY_GAIN_TOL:g}); valid runs above it: {s['ok_over_energy_tol']}",
    ]
    if "impulse_steps" in s:
        lines.append(
            f"- loose steps: {s['loose_steps']} in {s['loose_runs']} runs; of them kept by impulse_accept_tol"
            f" (unsolved at the smallest sub-step, momentum balanced): {s['impulse_steps']} in {s['impulse_runs']} runs"
        )
    if "checked" in s:
        line = (
            f"- dt / 4 check: {s['checked']} runs re-simulated, {s['checked_both_ok']} valid at both steps;"
            f" largest |ratio difference| among those {s['check_max_abs_diff_ok']:.4g}"
        )
        if "check_ok_outside_tol" in s:
            line += f"; valid runs outside the dt tolerance: {s['check_ok_outside_tol']}"
        if "check_outside_sensitive" in s:
            line += (
                f" ({s['check_outside_dt_limited']} limited by dt, {s['check_outside_sensitive']} sensitive: a change of"
                f" {runs.attrs.get('check_twin_rel', math.nan):g} in the magnetisation moves their ratio at dt beyond the tolerance)"
            )
        lines.append(line)
        outside = outside_table(runs)
        if outside:
            head = "Valid runs outside the dt tolerance, with the sensitivity twins' class (docs/guide/study_results.md, the dt check):"
            lines += ["", head, ""]
            lines.append(_md_table(outside).rstrip("\n"))
    lines += ["", "![energy ledger and dt check](stress.png)", "", "### Runs that are not valid, by class", ""]
    classes: dict[str, int] = {}
    for r in inv:
        classes[r["status"]] = classes.get(r["status"], 0) + 1
    for name, count in sorted(classes.items()):
        lines.append(f"- **{name}** ({count}): {STATUS_CLASSES.get(name, '')}")
    lines += ["", _md_table(inv)]
    if three_d:
        n3 = len(three_d)
        fails = sum(int(r["failed_steps"]) > 0 for r in three_d)
        over = sum(float(r["energy_gain_ratio"]) > ENERGY_GAIN_TOL for r in three_d)
        pen = max(float(r["max_penetration_H"]) for r in three_d)
        lines += [
            "## 3-D runs",
            "",
            f"{n3} cuboid runs, magnetisation tilted about a random axis by up to 30 deg, paper and aluminum, flat and 20 deg,"
            " 20 mT, 1 Hz, 2 periods.",
            "",
            f"- runs with failed steps: {fails} (target 0)",
            f"- runs over the energy tolerance: {over} (target 0)",
            f"- largest penetration: {pen:.3g} H (target at most 1e-3 H)",
            f"- largest |lateral drift|: {max(abs(float(r['lateral_drift'])) for r in three_d) * 1e3:.3g} mm;"
            f" largest |heading change|: {max(abs(float(r['heading_change_deg'])) for r in three_d):.3g} deg",
            "",
        ]
        keys = ["run", "preset", "incline_deg", "offset_deg", "offset_axis", "status", "failed_steps", "loose_steps"]
        keys += ["energy_gain_ratio", "max_penetration_H", "progress_ratio", "lateral_drift", "heading_change_deg"]
        lines.append(_md_table(three_d, keys))
    if repro:
        lines += ["## The solver's reproducers", "", "Both rotation rows (MODEL.md), default dt and dt / 4.", "", _md_table(repro)]
    path = out / "stress.md"
    path.write_text("\n".join(lines) + "\n")
    return path


def run_campaign(
    config: str | Path, result: str | Path, out_dir: str | Path, n3d: int, workers: int | None = None, quick: bool = False
) -> Path:
    """Run (or resume) the stress study and the 3-D runs, then write the report.

    ``workers``: processes of an embedded local cluster (``None``: all cores; 0: this
    process, no dask); ``quick``: the reproducers at the default dt only.
    """
    from tumblemc.study.engine import local_client, run_study

    t0 = time.perf_counter()
    client = None if workers == 0 else local_client(workers)
    try:
        res = run_study(config, client, out=result)
    finally:
        if client is not None:
            cluster = getattr(client, "cluster", None)
            client.close()
            if cluster is not None:
                cluster.close()
    print(f"study: {res.path} ({time.perf_counter() - t0:.0f} s)", flush=True)
    t1 = time.perf_counter()
    three = three_d_runs(n3d)
    print(f"3-D runs: {n3d} ({time.perf_counter() - t1:.0f} s)", flush=True)
    t2 = time.perf_counter()
    repro = reproducers(quick=quick)
    print(f"reproducers: {len(repro)} runs ({time.perf_counter() - t2:.0f} s)", flush=True)
    cmd = f"tumblemc stress --config {config} --result {result} --out {out_dir} --n3d {n3d}" + (" --quick" if quick else "")
    return write_report(res.runs, three, out_dir, [cmd], f"Stress campaign: {Path(config).name}", repro)


__all__ = ["REPRODUCERS", "invalid_table", "reproducers", "run_campaign", "study_summary", "three_d_runs", "write_report"]
