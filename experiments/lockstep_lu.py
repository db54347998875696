"""Does the Newton LU pay in lockstep? Issue 15, item 2, measured on the kernel the issue named.

    python experiments/lockstep_lu.py [--seconds 0.1] [--runs 8] [--lanes 1,8,16,32]

Item 2 asks for K runs advanced together in structure-of-arrays form, so that the
arithmetic of K runs goes through the vector units at once. The issue's own check put the
gain at about 2.5x per run, with the LU the largest single cost of a step. This script
measures the LU part on real matrices before anyone rewrites the stepper:

1. **Capture.** For each scenario, ``--runs`` runs (the friction coefficient and the
   magnetisation offset drawn per run, seed 5) are simulated for ``--seconds`` with the
   kernels as plain Python, and every Newton matrix is kept
   (``experiments/jacobian_patterns.py``'s capture). Lane ``l`` of a lockstep group takes the
   ``m``-th matrix of run ``l`` (runs repeat, 37 matrices later, past ``--runs`` lanes),
   with a random right-hand side (seed 1).
2. **Scalar path.** Per matrix, what ``newton.solve`` does today: ``copy_amax``, the sparse
   partial-pivoting ``lu_factor`` and ``lu_solve``.
3. **Lockstep.** The same three steps on ``K`` matrices stored ``A[i, j, lane]``
   (:func:`soa_copy_amax`, :func:`soa_lu_factor`, :func:`soa_lu_solve`): each lane's
   partial pivoting (the same choice, ties included), rows swapped from the pivot column on
   (LINPACK's ``dgefa``/``dgesl`` form), the elimination over the union of the lanes'
   nonzero rows and columns, the lane loop innermost (LLVM vectorises it: ``vmulpd`` and
   ``vsubpd`` on zmm registers on this machine's AVX-512).
   The same on one flat array per group with ``n`` and ``K`` compile-time constants
   (:func:`flat_lu`), the layout in which LLVM vectorises straight-line code (item 5).
   Three more forms leave every lane's rows in place, as ``lu_factor`` does, with its
   position bookkeeping per lane (:func:`inplace_lu`): with lane loops, with the lane
   loops written out in generated source (:func:`unrolled_lu`), and with the union
   pattern kept as bit masks (``inplace_lu(..., masks=True)``). Their solutions are
   compared bit pattern for bit pattern (signed zeros too).
4. **Dense scalar**, for scale: the same elimination on one matrix without the sparse
   bookkeeping (:func:`dense_lu_factor`).
5. **A straight-line block of the residual** (``--block``): the end-of-step orientation,
   its rotation matrix and ``d(theta)/d(w+)`` (``geometry.quat_step`` and
   ``quat_to_rot``, the residual's first lines) for K lanes, the lane loop outside a
   straight-line body (:func:`soa_quat_block`), and the same statements each in its own
   lane loop over a scratch row per local (:func:`per_statement_block`, generated from
   :func:`soa_quat_block`'s source), against the scalar kernels lane by lane, on random
   unit quaternions and angular velocities; and the lane-outside form on one flat array
   with ``K`` a compile-time constant (:func:`flat_block`). LLVM vectorises the second
   form only past K = 16 (the per-loop overhead), does not vectorise the first (runtime
   alias checks between the rows of different arrays), and fully vectorises the third
   (zmm ``vmulpd``: every address is one base plus a constant).

Every lane's solution is compared bit for bit with the scalar path's (the extra terms of
the union are exact zeros: ``x - f * 0 == x``), and the times are medians of ``--rounds``
rounds of ``--reps`` passes over every group, compiled first.

Reported in docs/notes/kernel_experiments.md ("Lockstep" and "The lockstep LU with each lane's
rows in place").
"""

from __future__ import annotations

import argparse
import importlib.util
import inspect
import math
import re
import sys
import tempfile
import time
from pathlib import Path
from types import ModuleType
from typing import Any

import numba as nb
import numpy as np

from tumblemc.kernels.geometry import N_QS, QS_JTH, QS_Q, quat_step, quat_to_rot
from tumblemc.kernels.lu import PIVOT_REL, copy_amax, lu_factor, lu_solve

HERE = Path(__file__).resolve().parent
SCENARIOS = {
    "cuboid, paper, 45 deg": dict(shape="cuboid", preset="paper", incline_deg=45.0),
    "cuboid, aluminum, 30 deg": dict(shape="cuboid", preset="aluminum", incline_deg=30.0),
    "curved, paper, 45 deg": dict(shape="curved", preset="paper", incline_deg=45.0),
}
MU = {"paper": (0.3, 0.6), "aluminum": (0.8, 1.0)}  # friction drawn per run, as in the studies' ranges
LANE_SHIFT = 37  # lanes past the runs take a run's matrices this many later

JIT_OPTIONS: dict[str, object] = {
    "nogil": True,
    "error_model": "numpy",
    "_nrt": False,
}  # the kernels' policy (tumblemc/kernels/_jit.py), uncached


def jit(func):
    """Compile ``func`` as the package compiles its kernels (no reference counting)."""
    return nb.njit(**JIT_OPTIONS)(func)  # type: ignore[call-overload]


def _patterns() -> ModuleType:
    spec = importlib.util.spec_from_file_location("jacobian_patterns", HERE / "jacobian_patterns.py")
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod
    spec.loader.exec_module(mod)
    return mod


# ---- lockstep kernels: K matrices stored A[i, j, lane] ---------------------------------
@jit
def soa_copy_amax(J, A, amax, n, K):
    """``A = J`` for every lane; ``amax[l] = max |J[:, :, l]|``."""
    for lane in range(K):
        amax[lane] = 0.0
    for i in range(n):
        for j in range(n):
            for lane in range(K):
                v = J[i, j, lane]
                A[i, j, lane] = v
                a = abs(v)
                amax[lane] = a if a > amax[lane] else amax[lane]


