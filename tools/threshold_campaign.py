"""Validation campaign of threshold studies: the search against exhaustive sweeps and the lab protocols.

    python tools/threshold_campaign.py audit [--samples 13] [--out-dir results/threshold_campaign]
    python tools/threshold_campaign.py lab [--samples 10] [--out-dir results/threshold_campaign]

``audit``: the main job (studies/default.toml) at ``--samples`` per shape and substrate
with every sample in the check subset (``[check] fraction = 1``), once per search start
(``pilot`` and ``bisect``): every sample's searched threshold is compared with the one
its direct simulations at every grid incline (to the end, no early decision) give; also
the verdicts at every grid incline, the early stops, and the runs per sample.

``lab``: a threshold study on the field axis (the critical field: the paper cuboid, flat,
1 Hz, fields 3 to 11 mT every 0.5 mT) and one on the frequency axis (the fastest grid
frequency the robot still climbs at: paper cuboid, flat, 6 mT, 2 to 66 Hz every 4 Hz, 3
periods),
each of ``--samples`` sampled robots, against the lab protocols run on the same sampled
parameters: :func:`tumblemc.lab.critical_field` bisecting ``[3, 11]`` mT to 0.5 mT (its
midpoints are grid points, so its final bracket is a pair of neighbouring grid values),
and :func:`tumblemc.lab.step_out` swept over the same grid (``refine=False``; the verdict
there is the study's: progress ratio >= 0.5, not the lab's following share). Brackets
must be identical.

Writes ``REPORT_<what>.md`` in ``--out-dir`` and, with ``--report``, the same text there
(``docs/notes/threshold_campaign.md``, which docs/notes/threshold_studies.md quotes).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
import tomllib
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def audit(samples: int, out_dir: Path) -> list[str]:
    from tumblemc.io import open_result
    from tumblemc.study.engine import run_study

    base = tomllib.loads((ROOT / "studies" / "default.toml").read_text())
    lines = [f"## Search against exhaustive sweeps ({samples} samples per shape and substrate, every sample audited)", ""]
    lines += [
        "| start | samples | thresholds compared | identical | verdicts compared | differ | non-monotone "
        "| early stops | contradicted | runs per sample |"
    ]
    lines += ["|---|---|---|---|---|---|---|---|---|---|"]
    for start in ("pilot", "bisect"):
        cfg = dict(
            base,
            name=f"threshold_audit_{start}",
            samples=samples,
            threshold_start=start,
            check={"fraction": 1.0, "min_runs": 1, "dt_factor": 4},
        )
        t0 = time.perf_counter()
        res = run_study(cfg, out=out_dir / f"audit_{start}.nc", progress=True)
        runs, _ = open_result(res.path)
        a = runs.attrs
        n = runs.sizes["run"]
        tc, tm = int(a["audit_thresholds_compared"]), int(a["audit_threshold_mismatches"])
        lines.append(
            f"| {start} | {n} | {tc} | {tc - tm} | {int(a['audit_compared_verdicts'])} | {int(a['audit_disagreements'])} | "
            f"{int(a['audit_nonmonotone_samples'])} | {int(a['audit_early_stopped_probes'])} | {int(a['audit_early_stopped_climbed'])} | "
            f"{float(runs['n_simulations'].mean()):.2f} |"
        )
        print(f"{start}: {time.perf_counter() - t0:.0f} s", file=sys.stderr)
        if tm:
            bad = runs["check_run"].values[runs["check_n_pass_direct"].values != runs["n_pass"].values[runs["check_run"].values]]
            lines.append(f"|  | mismatched runs: {bad.tolist()} | | | | | | | | |")
    return [*lines, ""]


def _lab_field(runs: Any, names: list[str]) -> list[str]:
    from tumblemc.lab import critical_field

    rows = []
    same = 0
    for i in range(runs.sizes["run"]):
        kw: dict[str, Any] = {p: float(runs[p].values[i]) for p in names}
        lab = critical_field(1.0, 0.0, "cuboid", "paper", lo_mT=3.0, hi_mT=11.0, tol_mT=0.5, periods=2.0, **kw)
        lab_br: tuple[Any, ...] = tuple(float(v) for v in lab["bracket_mT"].values)
        if bool(lab["tumbles_at_lo"]) or not bool(lab["tumbles_at_hi"]):
            lab_br = ("censored", "censored")
        st_br: tuple[Any, ...] = (float(runs["threshold_fail"].values[i]), float(runs["threshold"].values[i]))
        if int(runs["censored"].values[i]) != 0:
            st_br = ("censored", "censored")
        ok = lab_br == st_br
        same += ok
        sims = int(runs["n_simulations"].values[i])
        verdict = "yes" if ok else "NO"
        rows.append(
            f"| {i} | {lab_br[0]}-{lab_br[1]} | {st_br[0]}-{st_br[1]} | {int(lab['n_runs'])} | {sims} | {_audit(runs, i)} | {verdict} |"
        )
    head = [
        f"Identical brackets: {same} of {runs.sizes['run']}.",
        "",
        "| sample | lab bracket (mT) | study bracket (mT) | lab runs | study runs | study's audit | same |",
        "|---|---|---|---|---|---|---|",
    ]
    return head + rows


def _audit(runs: Any, i: int) -> str:
    """The study's own audit of sample ``i`` (every sample is a check sample in these studies)."""
    pos = np.flatnonzero(runs["check_run"].values == i)
    if not len(pos):
        return "not audited"
    return "NON-MONOTONE" if int(runs["check_nonmonotone"].values[pos[0]]) else "monotone"


