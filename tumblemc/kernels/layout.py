"""Index constants shared by the kernels and the Python layer.

All kernel quantities are dimensionless (see :mod:`tumblemc.units`): length unit
``1e-4 m``, mass unit the robot mass ``m``, time unit ``sqrt(1e-4 m / g)``, so the weight
``m g`` is 1 and the unknowns of one step are O(1).

``prm`` (float64[N_PRM]): the run's constant physical parameters, scaled.
``sc`` (float64[N_SC]): the data of one time step (start-of-step state, step length,
external force, magnetic torque data).
Unknown vector ``z`` of one step: ``[v+ (3), w+ (3), block_0, block_1, ...]`` with one
contact block per convex piece, laid out as ``B_*`` below (``m_k`` = number of constraints
of piece ``k``): ``a1 (3), a2 (3), lam_t, lam_o, lam_r, sigma, l_1..l_m, l_s, lam_n``.
Forces are unknowns (impulse / h) so that their size does not depend on the step.
"""

# ---- prm: run constants (scaled) -------------------------------------------------
P_MASS = 0  # robot mass (1 in scaled units)
P_G = 1  # gravity magnitude (1 in scaled units)
P_FELECT = 2  # electrostatic force magnitude along -n
P_MU = 3  # friction coefficient
P_ET = 4  # friction ellipsoid e_t
P_EO = 5  # friction ellipsoid e_o
P_ER = 6  # friction ellipsoid e_r (a length)
P_LINEFRAC = 7  # line-contact fraction of the adhesion area
P_ADHC = 8  # adhesion coefficient C (force / length^2)
P_TORQ = 9  # V_m |E| |B|: magnetic torque magnitude
P_FREQ = 10  # field frequency (cycles per time unit)
P_ELECT_FLIGHT = 11  # 1: electrostatic force also in flight (authors' code); 0: in contact only
P_TORQUE_END = 12  # weight of the end-of-step magnetic torque: 1 at the end (paper), 0 at the start, 0.5 their mean
P_N = 13  # plane normal n (3)
P_T = 16  # contact tangent t (3)
P_O = 19  # contact tangent o (3)
P_U = 22  # uphill direction u (3)
P_EB = 25  # unit magnetisation direction in the body frame (3)
P_IB = 28  # body inertia about the CM, 3x3 row-major (9)
P_FIELD_ON = 37  # 1: field on, 0: off
P_ROT_PAPER = 38  # 1: the paper's rotation row I+ (w+ - w)/h + w x (I+ w); 0: momentum form (I+ w+ - I w)/h
P_LINE_STRIP = 39  # 1: line/point contact adheres over a strip of width P_LINEW (MODEL.md); 0: P_LINEFRAC x face area
P_LINEW = 40  # line_contact_width (scaled length)
P_PEEL = 41  # 1: a released face peels (adhesion_release="peel", MODEL.md departures); 0: the paper's force law
P_PEEL_LEN = 42  # peel_length (scaled): the work of adhesion per area is C x peel_length
P_FPROG = 43  # number of field-program segments after N_PRM (0: the paper's field, P_TORQ x R_x(2 pi P_FREQ t) u)
P_POSE_W0 = 44  # the pose update's weight of the start w: Q+ turned by h ((1 - it) w+ + it w); 0 the paper's, 0.5 the midpoint rule's
N_PRM = 45

# ---- field program: prm[N_PRM + k * FSEG + FS_*], one row per segment (model/fields.py) ----
FS_T0 = 0  # segment start time
FS_FREQ = 1  # rotation frequency (cycles per time unit; 0: static)
FS_PSI0 = 2  # phase at the segment start (rad)
FS_AMP = 3  # rotating part: V_m |E| |B_rot| (a torque magnitude)
FS_S = 4  # start direction s (3)
FS_W = 7  # a x s (3)
FS_BIAS = 10  # static part V_m |E| B_static (3)
FSEG = 13

# ---- sc: one step ------------------------------------------------------------------
S_X = 0  # CM position at the start of the step (3)
S_Q = 3  # orientation quaternion (scalar first) at the start (4)
S_V = 7  # linear velocity at the start (3)
S_W = 10  # angular velocity (world) at the start (3)
S_H = 13  # step length
S_FEXT = 14  # applied force: gravity + electrostatic + adhesion (3)
S_TM = 17  # magnetic torque when evaluated at the start of the step (3)
S_B0 = 20  # the field at the start of the step, in torque units (P_TORQ * unit field, or V_m |E| B(t)) (3)
S_B1 = 23  # the same at the end of the step (3): the end-of-step torque's field and the ledger's field work
N_SC = 26