@jit
def soa_lu_factor(A, perm, amax, ok, n, K, lists, work):  # noqa: C901
    """Factor the K matrices ``A[:, :, l]`` in place.

    ``ok[l]`` is False where lane ``l``'s pivot falls below ``PIVOT_REL * amax[l]`` (the scalar path's global test; its row-relative
    retry is not modelled: no captured matrix needs it, which the comparison checks).

    Lane ``l`` swaps rows ``k`` and ``perm[k, l]`` from column ``k`` on (the multipliers
    stay where they were computed, as in LINPACK's ``dgefa``), so the row lists of column
    ``k`` (``lists = (rows, nrows, cols, ncols)``: the union over lanes of the rows below
    the pivot with a nonzero in column ``k``, and of the pivot row's nonzero columns) stay
    valid for the solve. ``work = (best, pidx, inv, U, f)``: lane scratch.
    """
    rows, nrows, cols, ncols = lists
    best, pidx, inv, U, f = work
    for lane in range(K):
        ok[lane] = True
    for k in range(n):
        for lane in range(K):
            best[lane] = abs(A[k, k, lane])
            pidx[lane] = k
        for i in range(k + 1, n):
            for lane in range(K):
                v = abs(A[i, k, lane])
                g = v > best[lane]
                best[lane] = v if g else best[lane]
                pidx[lane] = i if g else pidx[lane]
        for lane in range(K):
            if not best[lane] > PIVOT_REL * amax[lane]:
                ok[lane] = False
            p = pidx[lane]
            perm[k, lane] = p
            if p != k:
                for j in range(k, n):
                    t = A[k, j, lane]
                    A[k, j, lane] = A[p, j, lane]
                    A[p, j, lane] = t
            inv[lane] = 1.0 / A[k, k, lane]
        nc = 0
        for j in range(k + 1, n):
            anz = False
            for lane in range(K):
                anz |= A[k, j, lane] != 0.0
            if anz:
                cols[k, nc] = j
                for lane in range(K):
                    U[nc, lane] = A[k, j, lane]
                nc += 1
        ncols[k] = nc
        nr = 0
        for i in range(k + 1, n):
            anz = False
            for lane in range(K):
                anz |= A[i, k, lane] != 0.0
            if not anz:
                continue
            rows[k, nr] = i
            nr += 1
            for lane in range(K):
                a = A[i, k, lane]
                fl = a * inv[lane] if a != 0.0 else a
                A[i, k, lane] = fl
                f[lane] = fl
            for q in range(nc):
                j = cols[k, q]
                for lane in range(K):
                    A[i, j, lane] -= f[lane] * U[q, lane]
        nrows[k] = nr


@jit
def soa_lu_solve(A, perm, b, n, K, lists, work):
    """Solve in place with :func:`soa_lu_factor`'s factors.

    ``b[:, l]`` receives lane ``l``'s solution: each lane's swap of step ``k`` just before
    column ``k`` (``dgesl``), then the substitutions over the union lists.
    ``work = (bk, acc)``: lane scratch.
    """
    rows, nrows, cols, ncols = lists
    bk, acc = work
    for k in range(n):
        for lane in range(K):
            p = perm[k, lane]
            t = b[k, lane]
            b[k, lane] = b[p, lane]
            b[p, lane] = t
            bk[lane] = b[k, lane]
        for q in range(nrows[k]):
            i = rows[k, q]
            for lane in range(K):
                b[i, lane] -= A[i, k, lane] * bk[lane]
    for i in range(n - 1, -1, -1):
        for lane in range(K):
            acc[lane] = b[i, lane]
        for q in range(ncols[i]):
            j = cols[i, q]
            for lane in range(K):
                acc[lane] -= A[i, j, lane] * b[j, lane]
        for lane in range(K):
            b[i, lane] = acc[lane] / A[i, i, lane]


# ---- dense scalar LU, for scale --------------------------------------------------------
@jit
def dense_lu_factor(J, A, perm, n, prow):
    """``A = J`` and its dense partial-pivoting LU (``dgefa`` form); False if singular."""
    amax = 0.0
    for i in range(n):
        for j in range(n):
            v = J[i, j]
            A[i, j] = v
            a = abs(v)
            amax = a if a > amax else amax
    if not amax > 0.0:
        return False
    for k in range(n):
        p = k
        best = abs(A[k, k])
        for i in range(k + 1, n):
            v = abs(A[i, k])
            if v > best:
                best = v
                p = i
        if not best > PIVOT_REL * amax:
            return False
        perm[k] = p
        if p != k:
            for j in range(k, n):
                t = A[k, j]
                A[k, j] = A[p, j]
                A[p, j] = t
        inv = 1.0 / A[k, k]
        for j in range(k + 1, n):
            prow[j] = A[k, j]
        for i in range(k + 1, n):
            a = A[i, k]
            if a != 0.0:
                fl = a * inv
                A[i, k] = fl
                for j in range(k + 1, n):
                    A[i, j] -= fl * prow[j]
    return True


@jit
def dense_lu_solve(A, perm, b, n):
    """Solve in place with :func:`dense_lu_factor`'s factors."""
    for k in range(n):
        p = perm[k]
        bk = b[p]
        b[p] = b[k]
        b[k] = bk
        if bk != 0.0:
            for i in range(k + 1, n):
                b[i] -= A[i, k] * bk
    for i in range(n - 1, -1, -1):
        acc = b[i]
        for j in range(i + 1, n):
            acc -= A[i, j] * b[j]
        b[i] = acc / A[i, i]


# ---- a straight-line block of the residual in lockstep ----------------------------------
@jit
def soa_quat_block(q, w, h, out, K):
    """``quat_step`` and ``quat_to_rot`` for K lanes (``q`` (4, K), ``w`` (3, K)).

    The same arithmetic in the same order: ``out[0:4]`` Q+, ``out[4:13]`` R+,
    ``out[13:22]`` Jth.
    """
    for lane in range(K):
        a, b, c, d = q[0, lane], q[1, lane], q[2, lane], q[3, lane]
        w0, w1, w2 = w[0, lane], w[1, lane], w[2, lane]
        hh = 0.5 * h
        # E(Q) rows: (-b, -c, -d), (a, d, -c), (-d, a, b), (c, -b, a)
        n0 = a + hh * -b * w0
        n0 += hh * -c * w1
        n0 += hh * -d * w2
        n1 = b + hh * a * w0
        n1 += hh * d * w1
        n1 += hh * -c * w2
        n2 = c + hh * -d * w0
        n2 += hh * a * w1
        n2 += hh * b * w2
        n3 = d + hh * c * w0
        n3 += hh * -b * w1
        n3 += hh * a * w2
        ss = 0.0
        ss += n0 * n0
        ss += n1 * n1
        ss += n2 * n2
        ss += n3 * n3
        nrm = math.sqrt(ss)
        n0 /= nrm
        n1 /= nrm
        n2 /= nrm
        n3 /= nrm
        out[0, lane] = n0
        out[1, lane] = n1
        out[2, lane] = n2
        out[3, lane] = n3
        out[4, lane] = n0 * n0 + n1 * n1 - n2 * n2 - n3 * n3
        out[5, lane] = 2.0 * (n1 * n2 - n0 * n3)
        out[6, lane] = 2.0 * (n1 * n3 + n0 * n2)
        out[7, lane] = 2.0 * (n1 * n2 + n0 * n3)
        out[8, lane] = n0 * n0 - n1 * n1 + n2 * n2 - n3 * n3
        out[9, lane] = 2.0 * (n2 * n3 - n0 * n1)
        out[10, lane] = 2.0 * (n1 * n3 - n0 * n2)
        out[11, lane] = 2.0 * (n2 * n3 + n0 * n1)
        out[12, lane] = n0 * n0 - n1 * n1 - n2 * n2 + n3 * n3
        cc = h / nrm
        # d(theta)/d(w+) = (h / |Q~|) E(Q+)^T E(Q), summed from 0.0 in k order as quat_step does
        out[13, lane] = cc * (0.0 + (-n1) * (-b) + (n0) * (a) + (-n3) * (-d) + (n2) * (c))
        out[14, lane] = cc * (0.0 + (-n1) * (-c) + (n0) * (d) + (-n3) * (a) + (n2) * (-b))
        out[15, lane] = cc * (0.0 + (-n1) * (-d) + (n0) * (-c) + (-n3) * (b) + (n2) * (a))
        out[16, lane] = cc * (0.0 + (-n2) * (-b) + (n3) * (a) + (n0) * (-d) + (-n1) * (c))
        out[17, lane] = cc * (0.0 + (-n2) * (-c) + (n3) * (d) + (n0) * (a) + (-n1) * (-b))
        out[18, lane] = cc * (0.0 + (-n2) * (-d) + (n3) * (-c) + (n0) * (b) + (-n1) * (a))
        out[19, lane] = cc * (0.0 + (-n3) * (-b) + (-n2) * (a) + (n1) * (-d) + (n0) * (c))
        out[20, lane] = cc * (0.0 + (-n3) * (-c) + (-n2) * (d) + (n1) * (a) + (n0) * (-b))
        out[21, lane] = cc * (0.0 + (-n3) * (-d) + (-n2) * (-c) + (n1) * (b) + (n0) * (a))


