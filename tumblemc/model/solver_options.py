"""The solver's options (:class:`SolverOptions`: Newton, sub-stepping and landing rules; validated); the torque and rotation rows."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tumblemc.model.params import check_number

#: the magnetic torque of a step: at its start (the default), at its end pose (the paper's) or
#: their mean ("mid", the trapezoid of the midpoint integrator, rotation="midpoint")
TORQUE_OPTIONS: tuple[str, ...] = ("start", "end", "mid")
TORQUE_END_WEIGHT = {"start": 0.0, "end": 1.0, "mid": 0.5}
#: the rotational row (MODEL.md): "momentum" (the default), (I+ w+ - I w)/h, which keeps a free
#: body's angular momentum; "paper", I+ (w+ - w)/h + w x (I+ w) (forward Euler on Euler's
#: equations: it makes energy in a spin off a principal axis); "midpoint", the momentum row
#: with the pose turned by the mean of w and w+ (70x less damping of a free spin)
ROTATION_OPTIONS: tuple[str, ...] = ("momentum", "paper", "midpoint")
DEFAULT_ROTATION = "momentum"


@dataclass(frozen=True)
class SolverOptions:
    """Newton and sub-stepping options (tolerances in scaled units, :mod:`tumblemc.units`).

    tol : max-norm of the residual at convergence. Where rows cannot resolve it in float64
        (small steps and fast spins in the Newton-Euler rows, a landing's large forces in the
        friction cone's row: ``tumblemc.kernels.rounding``), a plain Newton iterate whose
        every row lies within a few ulps of its terms passes once no descent is left. Such a
        step records its residual (above ``tol``) and is not counted as loose.
    max_iter : Newton iterations per solve.
    max_substep_depth : a failed step is retried as halves down to ``dt / 2**depth``.
    armijo : sufficient-decrease constant of the line search.
    min_step : smallest line-search step before a fallback.
    max_failed_steps : stop the run after this many failed steps (0: never stop). Studies
        use 1: a run with a failed step is invalid there anyway, and a step that fails at
        the smallest sub-step leaves the rest of the step at that sub-step (costly).
    accept_tol : when no strategy solves a (sub-)step to ``tol``, its best attempt is kept
        at once, without halving, and the step counted as loose, if the max-norm of the
        model's residual there is at most this (at metres per second the residual can stall
        just above ``tol``, and its floor grows as the step shrinks). Allowed: 0, or from
        ``tol`` to 1. 0 (with ``impulse_accept_tol`` = 0) restores the earlier rule: halve, then fail.
    landing_work : a converged contact (sub-)step whose normal impulse does positive work
        above this fraction of the step's energy scale (the weight times the length unit +
        the field's work bound over one step, ``m g x 1e-4 m + |m||B| (2 + 2 pi f dt)``) is
        solved again as halves, down to ``dt / 2**max_substep_depth`` (a rigid contact
        cannot push; at a fast landing the robot crosses several thicknesses in one step
        and the end-pose contact throws it back out: docs/solver_gaps.md, section 4). The
        refinement is kept only if every sub-step converges (one that does not is halved
        again, at most ``refine_halvings`` times) and the sub-steps together do less
        positive normal work; otherwise the full step is solved again and kept. Every
        converged sub-step is checked, also one after an earlier sub-step of the same step
        was committed (before, only a step's first sub-step was, and a
        landing in the second half of a step halved for convergence kept its positive
        work: docs/solver_gaps.md, section 9). The default 1e-5 is a thousandth of the
        energy tolerance (``ENERGY_GAIN_TOL`` = 1e-2 of a scale at least the step's), so a
        run keeps a thousand landings at the threshold before the ledger flags it. Allowed: 0 (never: the paper's fixed step) to 1.
    impulse_accept_tol : a (sub-)step that no strategy solves even at ``dt / 2**max_substep_depth``
        is kept, as a loose step, instead of failing, if its best attempt balances linear and
        angular momentum to this fraction of the step's momenta and impulses (the force rows'
        residual times the sub-step, against ``m (|v| + |v+|) + h (m g + contact forces)``
        and its angular twin), its friction rows to this fraction of their terms, and its
        ECP, normal-cone and complementarity rows to 1e-3 in scaled units (0.1 um where the
        row is a length: the penetration tolerance of the 3-D runs), and if its contact point
        ends more than 1e-6 below the plane, that point is not moving further in (an attempt
        whose normal force does nothing passes through the plane a step's travel a step:
        docs/notes/solver_gaps.md, section 13). A step refused goes to the rescue pass
        (``rescue_iter``), then fails; with the rescue off the same iterate is kept either
        way: only the label changes (and a run with ``max_failed_steps`` goes on).
        At a landing solved in a tiny sub-step the contact forces are an impulse divided by that sub-step (1e6 weights at 2e-8 s), and
        Newton can stall at a kink with a residual of 0.9 that is 5e-7 of the forces it
        balances (docs/solver_gaps.md). The energy ledger still judges what is kept; steps
        that converge are not affected. Allowed: 0 (never: such steps fail, the earlier rule) to 1e-3.
    chord_iter : a step's first attempt starts with up to this many chord iterations: the
        LU factors of the last plain Newton matrix of the same step length (an earlier
        step's) applied to the new residual, kept while each divides the residual's max-norm
        by at least 2, then Newton from the last point kept (Jacobian reuse, as in stiff
        integrators; ``tumblemc.kernels.newton.solve``). The convergence test is unchanged
        (``tol``), so the solutions agree to ``tol``, not bit for bit; the iterations
        recorded count the chord ones. 0: a fresh Jacobian and LU at every iteration (the
        earlier rule, bit for bit). Allowed: 0 to 100.
    smooth_stalled : 1 (the default): every strategy is tried at every (sub-)step. 0: once
        an attempt has stalled at a residual within ``accept_tol`` (so the (sub-)step will
        not be halved for want of convergence; a landing refinement, its restart or a
        lift-off may still replace it), the smoothing strategies, which cost up to 300
        iterations each, are skipped and only the cheap ones are tried for a converged
        solution; the iterate kept is the lowest stall among the attempts tried. Measured
        with 0 (docs/kernel_experiments.md): 10% fewer Newton iterations on 16 aluminum
        runs (the curved robot's sliders 17% to 39%), the main job 1,928 s against 2,280 s
        with every verdict equal, but 26% more loose steps there (14,336 -> 18,091), and
        on the paper robot climbing 45 deg at 10 Hz 4 loose steps where every step
        converged and 3% to 5% more iterations: the smoothing attempts it skips are what
        converge those steps. Not the default until that trade is settled.
        Allowed: 0 or 1 (an integer, as the run's attributes store it).
    warm_order : the warm start of a step in smooth contact (the fourth and later full-length
        contact step in a row) extrapolates the last solutions, with the polynomial of the
        order (2 up to ``warm_order``) that predicted the step just solved best (the
        max-norm of each extrapolation's error; variable-order predictors choose their
        order the same way). An order p needs p + 1 contact solutions in a row. 2: the
        quadratic through the last three (the earlier rule, bit for bit). 3 (the
        default): the cubic or the quadratic. 4: up to the quartic; 5: up to the quintic.
        Only the starting point changes: the convergence test is the same, so the solutions
        agree to ``tol``, not bit for bit. Measured (docs/kernel_experiments.md, "A cubic
        warm start" and "Warm starts up to the quartic"): 3 against 2, 0.91x the time per
        step; 4 against 3, 0.93x the time of the default study's first 20 samples per cell
        (5: 0.88x), but 1.07x the CPU time on the whole main job (one run, against an
        order-3 run of another session; 3.5% fewer iterations). Not the default: with 4 the
        stress campaign had 6 invalid runs of 576 against 2 and one 3-D run with a failed
        step (a landing no strategy solves on that path, docs/solver_gaps.md), where 3 has
        none.
        Allowed: 2 to 5.
    pivot_row_test : 1 (the default): a pivot of the Newton matrix that fails the LU's
        singularity test (below 1e-13 of the matrix's largest magnitude) is tested against
        the largest magnitude of its own row instead, and the factorisation goes on if it
        passes that. At an impact the torsional friction row (``mu e_r lam_n``, with the
        authors' ``e_r = 0.1 m`` and a force ``lam_n`` of an impulse over the step) is up to
        1e9 times the unit rows, and the matrix-wide test called regular matrices singular.
        The solver then took a Levenberg-Marquardt direction that stalls (docs/solver_gaps.md,
        section 7: the small-step landings of reproducer 1). 0: the matrix-wide test alone,
        the earlier rule, bit for bit. Matrices that pass the matrix-wide test are
        factored the same way under either setting. Allowed: 0 or 1.
    stall_window : > 0: a smoothing attempt (the continuation of strategies 6-16 and 22, up
        to 300 iterations) stops as unconverged once ``stall_window`` iterations in a row
        have neither halved its residual's max-norm nor lowered its smoothing parameter;
        the next strategy follows, as after its iteration limit. Plain attempts are not
        affected. 0: every smoothing attempt runs to its limit (the earlier rule,
        bit for bit). On refined steps of the curved robot sliding on aluminum, attempts
        that never converge took up to 35,700 of a step's 42,244 iterations. Measured with
        80 against 0 (docs/kernel_experiments.md, "A stall window for the smoothing
        continuation"): the 50-sample default study in 0.80x the CPU time, every verdict
        the same; 400 runs of the stress campaign's violent class (aluminum, 70 deg, 0.5
        Hz) 20 invalid with either; 13 of 18 reference runs bit for bit, the others (the
        spiked-ends robot on paper, the cuboid on aluminum at 20 deg, the reproducers) on
        other paths, climbers with the same ratio to 1e-10.
        Allowed: 0 to 10,000.
    rescue_iter : > 0: a step that no strategy solves at any sub-step depth is solved once
        more from its start before it is kept as failed, every attempt (plain and smoothing)
        allowed ``max(max_iter, 300, rescue_iter)`` Newton iterations and no stall window.
        Steps that do not fail are untouched, bit for bit; only a failing step pays for the
        second pass. Found on the main job's 13 invalid runs at a97302c (curved and spiked
        robots sliding on aluminum at 40-60 deg, one failed step each): sub-steps whose
        plain Newton converges after 60 to a few hundred iterations, or whose smoothing
        attempt the stall window had cut. 1000 (the default) solves all 13 (300 solves 9).
        0: the failed step is kept at once (the earlier rule).
        Allowed: 0 to 10,000.
    refine_halvings : a sub-step of a refined landing (``landing_work``) that does not
        converge is halved again, at most this many times within the refinement (the rest of
        the refined step goes on at that length, so a refinement costs at most
        ``2**(1 + refine_halvings)`` sub-steps more than the step it replaces), before the
        step returns to its start and is solved again with a shallower refinement. Found on
        the stress study's violent class (aluminum, 70 deg, 0.5 Hz): landings at 15-25 m/s
        whose first half-step does not converge, so the refinement was refused and the step
        kept at dt with its positive normal work (up to 2e-6 J, the runs' whole energy gain).
        2 (the default) makes 4 of that class's 5 ``energy_gain`` runs of 400 valid at about
        the same cost (docs/solver_gaps.md, section 10); without a bound, the refinement
        went down to dt/256 at such landings and a run took ten times longer. 0: the step
        returns to its start at once (the earlier rule, bit for bit).
        Allowed: 0 to 30.
    """

    tol: float = 1e-9
    max_iter: int = 60
    max_substep_depth: int = 8
    armijo: float = 1e-4
    min_step: float = 1e-10
    max_failed_steps: int = 0
    accept_tol: float = 1e-6
    landing_work: float = 1e-5
    impulse_accept_tol: float = 1e-6
    chord_iter: int = 4
    smooth_stalled: int = 1
    warm_order: int = 3
    pivot_row_test: int = 1
    stall_window: int = 80
    rescue_iter: int = 1000
    refine_halvings: int = 2

    def __post_init__(self) -> None:
        check_number("tol", self.tol, "> 0")
        integers = (
            "max_iter",
            "max_substep_depth",
            "max_failed_steps",
            "chord_iter",
            "smooth_stalled",
            "warm_order",
            "pivot_row_test",
            "stall_window",
            "rescue_iter",
            "refine_halvings",
        )
        for name in integers:
            v = getattr(self, name)
            if not isinstance(v, (int, np.integer)) or isinstance(v, bool):
                raise ValueError(f"{name}={v!r} is not allowed (allowed: an integer)")
        check_number("max_iter", self.max_iter, "", 1, 10_000)
        check_number("max_substep_depth", self.max_substep_depth, "", 0, 30)
        check_number("armijo", self.armijo, "", 1e-12, 0.5)
        check_number("min_step", self.min_step, "", 1e-16, 0.5)
        check_number("max_failed_steps", self.max_failed_steps, "", 0, 1e12)
        check_number("accept_tol", self.accept_tol, "", 0.0, 1.0)
        check_number("landing_work", self.landing_work, "", 0.0, 1.0)
        check_number("impulse_accept_tol", self.impulse_accept_tol, "", 0.0, 1e-3)
        check_number("chord_iter", self.chord_iter, "", 0, 100)
        check_number("smooth_stalled", self.smooth_stalled, "", 0, 1)
        check_number("warm_order", self.warm_order, "", 2, 5)
        check_number("pivot_row_test", self.pivot_row_test, "", 0, 1)
        check_number("stall_window", self.stall_window, "", 0, 10_000)
        check_number("rescue_iter", self.rescue_iter, "", 0, 10_000)
        check_number("refine_halvings", self.refine_halvings, "", 0, 30)
        if 0.0 < self.accept_tol < self.tol:
            raise ValueError(f"accept_tol={self.accept_tol!r} is below tol={self.tol!r} (allowed: 0, or from tol to 1)")

    def as_array(self) -> np.ndarray:
        """Pack the options into the kernels' options array (layout ``O_*`` of :mod:`tumblemc.kernels.layout`)."""
        from tumblemc.kernels import layout as L

        a = np.zeros(L.N_OPT)
        a[L.O_TOL] = self.tol
        a[L.O_MAXIT] = self.max_iter
        a[L.O_MAXDEPTH] = self.max_substep_depth
        a[L.O_ARMIJO] = self.armijo
        a[L.O_MINSTEP] = self.min_step
        a[L.O_MAXFAIL] = self.max_failed_steps
        a[L.O_ACCEPT] = self.accept_tol
        a[L.O_NWORK] = self.landing_work
        a[L.O_IMPULSE] = self.impulse_accept_tol
        a[L.O_CHORD] = self.chord_iter
        a[L.O_SMOOTH_STALLED] = float(self.smooth_stalled)
        a[L.O_WARM] = float(self.warm_order)
        a[L.O_PIVROW] = float(self.pivot_row_test)
        a[L.O_STALL] = float(self.stall_window)
        a[L.O_RESCUE] = float(self.rescue_iter)
        a[L.O_REFINE_HALVE] = float(self.refine_halvings)
        return a
