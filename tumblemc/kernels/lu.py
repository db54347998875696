"""Sparse LU of the Newton matrix with partial pivoting and row tests.

:func:`lu_factor` factors the Newton matrix in place, recording its nonzero pattern so that
:func:`lu_solve` substitutes over the nonzeros only; :func:`copy_amax` copies the matrix and
its largest magnitude. Used by :mod:`.newton` (the Newton and chord iterations).
"""

from __future__ import annotations

import numpy as np

from ._jit import jit

#: ``lu_factor``: a pivot below this fraction of the matrix's largest magnitude (or, with
#: its row test, of its own row's) counts as singular
PIVOT_REL = 1e-13


ABS_BITS = 0x7FFFFFFFFFFFFFFF  # a float64's bits without the sign
INF_BITS = 0x7FF0000000000000  # +inf; larger patterns (sign cleared) are NaN


@jit
def copy_amax(J, A, n):  # type: ignore[no-untyped-def]
    """``A[:n, :n] = J[:n, :n]``; returns ``max |J[:n, :n]|`` for :func:`lu_factor`.

    The copy moves bit patterns, and the maximum is taken over the patterns with the sign
    bit cleared (ordered like the magnitudes for non-NaN floats), which costs about half
    of a separate scan of the copy. With a NaN among the entries it returns -1, and
    ``lu_factor`` scans itself (that scan skips NaN).
    """
    Jb = J.view(np.int64)
    Ab = A.view(np.int64)
    m = 0
    im = 0
    jm = 0
    for i in range(n):
        for j in range(n):
            b = Jb[i, j]
            Ab[i, j] = b
            v = b & ABS_BITS
            if v > m:
                m = v
                im = i
                jm = j
    if m > INF_BITS:
        return -1.0
    return abs(J[im, jm])


@jit
def lu_factor(A, order, n, unz, ucnt, lnz, lcnt, amax, J, rowrel):  # type: ignore[no-untyped-def]  # noqa: C901
    """In-place LU with partial pivoting of ``A[:n, :n]``. False if numerically singular.

    Rows stay where they are: ``order[k]`` is the row chosen as the k-th pivot (the same
    choice, ties included, as swapping rows). The Jacobian is sparse (about 15% of it is
    nonzero for the cuboid, and its factors about 30%), so each elimination step visits only the
    nonzero columns of the pivot row and the rows with a nonzero in the pivot column, and
    keeps both lists for :func:`lu_solve`: ``unz[k, :ucnt[k]]`` the columns right of the
    diagonal in row ``order[k]`` of U, ``lnz[k, :lcnt[k]]`` the rows holding a multiplier
    of column k (int64 workspaces). The factors are those of the dense algorithm.
    ``amax``: ``max |A[:n, :n]|`` when the caller has it (:func:`copy_amax`), or < 0 to
    have it computed here. A pivot below ``1e-13 amax`` counts as singular, unless
    ``rowrel`` and it is at least ``1e-13`` times the largest magnitude of its own row of
    ``J`` (the matrix that ``A`` holds a copy of, unfactored): the Newton matrix's rows
    differ in scale by up to 1e9 at an impact (the torsional friction row is ``mu e_r
    lam_n``, with ``lam_n`` an impulse over ``h``), and a test against the largest entry
    alone calls regular matrices singular there (docs/solver_gaps.md, section 7). The row
    test runs only where the global one fails, so every matrix that passed it is factored
    as before.
    """
    for i in range(n):
        order[i] = i
    if amax < 0.0:
        amax = 0.0
        for i in range(n):
            for j in range(n):
                v = abs(A[i, j])
                if v > amax:
                    amax = v
    if not amax > 0.0:
        return False
    tiny = PIVOT_REL * amax
    for k in range(n):
        # one pass over the rows not yet pivoted: the nonzeros of column k (by position)
        # and the first largest of them
        p = k
        best = abs(A[order[k], k])
        nl = 0
        for i in range(k, n):
            a = A[order[i], k]
            if a != 0.0:
                lnz[k, nl] = i
                nl += 1
                v = abs(a)
                if v > best:
                    best = v
                    p = i
        if not best > tiny:
            if not (rowrel and best > 0.0):
                return False
            rmax = 0.0
            for j in range(n):
                v = abs(J[order[p], j])
                if v > rmax:
                    rmax = v
            if not best > PIVOT_REL * rmax:
                return False
        rk = order[p]
        if p != k:
            order[p] = order[k]
            order[k] = rk
        nnz = 0
        for j in range(k + 1, n):
            if A[rk, j] != 0.0:
                unz[k, nnz] = j
                nnz += 1
        ucnt[k] = nnz
        inv = 1.0 / A[rk, k]
        m = 0
        for q in range(nl):
            i = lnz[k, q]
            if i == p:
                continue
            if i == k:
                i = p  # the row at position k moved to position p
            ri = order[i]
            lnz[k, m] = ri
            m += 1
            f = A[ri, k] * inv
            A[ri, k] = f
            for qq in range(nnz):
                j = unz[k, qq]
                A[ri, j] -= f * A[rk, j]
        lcnt[k] = m
    return True


@jit
def lu_solve(A, order, b, n, unz, ucnt, lnz, lcnt, y):  # type: ignore[no-untyped-def]
    """Solve in place with the factors of :func:`lu_factor` (``y``: float64[n] workspace).

    The same subtractions in the same order as the dense substitutions, without the
    products with the zeros of the factors.
    """
    # forward substitution column by column, in the original row numbering
    for k in range(n):
        bk = b[order[k]]
        y[k] = bk
        if bk != 0.0:
            for q in range(lcnt[k]):
                r = lnz[k, q]
                b[r] -= A[r, k] * bk
    for i in range(n - 1, -1, -1):
        ri = order[i]
        acc = y[i]
        for q in range(ucnt[i]):
            j = unz[i, q]
            acc -= A[ri, j] * b[j]
        b[i] = acc / A[ri, i]