BLOCK_LOCALS = ("a", "b", "c", "d", "w0", "w1", "w2", "n0", "n1", "n2", "n3", "ss", "nrm", "cc")
N_BLOCK_LOCALS = len(BLOCK_LOCALS)


def _block_statements(load: Any) -> list[str]:
    """:func:`soa_quat_block`'s statements, one per line.

    Its loads of ``q`` and ``w`` are written by ``load(array_name, row)``: the forms below
    differ only in their addressing.
    """
    src = inspect.getsource(soa_quat_block.py_func)
    body = src[src.index("    for lane in range(K):") :].splitlines()[1:]
    stmts: list[str] = []
    for line in (ln.strip() for ln in body):
        if not line or line.startswith("#") or line.startswith("hh ="):
            continue
        if line.startswith("a, b, c, d"):
            stmts += [f"{v} = {load('q', i)}" for i, v in enumerate("abcd")]
        elif line.startswith("w0, w1, w2"):
            stmts += [f"w{i} = {load('w', i)}" for i in range(3)]
        else:
            stmts.append(line)
    return stmts


def _compile(lines: list[str], name: str, **consts: Any) -> Any:
    """Compile the generated function ``name`` (:func:`jit`) with ``consts`` as globals."""
    ns: dict[str, Any] = {"math": math, **consts}
    exec("\n".join(lines), ns)  # noqa: S102 - our own source, transformed
    return jit(ns[name])


def per_statement_block() -> Any:
    """:func:`soa_quat_block` with every statement in its own lane loop.

    Every local is a row of the scratch ``t`` (N_BLOCK_LOCALS, K): ``f(q, w, h, out, t, K)``.
    """
    pat = re.compile(r"\b(" + "|".join(BLOCK_LOCALS) + r")\b(?!\s*\[)")
    lines = ["def per_statement(q, w, h, out, t, K):", "    hh = 0.5 * h"]
    for st in _block_statements(lambda a, i: f"{a}[{i}, lane]"):
        lines += ["    for lane in range(K):", "        " + pat.sub(lambda m: f"t[{BLOCK_LOCALS.index(m.group(1))}, lane]", st)]
    return _compile(lines, "per_statement")


PER_STATEMENT = per_statement_block()


def flat_block(K: int) -> Any:
    """:func:`soa_quat_block` on one flat array with ``K`` a compile-time constant.

    ``s[r * K + lane]``: rows 0-3 ``q``, 4-6 ``w``, 7-28 the output. Every address is the
    same base plus a constant, so LLVM can prove that the rows do not overlap and
    vectorises the lane loop (zmm ``vmulpd`` on this machine). Returns ``f(s, h)``.
    """
    lines = ["def flat(s, h):", "    hh = 0.5 * h", "    for lane in range(KK):"]
    for st in _block_statements(lambda a, i: f"s[{i if a == 'q' else 4 + i} * KK + lane]"):
        lines.append("        " + re.sub(r"out\[(\d+), lane\]", lambda m: f"s[{7 + int(m.group(1))} * KK + lane]", st))
    f = _compile(lines, "flat", KK=K)

    @nb.njit(nogil=True)
    def rep(S, h, reps):
        for _ in range(reps):
            for m in range(S.shape[0]):
                f(S[m], h)

    return rep


@nb.njit(nogil=True)
def block_soa_all(q, w, h, out, reps):
    """:func:`soa_quat_block` over groups ``q[m]`` (4, K), ``w[m]`` (3, K)."""
    M, _, K = q.shape
    for _ in range(reps):
        for m in range(M):
            soa_quat_block(q[m], w[m], h, out[m], K)


@nb.njit(nogil=True)
def block_stmt_all(q, w, h, out, reps):
    """:data:`PER_STATEMENT` over the same groups."""
    M, _, K = q.shape
    t = np.zeros((N_BLOCK_LOCALS, K))
    for _ in range(reps):
        for m in range(M):
            PER_STATEMENT(q[m], w[m], h, out[m], t, K)


@nb.njit(nogil=True)
def block_scalar_all(q, w, h, out, reps):
    """The scalar kernels lane by lane: ``q`` (M, K, 4), ``w`` (M, K, 3), ``out`` (M, K, 22)."""
    M, K, _ = q.shape
    o = np.zeros(N_QS)
    for _ in range(reps):
        for m in range(M):
            for lane in range(K):
                quat_step(q[m, lane], 0, w[m, lane], 0, h, o, 0)
                r = out[m, lane]
                for i in range(4):
                    r[i] = o[QS_Q + i]
                quat_to_rot(o, QS_Q, r, 4)
                for i in range(9):
                    r[13 + i] = o[QS_JTH + i]


def median_ns(paths: Any, rounds: int, reps: int, per: float) -> dict[str, float]:
    """Median time of each ``(name, fn, args)`` path, times ``per`` (ns per unit of work).

    Each round calls ``fn(*args, reps)`` once per path, the paths interleaved.
    """
    t: dict[str, list[float]] = {name: [] for name, _, _ in paths}
    for _ in range(rounds):
        for name, fn, args in paths:
            t0 = time.perf_counter()
            fn(*args, reps)
            t[name].append(time.perf_counter() - t0)
    return {k: float(np.median(v)) * per for k, v in t.items()}