def _lab_freq(runs: Any, names: list[str], freqs: np.ndarray) -> list[str]:
    from tumblemc.lab import step_out

    rows = []
    same = same_mono = n_mono = agree_mono = 0
    for i in range(runs.sizes["run"]):
        kw: dict[str, Any] = {p: float(runs[p].values[i]) for p in names}
        sw = step_out(
            freqs.tolist(), field_mT=6.0, incline_deg=0.0, shape="cuboid", preset="paper", periods=3.0, threshold=0.5, refine=False, **kw
        )
        climbed = (sw["progress_ratio"].values >= 0.5) & (sw["status"].values == 0)
        fails = np.flatnonzero(~climbed)
        k = int(fails[0]) if len(fails) else len(freqs)
        lab_br = (float(freqs[k - 1]) if k > 0 else math.nan, float(freqs[k]) if k < len(freqs) else math.nan)
        st_br = (float(runs["threshold"].values[i]), float(runs["threshold_fail"].values[i]))
        ok = all((a == b) or (math.isnan(a) and math.isnan(b)) for a, b in zip(lab_br, st_br, strict=True))
        same += ok
        mono = "yes" if not np.any(np.diff(climbed.astype(int)) > 0) else "no"
        sims = int(runs["n_simulations"].values[i])
        audit = _audit(runs, i)
        agree_mono += (mono == "yes") == (audit == "monotone")
        same_mono += ok and mono == "yes"
        n_mono += mono == "yes"
        verdict = "yes" if ok else "NO"
        rows.append(
            f"| {i} | {lab_br[0]:g}-{lab_br[1]:g} | {st_br[0]:g}-{st_br[1]:g} | {len(freqs)} | {sims} | {mono} | {audit} | {verdict} |"
        )
    head = [
        f"Identical brackets: {same} of {runs.sizes['run']}; {same_mono} of the {n_mono} robots whose lab sweep is monotone. "
        f"The study's audit (every robot swept over the grid) calls the same robots non-monotone as the lab sweep in "
        f"{agree_mono} of {runs.sizes['run']}.",
        "",
        "| sample | lab sweep: last climbed - first failed (Hz) | study bracket (Hz) | lab runs | study runs | lab sweep monotone "
        "| study's audit | same |",
        "|---|---|---|---|---|---|---|---|",
    ]
    return head + rows


def lab(samples: int, out_dir: Path) -> list[str]:
    from tumblemc.io import open_result
    from tumblemc.study.engine import run_study

    common: dict[str, Any] = {
        "mode": "threshold",
        "shapes": ["cuboid"],
        "presets": ["paper"],
        "incline_deg": 0,
        "periods": 2,
        "samples": samples,
        "seed": 7,
        "threshold_start": "bisect",
        "check": {"fraction": 1.0, "min_runs": 0},  # every sample audited: the study's own verdict on monotonicity
    }
    fields = np.arange(3.0, 11.01, 0.5)
    freqs = np.arange(2.0, 66.01, 4.0)
    out = []
    f_cfg = dict(common, name="critical_field_study", threshold_axis="field_mT", field_mT=fields.tolist(), freq_hz=1)
    fr = run_study(f_cfg, out=out_dir / "critical_field.nc", progress=True)
    runs, _ = open_result(fr.path)
    names = [v for v in str(runs.attrs["uncertain"]).split(",") if v]
    out += ["## Critical field per sample: threshold study against `lab.critical_field`", "", *_lab_field(runs, names), ""]
    # 3 periods: with 2, summarize() (the lab's) refuses some frequencies whose last period is
    # a rounding short of a whole one (the window is n_steps - i0 steps of dt)
    q_cfg = dict(common, name="frequency_study", threshold_axis="freq_hz", field_mT=6, freq_hz=freqs.tolist(), periods=3)
    qr = run_study(q_cfg, out=out_dir / "frequency.nc", progress=True)
    runs, _ = open_result(qr.path)
    out += [
        "## Fastest frequency climbed per sample: threshold study against a `lab.step_out` sweep",
        "",
        *_lab_freq(runs, names, freqs),
        "",
    ]
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("what", choices=["audit", "lab", "all"])
    ap.add_argument("--samples", type=int, default=None, help="per shape and substrate (audit: 13), or per study (lab: 10)")
    ap.add_argument("--out-dir", default="results/threshold_campaign", help="the studies' result files")
    ap.add_argument("--report", default=None, help="also write the report (Markdown) here, e.g. docs/notes/threshold_campaign.md")
    args = ap.parse_args(argv)
    out_dir = Path(args.out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    lines = ["# Threshold studies: validation campaign", "", f"`python tools/threshold_campaign.py {args.what}`", ""]
    if args.what in ("audit", "all"):
        lines += audit(args.samples or 13, out_dir)
    if args.what in ("lab", "all"):
        lines += lab(args.samples or 10, out_dir)
    text = "\n".join(lines)
    (out_dir / f"REPORT_{args.what}.md").write_text(text + "\n")
    if args.report:
        Path(args.report).write_text(text + "\n")
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
