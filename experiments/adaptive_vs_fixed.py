"""Compare an adaptive study with the fixed-n study of the same cells (issue 15, item 4): writes a markdown report.

    python experiments/adaptive_vs_fixed.py FIXED.nc ADAPTIVE.nc [--out docs/notes/adaptive_default.md]
        [--fixed-minutes M] [--adaptive-minutes M]

Per cell: runs kept, ``p_success`` of both, whether the adaptive estimate lies in the
fixed-n study's interval, and whether the runs kept are exactly the first runs of the fixed
study's cell (same ``run_key``, same outcomes) with the count the stopping rule picks from
the fixed study's outcomes (:func:`tumblemc.analysis.confseq.stop_count`). A figure of
runs kept per cell against the fixed study's ``p_success`` is written next to the report.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from tumblemc.analysis.confseq import CS_METHODS, stop_count
from tumblemc.io import open_result
from tumblemc.model.outcome import is_valid

OUTCOME_COLUMNS = ("run_key", "status", "climbed", "progress_ratio", "energy_gain", "newton_iterations")


def compare(fixed: Path, adaptive: Path) -> tuple[list[dict[str, object]], dict[str, object]]:
    """Rows per cell and totals."""
    fr, fm = open_result(fixed)
    ar, am = open_result(adaptive)
    prec, level, cap = float(ar.attrs["precision"]), float(am["p_success_lower"].attrs["confidence_level"]), 0
    mixture = CS_METHODS[str(am["p_success_lower"].attrs["ci_method"])]
    rows = []
    dims = am["p_success"].dims  # shape, substrate, incline_deg and any field or frequency sweep
    for idx in np.ndindex(*am["p_success"].shape):
        where = {d: am[d].values[i] for d, i in zip(dims, idx, strict=True)}
        fsel = np.flatnonzero(np.logical_and.reduce([fr[d].values == v for d, v in where.items()]))
        asel = np.flatnonzero(np.logical_and.reduce([ar[d].values == v for d, v in where.items()]))
        fsel = fsel[np.argsort(fr["sample"].values[fsel])]
        asel = asel[np.argsort(ar["sample"].values[asel])]
        cap = max(cap, fsel.size)
        valid = is_valid(fr["status"].values[fsel])
        j = stop_count(valid, valid & (fr["climbed"].values[fsel] == 1), prec, level, mixture) or fsel.size
        prefix = asel.size == j and all(
            np.array_equal(ar[c].values[asel], fr[c].values[fsel[:j]], equal_nan=ar[c].dtype.kind == "f") for c in OUTCOME_COLUMNS
        )
        fc = fm.sel(where)
        ac = am.sel(where)
        pf, pa = float(fc["p_success"]), float(ac["p_success"])
        lo, hi = float(fc["p_success_lower"]), float(fc["p_success_upper"])
        rows.append(
            {
                "shape": str(where["shape"]),
                "substrate": str(where["substrate"]),
                "incline_deg": float(where["incline_deg"]),
                **{d: float(v) for d, v in where.items() if d in ("field_mT", "freq_hz")},
                "kept": int(asel.size),
                "rule_on_fixed": int(j),
                "prefix": bool(prefix),
                "p_fixed": pf,
                "fixed_lo": lo,
                "fixed_hi": hi,
                "p_adaptive": pa,
                "adaptive_lo": float(ac["p_success_lower"]),
                "adaptive_hi": float(ac["p_success_upper"]),
                "inside": bool(np.isnan(pf) and np.isnan(pa)) or (lo <= pa <= hi),
                "fixed_in_cs": bool(np.isnan(pf) and np.isnan(pa)) or (float(ac["p_success_lower"]) <= pf <= float(ac["p_success_upper"])),
            }
        )
    totals = {
        "fixed_runs": int(fr.sizes["run"]),
        "kept": int(ar.sizes["run"]),
        "simulated": int(ar.attrs["runs_simulated"]),
        "cells": len(rows),
        "cells_at_cap": int(ar.attrs["cells_at_cap"]),
        "inside": sum(bool(r["inside"]) for r in rows),
        "fixed_in_cs": sum(bool(r["fixed_in_cs"]) for r in rows),
        "prefix": sum(bool(r["prefix"]) for r in rows),
        "precision": prec,
        "cap": cap,
        "check_fixed": int(fr.sizes.get("check", 0)),
        "check_adaptive": int(ar.sizes.get("check", 0)),
        "fixed_ci": str(fm["p_success_lower"].attrs.get("ci_method")),
    }
    return rows, totals


def figure(rows: list[dict[str, object]], cap: int, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.0), constrained_layout=True)
    p = np.array([float(r["p_fixed"]) for r in rows])  # type: ignore[arg-type]
    k = np.array([int(r["kept"]) for r in rows])  # type: ignore[call-overload]
    rng = np.random.default_rng(0)
    ax.scatter(p, k + rng.uniform(-1.5, 1.5, k.size), s=16, alpha=0.7, label="a cell (jittered by +-1.5 runs)")
    ax.axhline(cap, color="0.4", ls=":", lw=1)
    ax.text(0.5, cap * 1.01, f"cap ({cap} runs: the fixed-n study)", ha="center", va="bottom", fontsize=8, color="0.3")
    ax.set(xlabel="P(success) of the cell in the fixed-n study", ylabel="runs kept by adaptive sampling", xlim=(-0.03, 1.03))
    ax.set_ylim(0, cap * 1.12)
    ax.set_title(f"Runs per cell: {k.sum():,} kept of {k.size * cap:,}", fontsize=10)
    ax.legend(fontsize=8, loc="lower center")
    fig.savefig(path, dpi=120)
    plt.close(fig)


def report(rows: list[dict[str, object]], t: dict[str, object], fig_name: str, minutes: tuple[float | None, float | None]) -> str:
    saved = 1.0 - float(t["simulated"]) / float(t["fixed_runs"])  # type: ignore[arg-type]
    lines = [
        f"- cells: {t['cells']}; runs kept {t['kept']:,} and simulated {t['simulated']:,} (the rest of the last round of "
        f"a cell that stopped inside it) of the fixed study's {t['fixed_runs']:,}: **{saved:.0%} fewer runs simulated**; "
        f"cells that reached the cap of {t['cap']}: {t['cells_at_cap']}",
        f"- dt-check runs: {t['check_adaptive']} (drawn from the runs kept) against {t['check_fixed']} in the fixed study",
        f"- cells whose adaptive P(success) lies in the fixed study's 95% {t['fixed_ci']} interval: **{t['inside']} of {t['cells']}**",
        f"- cells whose fixed-study P(success) lies in the adaptive study's 95% confidence sequence: "
        f"**{t['fixed_in_cs']} of {t['cells']}**",
        f"- cells whose runs are exactly the first runs of the fixed study's cell, as many as the stopping rule picks "
        f"from the fixed study's outcomes: {t['prefix']} of {t['cells']}",
    ]
    if minutes[0] is not None and minutes[1] is not None:
        lines.append(f"- wall time on this machine (2 workers): fixed {minutes[0]:.1f} min, adaptive {minutes[1]:.1f} min")
    lines += [
        "",
        f"![runs kept per cell]({fig_name})",
        "",
    ]
    sweeps = [(d, u) for d, u in (("field_mT", "field (mT)"), ("freq_hz", "frequency (Hz)")) if rows and d in rows[0]]
    lines += [
        "| shape | substrate | incline | "
        + "".join(f"{u} | " for _, u in sweeps)
        + "runs kept | P fixed (95% interval) | P adaptive (95% CS) | in fixed interval |",
        "|---|---|---|" + "---|" * len(sweeps) + "---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['shape']} | {r['substrate']} | {float(r['incline_deg']):g} | "  # type: ignore[arg-type]
            + "".join(f"{float(r[d]):g} | " for d, _ in sweeps)  # type: ignore[arg-type]
            + f"{r['kept']} | "
            f"{float(r['p_fixed']):.3f} ({float(r['fixed_lo']):.3f}-{float(r['fixed_hi']):.3f}) | "  # type: ignore[arg-type]
            f"{float(r['p_adaptive']):.3f} ({float(r['adaptive_lo']):.3f}-{float(r['adaptive_hi']):.3f}) | "  # type: ignore[arg-type]
            f"{'yes' if r['inside'] else '**no**'} |"
        )
    return "\n".join(lines) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("fixed")
    ap.add_argument("adaptive")
    ap.add_argument("--out", default="docs/notes/adaptive_default.md")
    ap.add_argument("--fixed-minutes", type=float, default=None)
    ap.add_argument("--adaptive-minutes", type=float, default=None)
    args = ap.parse_args()
    rows, totals = compare(Path(args.fixed), Path(args.adaptive))
    out = Path(args.out)
    fig = out.with_suffix(".png")
    figure(rows, int(totals["cap"]), fig)  # type: ignore[call-overload]
    out.write_text(report(rows, totals, fig.name, (args.fixed_minutes, args.adaptive_minutes)), encoding="utf-8")
    print(f"wrote {out} and {fig}")
    print({k: v for k, v in totals.items()})


if __name__ == "__main__":
    main()