def compare_block(K: int, M: int = 4096, reps: int = 20, rounds: int = 7, seed: int = 2) -> dict[str, Any]:
    """Bit-for-bit check and median ns per lane of the residual's orientation block, lockstep and scalar."""
    rng = np.random.default_rng(seed)
    q = rng.standard_normal((M, K, 4))
    q /= np.linalg.norm(q, axis=2, keepdims=True)
    w = rng.standard_normal((M, K, 3)) * 50.0
    h = 5e-5
    qv = np.ascontiguousarray(q.transpose(0, 2, 1))
    wv = np.ascontiguousarray(w.transpose(0, 2, 1))
    outs, outv, outp = np.zeros((M, K, 22)), np.zeros((M, 22, K)), np.zeros((M, 22, K))
    S3 = np.zeros((M, 29, K))
    S3[:, 0:4] = qv
    S3[:, 4:7] = wv
    S = S3.reshape(M, 29 * K)
    flat = flat_block(K)
    block_scalar_all(q, w, h, outs, 1)
    block_soa_all(qv, wv, h, outv, 1)
    block_stmt_all(qv, wv, h, outp, 1)
    flat(S, h, 1)
    outf = S.reshape(M, 29, K)[:, 7:]
    same = all(np.array_equal(outs, o.transpose(0, 2, 1)) for o in (outv, outp, outf))
    paths = (
        ("scalar", block_scalar_all, (q, w, h, outs)),
        ("lockstep", block_soa_all, (qv, wv, h, outv)),
        ("per_statement", block_stmt_all, (qv, wv, h, outp)),
        ("flat", flat, (S, h)),
    )
    return {"K": K, "bit": same, **median_ns(paths, rounds, reps, 1e9 / (reps * M * K))}


# ---- the paths over every group ----------------------------------------------------
@nb.njit(nogil=True)
def scalar_all(Jl, bs, X, okv, reps):
    """Today's path, matrix by matrix: ``Jl[m, l]`` (n, n), solutions into ``X[m, l]``."""
    M, K, n, _ = Jl.shape
    A = np.zeros((n, n))
    order = np.zeros(n, np.int64)
    unz = np.zeros((n, n), np.int64)
    ucnt = np.zeros(n, np.int64)
    lnz = np.zeros((n, n), np.int64)
    lcnt = np.zeros(n, np.int64)
    y = np.zeros(n)
    for _ in range(reps):
        for m in range(M):
            for lane in range(K):
                J = Jl[m, lane]
                b = X[m, lane]
                for i in range(n):
                    b[i] = bs[m, lane, i]
                amax = copy_amax(J, A, n)
                ok = lu_factor(A, order, n, unz, ucnt, lnz, lcnt, amax, J, False)
                okv[m, lane] = ok
                if ok:
                    lu_solve(A, order, b, n, unz, ucnt, lnz, lcnt, y)


@nb.njit(nogil=True)
def dense_all(Jl, bs, X, okv, reps):
    """The dense scalar LU, matrix by matrix (same layout as :func:`scalar_all`)."""
    M, K, n, _ = Jl.shape
    A = np.zeros((n, n))
    perm = np.zeros(n, np.int64)
    prow = np.zeros(n)
    for _ in range(reps):
        for m in range(M):
            for lane in range(K):
                b = X[m, lane]
                for i in range(n):
                    b[i] = bs[m, lane, i]
                ok = dense_lu_factor(Jl[m, lane], A, perm, n, prow)
                okv[m, lane] = ok
                if ok:
                    dense_lu_solve(A, perm, b, n)


@nb.njit(nogil=True)
def soa_all(Js, bsv, X, okv, reps):
    """Lockstep: group ``m`` is ``Js[m]`` (n, n, K), solutions into ``X[m]`` (n, K)."""
    M, n, _, K = Js.shape
    A = np.zeros((n, n, K))
    amax = np.zeros(K)
    perm = np.zeros((n, K), np.int64)
    ok = np.zeros(K, np.bool_)
    lists = (np.zeros((n, n), np.int64), np.zeros(n, np.int64), np.zeros((n, n), np.int64), np.zeros(n, np.int64))
    fwork = (np.zeros(K), np.zeros(K, np.int64), np.zeros(K), np.zeros((n, K)), np.zeros(K))
    swork = (np.zeros(K), np.zeros(K))
    for _ in range(reps):
        for m in range(M):
            b = X[m]
            for i in range(n):
                for lane in range(K):
                    b[i, lane] = bsv[m, i, lane]
            soa_copy_amax(Js[m], A, amax, n, K)
            soa_lu_factor(A, perm, amax, ok, n, K, lists, fwork)
            soa_lu_solve(A, perm, b, n, K, lists, swork)
            for lane in range(K):
                okv[m, lane] = ok[lane]


