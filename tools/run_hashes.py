"""Hash every recorded array of a set of runs, to compare two versions bit for bit.

    python tools/run_hashes.py --out new.json                    # this checkout
    PYTHONPATH=/path/to/old/checkout python tools/run_hashes.py --out old.json
    python tools/run_hashes.py --compare old.json new.json

A refactor or a speed change that claims the same arithmetic should leave every run's
records unchanged. Each case below (every shape; paper and aluminum; inclines, flat, 10 Hz;
a 3-D magnetisation) is simulated with every step recorded (``record_every=1``), and the
SHA-256 of each variable's bytes (data and coordinates) and of the run's attributes is
written. ``--compare`` lists the cases and
variables that differ, and exits 1 if any does.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
from pathlib import Path
from typing import Any

CASES: dict[str, dict[str, Any]] = {
    "cuboid_paper_45": dict(shape="cuboid", preset="paper", incline_deg=45.0, duration_s=1.0),
    "cuboid_aluminum_30": dict(shape="cuboid", preset="aluminum", incline_deg=30.0, duration_s=1.0),
    "cuboid_flat_10Hz": dict(shape="cuboid", preset="paper", incline_deg=0.0, freq_hz=10.0, duration_s=0.3),
    "spiked_paper_20": dict(shape="spiked", preset="paper", incline_deg=20.0, duration_s=1.0),
    "spiked_aluminum_25": dict(shape="spiked", preset="aluminum", incline_deg=25.0, duration_s=1.0),
    "spiked_ends_paper_45": dict(shape="spiked_ends", preset="paper", incline_deg=45.0, duration_s=1.0),
    "spiked_ends_aluminum_20": dict(shape="spiked_ends", preset="aluminum", incline_deg=20.0, duration_s=1.0),
    "curved_paper_45": dict(shape="curved", preset="paper", incline_deg=45.0, duration_s=1.0),
    "curved_paper_flat": dict(shape="curved", preset="paper", incline_deg=0.0, duration_s=1.0),
    "curved_flat_10Hz": dict(shape="curved", preset="paper", incline_deg=0.0, freq_hz=10.0, duration_s=0.3),
    "curved_aluminum_35": dict(shape="curved", preset="aluminum", incline_deg=35.0, duration_s=1.0),
    "curved_aluminum_60": dict(shape="curved", preset="aluminum", incline_deg=60.0, duration_s=0.5),
    "cuboid_offset_3d": dict(
        shape="cuboid", preset="paper", incline_deg=15.0, offset_deg=20.0, offset_axis=(0.0, 1.0, 0.0), duration_s=0.5
    ),
}


#: attributes that name the version or describe the file, not the run's result
SKIP_ATTRS = ("tumblemc_version", "source", "title", "Conventions", "status_meanings")


def hashes(cases: dict[str, dict[str, Any]]) -> dict[str, dict[str, str]]:
    """SHA-256 of every variable (data and coordinates) of each case's records, and of its attributes.

    The attributes hold the run's status, counters and energy figures; :data:`SKIP_ATTRS`
    are left out.
    """
    import tumblemc

    out: dict[str, dict[str, str]] = {}
    for name, kw in cases.items():
        print(f"{name} ...", file=sys.stderr, flush=True)
        ds = tumblemc.simulate(**kw, record_every=1)
        h = {v: hashlib.sha256(ds[v].values.tobytes()).hexdigest() for v in sorted(str(k) for k in ds.variables)}
        attrs = {k: repr(v) for k, v in sorted(ds.attrs.items()) if k not in SKIP_ATTRS}
        h["(attributes)"] = hashlib.sha256(json.dumps(attrs, sort_keys=True).encode()).hexdigest()
        out[name] = h
    return out


def compare(a: dict[str, dict[str, str]], b: dict[str, dict[str, str]]) -> list[str]:
    """The (case, variable) pairs whose hashes differ or that one side lacks."""
    diff = []
    for case in sorted(set(a) | set(b)):
        va, vb = a.get(case, {}), b.get(case, {})
        diff += [f"{case}: {v}" for v in sorted(set(va) | set(vb)) if va.get(v) != vb.get(v)]
    return diff


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, help="write the hashes here (JSON)")
    ap.add_argument("--compare", nargs=2, type=Path, metavar=("A", "B"), help="compare two hash files")
    ap.add_argument("--cases", default=None, help="comma-separated subset of the cases (default: all)")
    args = ap.parse_args(argv)
    if args.compare:
        a, b = (json.loads(p.read_text()) for p in args.compare)
        diff = compare(a, b)
        n = sum(len(v) for v in b.values())
        print(f"{len(b)} cases, {n} arrays: " + ("identical" if not diff else f"{len(diff)} differ"))
        for d in diff:
            print("  " + d)
        return 1 if diff else 0
    names = list(CASES) if args.cases is None else args.cases.split(",")
    unknown = [c for c in names if c not in CASES]
    if unknown:
        raise SystemExit(f"--cases: unknown {unknown} (allowed: {', '.join(CASES)})")
    h = hashes({c: CASES[c] for c in names})
    text = json.dumps(h, indent=1, sort_keys=True)
    if args.out:
        args.out.write_text(text)
    else:
        print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