# ---- contact block of one convex piece ---------------------------------------------
B_A1 = 0
B_A2 = 3
B_LT = 6
B_LO = 7
B_LR = 8
B_SIG = 9
B_L = 10  # first l_i; l_s = B_L + m, lam_n = B_L + m + 1
B_FIXED = 12  # block size = B_FIXED + m

# ---- constraint types ---------------------------------------------------------------
C_PLANE = 0  # data (nx, ny, nz, d): f(y) = n.y - d
C_CYL_X = 1  # data (cy, cz, R, 0): f(y) = sqrt((y1-cy)^2 + (y2-cz)^2) - R (axis along x)

# ---- solver options array ----------------------------------------------------------
O_TOL = 0
O_MAXIT = 1
O_MAXDEPTH = 2
O_ARMIJO = 3
O_MINSTEP = 4
O_MAXFAIL = 5  # stop the run after this many failed steps (0: never)
O_ACCEPT = 6  # an unsolved (sub-)step is kept at once, as loose, if its best residual is at most this (0: never)
# a contact (sub-)step whose normal impulse does positive work above this x (m g + the
# field's work bound over a step) is refined in sub-steps (0: never)
O_NWORK = 7
# a (sub-)step that fails at the smallest sub-step is kept as loose if its best attempt
# balances momentum to this fraction of the step's momenta and impulses and its geometric
# rows to IMPULSE_ACCEPT_LEN, and its contact does not pass through the plane
# (contact.impulse_consistent; 0: never, such steps fail)
O_IMPULSE = 8
# chord iterations (the factors of an earlier Newton matrix of the same step length) at
# the start of a step's first attempt, before Newton (newton.solve; 0: never)
O_CHORD = 9
# early decision (stepper.run, kernels/decide.py): 0 off, 1 note the first time the energy
# bound decides the run's verdict (failure), 2 also stop the run there
O_DECIDE = 10
O_DECIDE_NEED = 11  # uphill progress over the window that success needs (scaled length)
O_DECIDE_STEP = 12  # the step that starts the measurement window
# 1 (default): a (sub-)step whose best attempt stalled within O_ACCEPT still tries the
# smoothing strategies; 0: it skips them (stepper.run; SolverOptions.smooth_stalled)
O_SMOOTH_STALLED = 13
# the extrapolated warm start of a smooth contact step: the polynomial through the last
# solutions of the order, 2 up to this, that predicted the step just solved best (2: always
# the quadratic; stepper.run, stepper._best_order; SolverOptions.warm_order)
O_WARM = 14
# 1 (default): a Newton matrix's pivot that fails lu_factor's test against the largest
# entry is tested against its own row; 0: the matrix-wide test only (newton.solve;
# SolverOptions.pivot_row_test)
O_PIVROW = 15
# > 0: a Newton solve stops (ST_MAXIT) after this many iterations in which neither the
# residual's max-norm halved nor the smoothing parameter fell (newton.solve;
# SolverOptions.stall_window, default 80); 0: only the iteration limit stops it
O_STALL = 16
# a step that fails at every sub-step depth is solved once more from its start, every
# attempt allowed this many Newton iterations and no stall window (SolverOptions.rescue_iter,
# default 1000); 0: the step is kept as failed at once
O_RESCUE = 17
# a sub-step of a refined landing (O_NWORK) that does not converge is halved again, at most
# this many times within the refinement, before the step returns to its snapshot
# (SolverOptions.refine_halvings; 0: it returns at once)
O_REFINE_HALVE = 18
N_OPT = 19

# ---- solver status codes -------------------------------------------------------------
ST_OK = 0
ST_MAXIT = 1
ST_LINESEARCH = 2
ST_NAN = 3
ST_STOPPED = 4  # the run stopped after opts[O_MAXFAIL] failed steps
ST_DECIDED = 5  # the run stopped once its verdict could no longer change (opts[O_DECIDE] == 2)