def flat_lu(n: int, K: int) -> Any:  # noqa: C901
    """The lockstep LU on one flat array per group, ``A[(i * n + j) * K + lane]``.

    ``n`` and ``K`` are compile-time constants (the layout that lets LLVM vectorise
    :func:`flat_block`); the same algorithm and arithmetic as :func:`soa_lu_factor` and
    :func:`soa_lu_solve`, lane scratch in one flat array. Returns ``run_all(Jf, bf, X, okv,
    reps)`` over groups ``Jf[m]`` (n n K) and right-hand sides ``bf[m]`` (n K).
    """
    NN = n * n * K
    flat_copy_amax = flat_copier(n * n, K)

    @jit
    def flat_factor(A, w, perm, lists):  # noqa: C901
        # w: [0:K] amax, [K:2K] best, [2K:3K] pidx (float), [3K:4K] inv, [4K:5K] ok, [5K:6K] f, [6K:6K+nK] U
        rows, nrows, cols, ncols = lists
        for lane in range(K):
            w[4 * K + lane] = 1.0
        for k in range(n):
            for lane in range(K):
                w[K + lane] = abs(A[(k * n + k) * K + lane])
                w[2 * K + lane] = k
            for i in range(k + 1, n):
                for lane in range(K):
                    v = abs(A[(i * n + k) * K + lane])
                    g = v > w[K + lane]
                    w[K + lane] = v if g else w[K + lane]
                    w[2 * K + lane] = i if g else w[2 * K + lane]
            for lane in range(K):
                if not w[K + lane] > PIVOT_REL * w[lane]:
                    w[4 * K + lane] = 0.0
                p = int(w[2 * K + lane])
                perm[k * K + lane] = p
                if p != k:
                    for j in range(k, n):
                        t = A[(k * n + j) * K + lane]
                        A[(k * n + j) * K + lane] = A[(p * n + j) * K + lane]
                        A[(p * n + j) * K + lane] = t
            for lane in range(K):
                w[3 * K + lane] = 1.0 / A[(k * n + k) * K + lane]
            nc = 0
            for j in range(k + 1, n):
                anz = False
                for lane in range(K):
                    anz |= A[(k * n + j) * K + lane] != 0.0
                if anz:
                    cols[k * n + nc] = j
                    nc += 1
            ncols[k] = nc
            nr = 0
            for i in range(k + 1, n):
                anz = False
                for lane in range(K):
                    anz |= A[(i * n + k) * K + lane] != 0.0
                if not anz:
                    continue
                rows[k * n + nr] = i
                nr += 1
                for lane in range(K):
                    a = A[(i * n + k) * K + lane]
                    A[(i * n + k) * K + lane] = a * w[3 * K + lane] if a != 0.0 else a
                for q in range(nc):
                    j = cols[k * n + q]
                    for lane in range(K):
                        A[(i * n + j) * K + lane] -= A[(i * n + k) * K + lane] * A[(k * n + j) * K + lane]
            nrows[k] = nr

    @jit
    def flat_solve(A, perm, b, lists):
        rows, nrows, cols, ncols = lists
        for k in range(n):
            for lane in range(K):
                p = perm[k * K + lane]
                t = b[k * K + lane]
                b[k * K + lane] = b[p * K + lane]
                b[p * K + lane] = t
            for q in range(nrows[k]):
                i = rows[k * n + q]
                for lane in range(K):
                    b[i * K + lane] -= A[(i * n + k) * K + lane] * b[k * K + lane]
        for i in range(n - 1, -1, -1):
            for q in range(ncols[i]):
                j = cols[i * n + q]
                for lane in range(K):
                    b[i * K + lane] -= A[(i * n + j) * K + lane] * b[j * K + lane]
            for lane in range(K):
                b[i * K + lane] = b[i * K + lane] / A[(i * n + i) * K + lane]

    @nb.njit(nogil=True)
    def run_all(Jf, bsv, X, okv, reps):
        M = Jf.shape[0]
        A = np.zeros(NN)
        w = np.zeros(6 * K + n * K)
        perm = np.zeros(n * K, np.int64)
        lists = (np.zeros(n * n, np.int64), np.zeros(n, np.int64), np.zeros(n * n, np.int64), np.zeros(n, np.int64))
        for _ in range(reps):
            for m in range(M):
                b = X[m]
                for i in range(n * K):
                    b[i] = bsv[m, i]
                flat_copy_amax(Jf[m], A, w)
                flat_factor(A, w, perm, lists)
                flat_solve(A, perm, b, lists)
                for lane in range(K):
                    okv[m, lane] = w[4 * K + lane] > 0.5

    return run_all


def flat_copier(nn: int, K: int) -> Any:
    """A compiled ``copy(J, A, amax)`` for the flat forms, ``nn`` and ``K`` compile-time constants.

    ``A = J`` (``nn`` entries of K lanes, ``[idx * K + lane]``); ``amax[l]`` the largest
    ``|J|`` of lane ``l``.
    """

    @jit
    def copy(J, A, amax):
        for lane in range(K):
            amax[lane] = 0.0
        for idx in range(nn):
            for lane in range(K):
                v = J[idx * K + lane]
                A[idx * K + lane] = v
                a = abs(v)
                amax[lane] = a if a > amax[lane] else amax[lane]

    return copy


def _inplace_harness(n: int, K: int, factor: Any, solve: Any, masks: bool) -> Any:
    """``run_all(Jf, bf, X, okv, reps)`` (as :func:`flat_lu`) around a rows-in-place LU.

    ``factor(A, U, L, w, pos, row, lists, rm, cm)`` and ``solve(U, L, b, y, row, lists)``
    (:func:`inplace_lu`, :func:`unrolled_lu`); ``w[0:K]`` each lane's largest ``|J|``,
    ``w[4K:5K]`` its ok flag. With ``masks`` the pattern's bit masks ``rm``, ``cm`` are
    set from each copy.
    """
    NN = n * n * K
    flat_copy_amax = flat_copier(n * n, K)

    @nb.njit(nogil=True)
    def run_all(Jf, bsv, X, okv, reps):
        M = Jf.shape[0]
        A = np.zeros(NN)
        U = np.zeros(NN)
        L = np.zeros(NN)
        w = np.zeros(6 * K)
        y = np.zeros((n + 1) * K)
        pos = np.zeros(n * K, np.int64)
        row = np.zeros(n * K, np.int64)
        rm = np.zeros(n, np.int64)
        cm = np.zeros(n, np.int64)
        lists = (np.zeros(n * n, np.int64), np.zeros(n, np.int64), np.zeros(n * n, np.int64), np.zeros(n, np.int64))
        for _ in range(reps):
            for m in range(M):
                b = X[m]
                for i in range(n * K):
                    b[i] = bsv[m, i]
                flat_copy_amax(Jf[m], A, w)
                if masks:
                    for i in range(n):
                        rm[i] = 0
                        cm[i] = 0
                    for i in range(n):
                        for j in range(n):
                            anz = False
                            for lane in range(K):
                                anz |= A[(i * n + j) * K + lane] != 0.0
                            if anz:
                                rm[i] |= np.int64(1) << j
                                cm[j] |= np.int64(1) << i
                factor(A, U, L, w, pos, row, lists, rm, cm)
                solve(U, L, b, y, row, lists)
                for lane in range(K):
                    okv[m, lane] = w[4 * K + lane] > 0.5

    return run_all


