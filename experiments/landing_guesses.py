"""Why three landings failed at every strategy and every halving (docs/notes/solver_gaps.md, sections 11 to 13).

A saved step (``tests/data/<case>.npz``), each fresh guess of the strategy ladder solved by
the kernel's plain Newton: the residual it stops at, the row that holds it, that row's
rounding allowance (``kernels.rounding``) and the contact forces; last the whole step
through the time loop. For ``tiny_step_landing`` (the paper cuboid hopping at 239.84 Hz,
20 mT, at 16 times the default step) first the rigid-body impact of its level edge.
``vertex_rest``: a robot of cell 1 at 3.125e-7 s, a corner landing that stops a turn.
``vertex_pass_through``: a robot of cell 1 at 7.8e-8 s, a corner impact that no attempt of
the ladder solves, and the rescue pass does (section 13).

    python experiments/landing_guesses.py tiny_step_landing
    python experiments/landing_guesses.py vertex_rest
    python experiments/landing_guesses.py vertex_pass_through
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tests.tooling import load_tool, one_step  # noqa: E402
from tumblemc.kernels import guesses as G  # noqa: E402
from tumblemc.kernels import layout as L  # noqa: E402
from tumblemc.kernels.contact import prepare_step  # noqa: E402
from tumblemc.kernels.geometry import quat_to_rot  # noqa: E402
from tumblemc.kernels.newton import make_workspace, solve  # noqa: E402
from tumblemc.kernels.residual import residual  # noqa: E402
from tumblemc.kernels.rounding import EPS, ROUND_ULPS, rounding_scales  # noqa: E402
from tumblemc.kernels.stepper import Model, make_scratch, solver_options  # noqa: E402
from tumblemc.model.run import prepare, run_inputs  # noqa: E402


def _edge_impact(K: np.ndarray, vc: np.ndarray, mu: float, h: float) -> None:
    """The level edge's rigid-body impact: sticking, or sliding with friction along -o or +o."""
    P_stick = np.linalg.solve(K, -vc)
    print(f"edge velocity (scaled): along o {vc[1]:+.3f}, normal {vc[2]:+.3f}; sticking needs |P_t| / P_n = "
          f"{np.hypot(P_stick[0], P_stick[1]) / P_stick[2]:.2f} > mu = {mu}")  # fmt: skip
    pn_ok = np.nan
    for s in (-1.0, 1.0):  # sliding along -/+ o with the full cone
        A = np.array([K[1, 2] + s * mu * K[1, 1], K[2, 2] + s * mu * K[2, 1]])
        pn = -vc[2] / A[1]
        if s * (vc[1] + A[0] * pn) < 0:
            pn_ok = pn
        print(f"  friction along {s:+.0f} o: P_n = {pn:.3f}, end slip along o {vc[1] + A[0] * pn:+.3f} "
              f"({'consistent' if s * (vc[1] + A[0] * pn) < 0 else 'inconsistent'}: friction must oppose the end slip)")  # fmt: skip
    print(f"  lam_n = P_n / h = {pn_ok / h:.3g} weights; one ulp of (mu lam_n)^2: {EPS * (mu * pn_ok / h) ** 2:.2g}")


def main(case: str) -> None:
    tool = load_tool(case)
    saved = np.load(tool.OUT)
    spec = prepare(run_inputs(**tool.RUN))
    model = Model(spec.prm, spec.geo)
    scr = make_scratch(model)
    state, t, h = saved["state"], float(saved["t"]), spec.h
    z0 = saved["z"]
    n = z0.size
    # the impact: the landing edge's middle and the inverse mass matrix there (start pose)
    R = np.zeros(9)
    quat_to_rot(state, 3, R, 0)
    R = R.reshape(3, 3)
    r = z0[6:9] - state[0:3]
    Iw_inv = R @ np.linalg.inv(spec.prm[L.P_IB : L.P_IB + 9].reshape(3, 3)) @ R.T
    rx = np.array([[0, -r[2], r[1]], [r[2], 0, -r[0]], [-r[1], r[0], 0]])
    K = np.eye(3) / spec.prm[L.P_MASS] - rx @ Iw_inv @ rx
    vc = state[7:10] + np.cross(state[10:13], r)
    mu = spec.prm[L.P_MU]
    if case == "tiny_step_landing":
        _edge_impact(K, vc, mu, h)
    opts = solver_options(spec.solver.as_array())[0]
    print("\n| guess | status | residual | row | its allowance | lam_n | lam_o | lam_r |")
    print("|---|---|---|---|---|---|---|---|")
    names = sorted((getattr(G, k), k) for k in dir(G) if k.startswith("G_") and isinstance(getattr(G, k), int))
    for g, name in names:
        prepare_step(state, t, h, spec.prm, float(saved["area"]), saved["mode"] > 0, scr)
        z = z0.copy()
        if g != G.G_WARM and not G.build_guess(g, z, z0.copy(), state, h, model, scr, np.ones(1, np.int64), np.zeros(3)):
            continue
        ws = make_workspace(n)
        it = np.zeros(3, np.int64)
        st, res = solve(z, scr.prob, ws, opts, it, False, 0.0, False)
        residual(z, scr.prob, ws.F, ws.J, (ws.isfb, ws.fbb, ws.rs), False, 0.0)
        sc = np.zeros(n)
        rounding_scales(z, scr.prob, sc)
        row = int(np.argmax(np.abs(ws.F)))
        forces = f"{z[-1]:.3g} | {z[6 + L.B_LO]:.3g} | {z[6 + L.B_LR]:.3g}"
        print(f"| {name} | {st} | {res:.2g} | {row} | {ROUND_ULPS * EPS * sc[row]:.2g} | {forces} |")
    t0 = time.perf_counter()
    (status, failed, _), rec, _, _ = one_step(saved, spec)
    print(f"\nthe step: status {status}, failed {failed}, residual {rec[L.R_RES]:.2g}, Newton iterations {rec[L.R_NIT]:.0f}, "
          f"fallbacks {rec[L.R_FALLBACK]:.0f}, sub-steps {rec[L.R_SUB]:.0f}, {time.perf_counter() - t0:.1f} s")  # fmt: skip


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "tiny_step_landing")