# ---- record columns (one row per recorded instant) ----------------------------------
R_T = 0
R_X = 1  # 3
R_Q = 4  # 4
R_V = 8  # 3
R_W = 11  # 3
R_LN = 14  # normal force (sum over pieces)
R_ADH = 15  # adhesion force computed from this step's contact mode (applied next step)
R_AREA = 16  # contact area
R_MODE = 17  # 0 none, 1 point/line, 2 face
R_SLIP = 18  # slip speed at the ECP
R_NIT = 19  # Newton iterations in the recorded interval
R_RES = 20  # final residual (max over the interval)
R_FALLBACK = 21  # damped/gradient fallbacks in the interval
R_SUB = 22  # extra sub-steps in the interval
R_PEN = 23  # max penetration in the interval
R_FAIL = 24  # steps in the interval with a sub-step that did not converge at the smallest size
R_ECP = 25  # ECP a1 of the first piece in contact (3)
R_LOOSE = 28  # steps in the interval with a (sub-)step kept unsolved: residual between O_TOL and O_ACCEPT, or by O_IMPULSE
R_LED = 29  # the energy ledger at the recorded instant (N_LED columns, L_* order)
R_IMPULSE = 46  # steps in the interval with a (sub-)step kept by O_IMPULSE alone (a subset of R_LOOSE)
N_REC = 47

# ---- ledger columns (cumulative over the run, except L_KE) ---------------------------
L_WMAG = 0  # work of the magnetic torque
L_WGRAV = 1  # work of gravity
L_WELECT = 2  # work of the electrostatic force
L_WADH = 3  # work of the adhesion force
L_WN = 4  # work of the normal contact impulses
L_WFRIC = 5  # work of friction (tangential and torsional)
L_DISS = 6  # backward Euler's dissipation 1/2 dV . M dV
L_BAL = 7  # balance: kinetic energy gained beyond the work of all forces (+ L_DISS)
L_GAIN = 8  # numerical energy gain: per step max(balance + max(W_n, 0), 0)
L_KE = 9  # kinetic energy at the end of the last step (not cumulative)
L_POTMAX = 10  # the most potential energy released so far: max over steps of L_WGRAV + L_WELECT
L_WFIELD = 11  # the field's own work: the magnetic energy's change due to the field's time variation
L_EXCESS = 12  # energy above its start beyond the field's work and every force's: sum of L_BAL - L_DISS + torque error
L_XGAIN = 13  # numerical energy excess: the most L_EXCESS has reached (0 at the start)
L_WMAGX = 14  # the magnetic energy the rotation released: cumulative -dU_rot (what h T . w+ approximates)
L_MAGMAX = 15  # the most energy the magnet has delivered: max over steps of L_WMAGX
N_LED = 16
# a run whose numerical energy gain (L_GAIN) exceeds this fraction of its energy scale (field
# work bound + initial kinetic energy + potential energy released + m g x length unit) is
# flagged (model/energy.py)
ENERGY_GAIN_TOL = 0.01

# ---- the time loop's scalar state (a float64[N_SV] record; runtypes.Frame.sv) ---------
# Integers and flags are stored as float64 (exact). The first N_SNAP entries are what a
# refined landing's restart restores, the first N_SNAP_STEP what a rescue pass restores.
SV_T = 0  # time (scaled)
SV_AREA = 1  # adhering area of the last committed (sub-)step's contact
SV_PEEL = 2  # area released by the contact that still adheres (peeling)
SV_PEEL_LEFT = 3  # work of adhesion left before the peeled area lets go
SV_ANY_TOUCH = 4  # 1 if the last committed (sub-)step touched the plane
SV_NCONT = 5  # consecutive full-length contact solves (the extrapolated warm start)
SV_PEN = 6  # largest penetration in the record interval
SV_RES = 7  # largest kept residual in the record interval
SV_SUB = 8  # extra sub-steps in the record interval
N_SNAP = 9
SV_ORDER = 9  # the order of the next step's extrapolated warm start (O_WARM >= 3)
N_SNAP_STEP = 10
SV_NIT = 10  # Newton iterations in the record interval
SV_FB = 11  # fallbacks in the record interval
SV_FAIL = 12  # failed steps in the record interval
SV_LOOSE = 13  # loose steps in the record interval
SV_IMPULSE = 14  # steps kept by O_IMPULSE in the record interval
SV_MODE = 15  # contact mode of the last committed (sub-)step (R_MODE)
SV_LNSUM = 16  # its normal force
SV_SLIP = 17  # its slip speed
SV_ECP = 18  # the offset of its first touching block in z (-1: none)
N_SV = 19