def inplace_lu(n: int, K: int, masks: bool = False) -> Any:  # noqa: C901
    """The lockstep LU with every lane's rows left in place, as ``newton.lu_factor`` leaves them.

    :func:`flat_lu` swaps rows lane by lane (scalar moves, half its factorisation). Here
    each lane keeps ``lu_factor``'s bookkeeping instead: ``pos[r, l]``, the position of
    row ``r``, and ``row[k, l]``, the row at position ``k``. The pivot search runs over
    all rows at once, lane-parallel: a row still unpivoted beats the best so far if its
    magnitude is larger, or equal at a smaller position (``lu_factor``'s first largest in
    position order, ties included). The pivot rows (``U``, stored by position) and the
    multipliers (``L``, by step, 0 where a lane has none) are kept apart from ``A``, so
    the elimination and both substitutions read them without a gather; an update is taken
    only where the lane's multiplier and pivot-row entry are both nonzero (a select, so an
    entry a lane would not touch keeps its bits, signed zeros included). Returns
    ``run_all(Jf, bf, X, okv, reps)`` as :func:`flat_lu`.

    With ``masks`` (``n`` at most 63), the union pattern is kept as bit masks, one per row
    (its columns) and one per column (its rows), set from the copy and grown by the fill:
    the pivot search and the multipliers visit only the rows of column ``k``'s mask, and
    the pivot rows are copied only on the columns of their masks (what the scalar LU's
    lists do, for all lanes at once).
    """
    if masks and n > 63:
        raise ValueError(f"inplace_lu(masks=True) holds a row's pattern in an int64: n={n} must be at most 63")

    @jit
    def factor(A, U, L, w, pos, row, lists, rm, cm):  # noqa: C901
        # w: [0:K] amax, [K:2K] best, [2K:3K] best position, [3K:4K] inv, [4K:5K] ok, [5K:6K] pivot row;
        # with masks, rm[r]: the columns that may be nonzero in row r (any lane), cm[j]: the rows of column j
        rows, nrows, cols, ncols = lists
        for lane in range(K):
            w[4 * K + lane] = 1.0
        for r in range(n):
            for lane in range(K):
                pos[r * K + lane] = r
                row[r * K + lane] = r
        for k in range(n):
            for lane in range(K):
                # lu_factor starts from the row at position k (a NaN there fails the lane, as there)
                rk0 = row[k * K + lane]
                w[K + lane] = abs(A[(rk0 * n + k) * K + lane])
                w[2 * K + lane] = k
                w[5 * K + lane] = rk0
            ck = cm[k] if masks else np.int64(-1)
            for r in range(n):
                if not (ck >> r) & 1:
                    continue
                for lane in range(K):
                    v = abs(A[(r * n + k) * K + lane])
                    ps = pos[r * K + lane]
                    bb = w[K + lane]
                    g = (ps > k) & ((v > bb) | ((v == bb) & (ps < w[2 * K + lane])))
                    w[K + lane] = v if g else bb
                    w[2 * K + lane] = ps if g else w[2 * K + lane]
                    w[5 * K + lane] = r if g else w[5 * K + lane]
            cmask = np.int64(0)
            for lane in range(K):
                if not w[K + lane] > PIVOT_REL * w[lane]:
                    w[4 * K + lane] = 0.0
                rk = int(w[5 * K + lane])
                p = int(w[2 * K + lane])
                r0 = row[k * K + lane]
                row[p * K + lane] = r0
                pos[r0 * K + lane] = p
                row[k * K + lane] = rk
                pos[rk * K + lane] = k
                w[3 * K + lane] = 1.0 / A[(rk * n + k) * K + lane]
                if masks:
                    cmask |= rm[rk]
                else:
                    for j in range(k, n):
                        U[(k * n + j) * K + lane] = A[(rk * n + j) * K + lane]
            nc = 0
            for j in range(k + 1, n):
                if masks:
                    anz = (cmask >> j) & 1 == 1
                else:
                    anz = False
                    for lane in range(K):
                        anz |= U[(k * n + j) * K + lane] != 0.0
                if anz:
                    cols[k * n + nc] = j
                    nc += 1
            ncols[k] = nc
            if masks:
                for lane in range(K):
                    rk = int(w[5 * K + lane])
                    U[(k * n + k) * K + lane] = A[(rk * n + k) * K + lane]
                    for q in range(nc):
                        j = cols[k * n + q]
                        U[(k * n + j) * K + lane] = A[(rk * n + j) * K + lane]
            nr = 0
            for r in range(n):
                if not (ck >> r) & 1:
                    continue
                anz = False
                for lane in range(K):
                    a = A[(r * n + k) * K + lane]
                    live = (pos[r * K + lane] > k) & (a != 0.0)
                    f = a * w[3 * K + lane] if live else 0.0
                    L[(k * n + r) * K + lane] = f
                    anz |= live
                if not anz:
                    continue
                rows[k * n + nr] = r
                nr += 1
                if masks:
                    rm[r] |= cmask
                for q in range(nc):
                    j = cols[k * n + q]
                    if masks:
                        cm[j] |= np.int64(1) << r
                    for lane in range(K):
                        f = L[(k * n + r) * K + lane]
                        u = U[(k * n + j) * K + lane]
                        x = A[(r * n + j) * K + lane]
                        A[(r * n + j) * K + lane] = x - f * u if (f != 0.0) & (u != 0.0) else x
            nrows[k] = nr

    @jit
    def solve(U, L, b, y, row, lists):
        rows, nrows, cols, ncols = lists
        for k in range(n):
            for lane in range(K):
                y[k * K + lane] = b[row[k * K + lane] * K + lane]
            for q in range(nrows[k]):
                r = rows[k * n + q]
                for lane in range(K):
                    f = L[(k * n + r) * K + lane]
                    bk = y[k * K + lane]
                    x = b[r * K + lane]
                    b[r * K + lane] = x - f * bk if (f != 0.0) & (bk != 0.0) else x
        for i in range(n - 1, -1, -1):
            for lane in range(K):
                y[n * K + lane] = y[i * K + lane]
            for q in range(ncols[i]):
                j = cols[i * n + q]
                for lane in range(K):
                    u = U[(i * n + j) * K + lane]
                    y[n * K + lane] = y[n * K + lane] - u * b[j * K + lane] if u != 0.0 else y[n * K + lane]
            for lane in range(K):
                b[i * K + lane] = y[n * K + lane] / U[(i * n + i) * K + lane]

    return _inplace_harness(n, K, factor, solve, masks)


def _lanes(K: int, indent: int, *stmts: str) -> list[str]:
    """Each statement written once per lane (``{l}`` the lane), statement by statement.

    Every lane's loads come before any lane's stores, so that LLVM's SLP vectoriser could
    pack the K copies without proving that the arrays do not overlap.
    """
    pad = " " * indent
    return [pad + st.format(l=lane) for st in stmts for lane in range(K)]


