"""Would the midpoint integrator make a good default? The validation suite run with it (issue 45, item 2).

Runs ``tumblemc.reports.claims.run_validation`` with the defaults of ``simulate``,
``run_inputs`` and ``TimeGrid`` switched to ``rotation="midpoint", torque="mid"`` (callers
that name a rotation or torque keep theirs: the convergence table's torque=end rows, the
stress reproducers' paper rows), into ``--out``; then compares its claims and robustness
tables with a reference folder (default: the committed ``docs/validation``) row by row.

    python experiments/midpoint_default.py --out /tmp/val_midpoint            # about 10 min
    python experiments/midpoint_default.py --compare-only --out /tmp/val_midpoint

The stress study's paired comparison is ``studies/stress.toml`` run twice, the second with
``rotation = "midpoint"`` and ``torque = "mid"`` added (see docs/notes/step_size.md).
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
from pathlib import Path


def use_midpoint() -> None:
    """Switch the default rotation and torque of a run and of a batch to the midpoint rule."""
    import tumblemc.model.rows as rows
    import tumblemc.model.run as run

    for f in (run.run_inputs, run.simulate):
        assert f.__kwdefaults__ is not None
        f.__kwdefaults__.update(rotation="midpoint", torque="mid")
    fields = [f for f in dataclasses.fields(rows.TimeGrid) if f.default is not dataclasses.MISSING]
    new = {"rotation": "midpoint", "torque": "mid"}
    rows.TimeGrid.__init__.__defaults__ = tuple(new.get(f.name, f.default) for f in fields)
    assert rows.TimeGrid().rotation == "midpoint" and rows.TimeGrid().torque == "mid"


def read(path: Path) -> list[dict[str, str]]:
    with path.open() as fh:
        return list(csv.DictReader(fh))


def compare(out: Path, ref: Path) -> None:
    """Claims whose verdict differs, and the robustness rows' statuses and largest ratios."""
    a, b = read(ref / "claims.csv"), read(out / "claims.csv")
    key = lambda r: (r["claim_id"], r["scenario"], r["quantity"])  # noqa: E731
    ra = {key(r): r for r in a}
    moved = [
        (k, ra[k]["verdict"], r["verdict"], ra[k]["measured"], r["measured"])
        for r in b
        if (k := key(r)) in ra and ra[k]["verdict"] != r["verdict"]
    ]
    n_a, n_b = (sum(r["verdict"] == "pass" for r in rows_) for rows_ in (a, b))
    print(f"claims: {n_a} pass with the default, {n_b} with midpoint; verdicts moved: {len(moved)}")
    for k, va, vb, ma, mb in moved:
        print(f"  {k[0]} {k[1]} ({k[2]}): {va} -> {vb}\n      default:  {ma}\n      midpoint: {mb}")
    ra_, rb_ = read(ref / "robustness.csv"), read(out / "robustness.csv")
    for name, rows_ in (("default", ra_), ("midpoint", rb_)):
        bad = [r for r in rows_ if r["status"] != "0"]
        worst = max(float(r["energy_gain_ratio"]) for r in rows_)
        fails = sum(int(r["failed_steps"]) for r in rows_)
        names = ": " + ", ".join(r["scenario"] for r in bad) if bad else ""
        print(
            f"robustness ({name}): {len(rows_)} scenarios, {len(bad)} not ok, {fails} failed steps, largest energy ratio {worst:.2g}{names}"
        )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="/tmp/val_midpoint")
    ap.add_argument("--ref", default=str(Path(__file__).resolve().parents[1] / "docs" / "validation"))
    ap.add_argument("--compare-only", action="store_true")
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args()
    if not args.compare_only:
        use_midpoint()
        from tumblemc.reports.claims import run_validation

        run_validation(args.out, quick=args.quick)
    compare(Path(args.out), Path(args.ref))


if __name__ == "__main__":
    main()