def unrolled_lu(n: int, K: int) -> Any:
    """:func:`inplace_lu` with the lane loops written out and the lane state in locals.

    The same algorithm and arithmetic; generated source (``_lanes``), ``n`` and ``K``
    compile-time constants. Returns ``run_all`` as :func:`flat_lu`.
    """
    L_ = _lanes
    f = ["def factor(A, U, L, w, pos, row, lists, rm, cm):", "    rows, nrows, cols, ncols = lists"]
    f += L_(K, 4, "ok{l} = True")
    f += ["    for r in range(NN_):"]
    f += L_(K, 8, "pos[r * KK + {l}] = r", "row[r * KK + {l}] = r")
    f += ["    for k in range(NN_):"]
    f += L_(K, 8, "br{l} = row[k * KK + {l}]", "b{l} = abs(A[(br{l} * NN_ + k) * KK + {l}])", "bp{l} = k")
    f += ["        for r in range(NN_):", "            base = (r * NN_ + k) * KK"]
    f += L_(
        K,
        12,
        "v{l} = abs(A[base + {l}])",
        "ps{l} = pos[r * KK + {l}]",
        "g{l} = (ps{l} > k) & ((v{l} > b{l}) | ((v{l} == b{l}) & (ps{l} < bp{l})))",
        "b{l} = v{l} if g{l} else b{l}",
        "bp{l} = ps{l} if g{l} else bp{l}",
        "br{l} = r if g{l} else br{l}",
    )
    for lane in range(K):
        f += [
            f"        ok{lane} = ok{lane} & (b{lane} > PIVOT_REL * w[{lane}])",
            f"        r0 = row[k * KK + {lane}]",
            f"        row[bp{lane} * KK + {lane}] = r0",
            f"        pos[r0 * KK + {lane}] = bp{lane}",
            f"        row[k * KK + {lane}] = br{lane}",
            f"        pos[br{lane} * KK + {lane}] = k",
            f"        inv{lane} = 1.0 / A[(br{lane} * NN_ + k) * KK + {lane}]",
            "        for j in range(k, NN_):",
            f"            U[(k * NN_ + j) * KK + {lane}] = A[(br{lane} * NN_ + j) * KK + {lane}]",
        ]
    f += ["        nc = 0", "        for j in range(k + 1, NN_):", "            base = (k * NN_ + j) * KK"]
    f += ["            anz = " + " | ".join(f"(U[base + {lane}] != 0.0)" for lane in range(K))]
    f += ["            if anz:", "                cols[k * NN_ + nc] = j", "                nc += 1"]
    f += ["        ncols[k] = nc", "        nr = 0"]
    f += ["        for r in range(NN_):", "            base = (r * NN_ + k) * KK", "            lb = (k * NN_ + r) * KK"]
    f += L_(
        K,
        12,
        "a{l} = A[base + {l}]",
        "live{l} = (pos[r * KK + {l}] > k) & (a{l} != 0.0)",
        "f{l} = a{l} * inv{l} if live{l} else 0.0",
        "L[lb + {l}] = f{l}",
    )
    f += ["            if not (" + " | ".join(f"live{lane}" for lane in range(K)) + "):", "                continue"]
    f += ["            rows[k * NN_ + nr] = r", "            nr += 1"]
    f += ["            for q in range(nc):", "                j = cols[k * NN_ + q]"]
    f += ["                xb = (r * NN_ + j) * KK", "                ub = (k * NN_ + j) * KK"]
    f += L_(K, 16, "x{l} = A[xb + {l}]", "u{l} = U[ub + {l}]", "y{l} = x{l} - f{l} * u{l} if (f{l} != 0.0) & (u{l} != 0.0) else x{l}")
    f += L_(K, 16, "A[xb + {l}] = y{l}")
    f += ["        nrows[k] = nr"]
    f += L_(K, 4, "w[4 * KK + {l}] = 1.0 if ok{l} else 0.0")

    s = ["def solve(U, L, b, y, row, lists):", "    rows, nrows, cols, ncols = lists", "    for k in range(NN_):"]
    s += L_(K, 8, "bk{l} = b[row[k * KK + {l}] * KK + {l}]", "y[k * KK + {l}] = bk{l}")
    s += ["        for q in range(nrows[k]):", "            r = rows[k * NN_ + q]", "            lb = (k * NN_ + r) * KK"]
    s += L_(K, 12, "f{l} = L[lb + {l}]", "x{l} = b[r * KK + {l}]", "z{l} = x{l} - f{l} * bk{l} if (f{l} != 0.0) & (bk{l} != 0.0) else x{l}")
    s += L_(K, 12, "b[r * KK + {l}] = z{l}")
    s += ["    for i in range(NN_ - 1, -1, -1):"]
    s += L_(K, 8, "c{l} = y[i * KK + {l}]")
    s += ["        for q in range(ncols[i]):", "            j = cols[i * NN_ + q]", "            ub = (i * NN_ + j) * KK"]
    s += L_(K, 12, "u{l} = U[ub + {l}]", "c{l} = c{l} - u{l} * b[j * KK + {l}] if u{l} != 0.0 else c{l}")
    s += ["        db = (i * NN_ + i) * KK"]
    s += L_(K, 8, "b[i * KK + {l}] = c{l} / U[db + {l}]")
    factor = _compile(f, "factor", NN_=n, KK=K, PIVOT_REL=PIVOT_REL)
    solve = _compile(s, "solve", NN_=n, KK=K)
    return _inplace_harness(n, K, factor, solve, False)


def bitwise_equal(a: np.ndarray, b: np.ndarray) -> bool:
    """Equal bit patterns (signed zeros and NaN payloads told apart)."""
    return bool(np.array_equal(np.ascontiguousarray(a).view(np.int64), np.ascontiguousarray(b).view(np.int64)))


def groups(runs: list[list[np.ndarray]], K: int, seed: int = 1, zeros: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Lockstep groups of K lanes from the captured runs: ``(M, n, n, K)`` matrices and ``(M, n, K)`` right-hand sides.

    With ``zeros``, a fifth of the right-hand sides' entries are +0.0 and a fifth -0.0
    (the tests' signed zeros).
    """
    R = len(runs)
    lanes = [runs[lane % R][(lane // R) * LANE_SHIFT :] for lane in range(K)]
    M = min(len(r) for r in lanes)
    n = lanes[0][0].shape[0]
    Js = np.zeros((M, n, n, K))
    for lane, r in enumerate(lanes):
        for m in range(M):
            Js[m, :, :, lane] = r[m]
    rng = np.random.default_rng(seed)
    bs = rng.standard_normal((M, n, K))
    if zeros:
        u = rng.random((M, n, K))
        bs[u < 0.2] = 0.0
        bs[u > 0.8] = -0.0
    return Js, bs


def compare(runs: list[list[np.ndarray]], K: int, reps: int, rounds: int, zeros: bool = False) -> dict[str, Any]:
    """Bit-for-bit check and median times (ns per matrix) of every path on K-lane groups (``zeros``: :func:`groups`)."""
    Js, bsv = groups(runs, K, zeros=zeros)
    M, n = Js.shape[0], Js.shape[1]
    Jl = np.ascontiguousarray(Js.transpose(0, 3, 1, 2))
    bs = np.ascontiguousarray(bsv.transpose(0, 2, 1))
    Xs, Xd, Xv = np.zeros((M, K, n)), np.zeros((M, K, n)), np.zeros((M, n, K))
    oks, okd, okv = (np.zeros((M, K), np.bool_) for _ in range(3))
    Jf = np.ascontiguousarray(Js.reshape(M, n * n * K))
    bf = np.ascontiguousarray(bsv.reshape(M, n * K))
    Xf = np.zeros((M, n * K))
    okf = np.zeros((M, K), np.bool_)
    flat = flat_lu(n, K)
    inplace = inplace_lu(n, K)
    unrolled = unrolled_lu(n, K)
    masked = inplace_lu(n, K, masks=True)
    Xi, Xu, Xm = np.zeros((M, n * K)), np.zeros((M, n * K)), np.zeros((M, n * K))
    oki, oku, okm = (np.zeros((M, K), np.bool_) for _ in range(3))
    scalar_all(Jl, bs, Xs, oks, 1)
    inplace(Jf, bf, Xi, oki, 1)
    unrolled(Jf, bf, Xu, oku, 1)
    masked(Jf, bf, Xm, okm, 1)
    dense_all(Jl, bs, Xd, okd, 1)
    soa_all(Js, bsv, Xv, okv, 1)
    flat(Jf, bf, Xf, okf, 1)
    Xf3 = Xf.reshape(M, n, K)
    Xi3 = Xi.reshape(M, n, K)
    both = oks & okv
    same = [
        bitwise_equal(Xs[m, lane], Xv[m, :, lane]) and bitwise_equal(Xs[m, lane], Xf3[m, :, lane])
        for m in range(M)
        for lane in range(K)
        if both[m, lane]
    ]
    Xu3 = Xu.reshape(M, n, K)
    Xm3 = Xm.reshape(M, n, K)
    same_i = [
        bitwise_equal(Xs[m, lane], Xi3[m, :, lane])
        and bitwise_equal(Xs[m, lane], Xu3[m, :, lane])
        and bitwise_equal(Xs[m, lane], Xm3[m, :, lane])
        for m in range(M)
        for lane in range(K)
        if oks[m, lane] and oki[m, lane]
    ]
    both_d = [(m, lane) for m in range(M) for lane in range(K) if oks[m, lane] and okd[m, lane]]
    same_d = [bitwise_equal(Xs[m, lane], Xd[m, lane]) for m, lane in both_d]
    # the dense LU also updates the zeros of the pivot row (x - f * 0 turns -0.0 into +0.0)
    value_d = [np.array_equal(Xs[m, lane], Xd[m, lane], equal_nan=True) for m, lane in both_d]
    paths = (
        ("scalar", scalar_all, (Jl, bs, Xs, oks)),
        ("dense", dense_all, (Jl, bs, Xd, okd)),
        ("lockstep", soa_all, (Js, bsv, Xv, okv)),
        ("flat", flat, (Jf, bf, Xf, okf)),
        ("inplace", inplace, (Jf, bf, Xi, oki)),
        ("unrolled", unrolled, (Jf, bf, Xu, oku)),
        ("masked", masked, (Jf, bf, Xm, okm)),
    )
    ns = median_ns(paths, rounds, reps, 1e9 / (reps * M * K))
    return {
        "K": K,
        "groups": M,
        "ok_equal": bool(all((oks == o).all() for o in (okv, okd, okf, oki, oku, okm))),
        "bit_inplace": float(np.mean(same_i)) if same_i else float("nan"),
        "bit_lockstep": float(np.mean(same)) if same else float("nan"),
        "bit_dense": float(np.mean(same_d)) if same_d else float("nan"),
        "value_dense": float(np.mean(value_d)) if value_d else float("nan"),
        **ns,
    }


def capture_runs(kw: dict[str, Any], runs: int, seconds: float, tmp: Path) -> list[list[np.ndarray]]:
    """Newton matrices of ``runs`` runs of one scenario (friction and offset drawn per run, seed 5)."""
    cap = _patterns().capture
    rng = np.random.default_rng(5)
    lo, hi = MU[str(kw["preset"])]
    out = []
    for r in range(runs):
        one = {**kw, "duration_s": seconds, "mu": float(rng.uniform(lo, hi)), "offset_deg": float(rng.uniform(-10.0, 10.0))}
        out.append([v for v, _, _ in cap(one, tmp / f"{r}.pkl")])
    n = max(v.shape[0] for r in out for v in r)
    return [[v for v in r if v.shape[0] == n] for r in out]


def main(argv: list[str] | None = None) -> str:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=0.1, help="simulated time per run (default 0.1)")
    ap.add_argument("--runs", type=int, default=8, help="runs per scenario (default 8)")
    ap.add_argument("--lanes", default="1,8,16,32", help="lockstep widths K (default 1,8,16,32)")
    ap.add_argument("--reps", type=int, default=3, help="passes over every group per round (default 3)")
    ap.add_argument("--rounds", type=int, default=7, help="timed rounds; medians reported (default 7)")
    ap.add_argument("--block", action="store_true", help="also the residual's orientation block in lockstep")
    args = ap.parse_args(argv)
    lanes = [int(k) for k in args.lanes.split(",")]
    if args.block:
        blines = [
            "",
            "The residual's orientation block (`--block`; ns per lane):",
            "",
            "| K | bit-identical (all forms) | scalar kernels | lockstep, lane loop outside "
            "| per-statement lane loops | flat, K constant | scalar / flat |",
            "|---|---|---|---|---|---|---|",
        ]
        for K in lanes:
            b = compare_block(K, rounds=args.rounds)
            blines.append(
                f"| {K} | {b['bit']} | {b['scalar']:.1f} | {b['lockstep']:.1f} | {b['per_statement']:.1f} "
                f"| {b['flat']:.1f} | {b['scalar'] / b['flat']:.2f}x |"
            )
    lines = [
        f"`python experiments/lockstep_lu.py --seconds {args.seconds:g} --runs {args.runs} --lanes {args.lanes}` "
        f"(medians of {args.rounds} rounds; ns per matrix: copy, factor and solve):",
        "",
        "| scenario | K | groups | ok flags equal | lockstep bit-identical | dense bit-identical "
        "| scalar sparse (today) | dense scalar | lockstep | flat lockstep, n and K constant "
        "| rows in place: bit-identical | rows in place | rows in place, lanes unrolled "
        "| rows in place, pattern masks | today / best lockstep |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    with tempfile.TemporaryDirectory() as tmp:
        for name, kw in SCENARIOS.items():
            print(f"capturing {name} ...", file=sys.stderr, flush=True)
            runs = capture_runs(kw, args.runs, args.seconds, Path(tmp))
            for K in lanes:
                c = compare(runs, K, args.reps, args.rounds)
                lines.append(
                    f"| {name} | {K} | {c['groups']:,} | {c['ok_equal']} | {c['bit_lockstep']:.4f} | {c['bit_dense']:.4f} "
                    f"| {c['scalar']:.0f} | {c['dense']:.0f} | {c['lockstep']:.0f} | {c['flat']:.0f} "
                    f"| {c['bit_inplace']:.4f} | {c['inplace']:.0f} | {c['unrolled']:.0f} | {c['masked']:.0f} "
                    f"| {c['scalar'] / min(c['lockstep'], c['flat'], c['inplace'], c['unrolled'], c['masked']):.2f}x |"
                )
    text = "\n".join(lines + (blines if args.block else []))
    print(text)
    return text


if __name__ == "__main__":
    main()
