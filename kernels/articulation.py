"""Articulated line ends: hinges, universal joints and ball joints at a node, exact (§8).

A welded line end carries the node's frame D X (1.3). An articulated end carries the joint
frame G = D X R(phi), whose rotation R relative to the node is restricted by the joint's kind
to a subset of SO(3), given by its coordinates phi (rad):
    hinge      R = exp(phi_0 a)                  a fixed in X
    universal  R = exp(phi_0 a) exp(phi_1 b)     a fixed in X, b fixed in the joint frame
    ball       R = exp(phi)                      phi a rotation vector, X's components
so the constrained relative rotations hold to round-off whatever phi is. The boundary Voronoi
point of the end (half an element, kernels/elastic.py) joins G, not D X, to the end element; the
model holds no bending stiffness there (cosnet.engine.flatten) and this effect carries it.

The joint frame has no inertia of its own (the rotary inertia about the end belongs to the end
element and the node, as at a weld), so at every evaluation of the loads phi is where the
loads on it balance. With c_i the joint frame's body axis of coordinate i and tau_G the
bending torque of the boundary point on G (3.22), the generalised torque
    Q_i(phi) = c_i . tau_G - k_i (phi_i - phi0_i) - T_i(phi_i) - d_i (phi_i - phi_i^-) / dt
(springs k, tables T of torque against angle, dampers d, phi^- the coordinates at the previous
evaluation, dt before it) equals the friction torque: zero without friction, the kinetic torque
against the motion while a coordinate slides; a coordinate sticks (phi_i = phi_i^-) while |Q_i(phi^-)| stays within the
static torque (the kinetic one once sliding) (a ball joint's friction is one torque on its rotation
as a whole: start_turning), and a limit holds phi_i in [lower_i, upper_i] (a
ball joint's cone holds the angle of G's d3 from X's within it).
Without dampers and friction phi minimises the boundary bending energy plus the springs', so
the loads are the exact gradient of that energy minimised over the joint (the envelope
theorem): the step stays variational, and a free axis adds no stiffness to it. The node
receives the whole torque on G (the joint frame is in balance between the line and the node).

phi is found by Newton's method with the Jacobian's leading term, c_i^T B c_k / L + (k_i +
d_i / dt) delta_ik (B in G's components, L the boundary point's length), to round-off. A
hinge that turns takes its exact derivative once its first step is above the tolerance, and a
step so found below ONE_STEP is not evaluated again: its loads are carried along it to first
order (settle_hinge), one evaluation of the boundary point a step where two were needed; a
universal joint likewise (settle_universal), and a ball joint (settle_ball, its three axes
turning with phi: joint_math.ball_exact; its leading-term steps otherwise, in their own terms,
w_i = J k_i, where the load kernel took settle_joint's before). A loose ball joint,
nothing on R but the boundary point, needs no iteration: it balances where that point is
unstrained, R in closed form (loose_turn), and passes no torque; with a cone, so while that
balance lies within it. In a net of LANE_MIN joints or more, a hinge without a spring table
settles first in vector lanes (joint_lanes.settle_hinges, the joints padded to whole vectors):
every joint takes there what settle_axes takes first, with friction or a damper the friction
weighed at phi^- (a joint it holds is settled there), then settle_hinge's first evaluation,
both of its Newton steps computed and the one settle_hinge would take selected, with no
branch; one whose evaluation is its balance (its step ends the iteration or is carried) is
done, one whose exact step is too long to carry goes on through settle_hinge from the lanes'
next point. (Where friction holds all but fewer than one in TURNING_SHARE of the columns,
settle_hinges does not run: the held hinges take weigh_hinges' loads, the others the scalar
path.) A universal joint without a spring table takes its friction's weighing and
settle_universal's first evaluation in the same way, its two coordinates' Newton steps selected
without a branch (settle_universals, in one loop over the lanes' rows that LLVM keeps scalar);
the others (spring tables, boundary points turned past 0.2 rad) go through the scalar path as
before. A ball joint with friction or a damper and without a spring table has its friction
weighed at phi^- in lanes too (weigh_balls, start_turning's weighing): one that its friction
holds is settled there, with the loads it was weighed with (a friction joint is held most of
the time), one that turns goes on through the iteration, which on the scalar path likewise
takes the weighed loads of a joint held whole. A ball joint that turns, neither loose nor with
a spring table or a cone, settles by settle_ball (the leading term's steps, and an exact step
below ONE_STEP carried, as a hinge's), in lanes by its first evaluation (settle_sockets, where
at least one in TURNING_SHARE of the lanes' columns turns: the lanes take every column).
The lanes read each joint's constants from rows of one number a joint (lane_tables): read
from the record's rows of three, whose length is no constant to LLVM, the loop ran in lanes
only under a run-time test that a row holds one number, and so never did. The joints' own
arithmetic is the scalar path's (kernels/joint_math.py). A loose ball joint settles in lanes
likewise, by loose_turn itself (settle_balls: its arctangent and branch written as selects,
rotations.quat_log). The larger helpers are compiled as functions of their own, not inlined
into each caller: the load kernel, the energy and the fields share them, and numba types an
inlined copy anew each time (tens of seconds for this module). coordinate_balance, called
three times in each Newton step, stays inlined: as a call it receives the records as hundreds
of arguments, which cost more than its arithmetic (a joint's step took 1.7 us so, 0.2
inlined).
"""

import math
import sys
from typing import NamedTuple

import numpy as np
from numba import njit

from .backend import ENTRY
from .compiler import CACHED, INLINE, INNER
from .compose import load_kernel
from . import joint_lanes
from .elastic import end_frame
from .joint_lanes import AHEAD, BALL_OK, C_GRIP, C_HELD, C_HINGE, C_LOOSE, C_SOCKET, C_UNIVERSAL, FRIC, GRIPPED, \
    G_FRIC, G_NODE, G_OK, LANE_MIN, MOVES, NODE, OK, PHI, SETTLED, SOCKETED, S_NODE, S_OK, S_PHI, TURN, TURNING_SHARE, \
    UNIVERSALS, U_FRIC, U_MOVES, U_NODE, U_OK, U_PHI, WEIGHED, W_FRIC, W_MOVES, W_NODE, W_OK, lane_loads, \
    settle_balls, settle_hinges, settle_sockets, settle_universals, weigh_balls, weigh_hinges
from .joint_math import BALL, HINGE, NEWTON_TOL, ONE_STEP, UNIVERSAL, ball_axes, ball_exact, ball_weighed, \
    bend_rate, boundary_moment, boundary_pair, boundary_quat, carried_torque, cone_cosine, dot3, friction_weighed, \
    hinge_terms, hinge_torques, inverse_jacobian, jacobian_rate, loose_turn, node_torque, positive_sym3, small_rate
from .rotations import cross, quat_exp, quat_log, quat_mul, quat_rotate, quat_rotate_inv, rotation_of, solve_sym3
from .specialise import Variants

NEWTON_STEPS = 40                  # at most; a balance converges in a few

# Compile-time options (kernels/specialise.py): the joints' record is of the variant its data
# needs (VARIANTS), whose kernels leave out what no joint of the net has. This module's own
# functions, and its record ArticulationParams, are the variant with both.
BALLS = True    # some joint is a ball joint: rotation-vector coordinates, a cone, one friction torque
HELD = True     # some joint has friction or a damper: coordinates that stick, a friction torque
PINS = True     # some joint is a hinge without a spring table, of LANE_MIN joints or more (joint_lanes)
LOOSE = True    # some joint is a loose ball joint, of LANE_MIN joints or more (joint_lanes.settle_balls)
CARDANS = True  # some joint is a universal joint without a spring table, of LANE_MIN joints or more
                # (joint_lanes.settle_universals)
GRIPS = True    # some joint is a ball joint with friction or a damper and without a spring table, of LANE_MIN
                # joints or more (joint_lanes.weigh_balls)
SOCKETS = True  # some joint is a ball joint neither loose nor with a spring table or a cone, of LANE_MIN joints
                # or more (joint_lanes.settle_sockets)
OPTIONS = ("BALLS", "HELD", "PINS", "LOOSE", "CARDANS", "GRIPS", "SOCKETS")


class ArticulationParams(NamedTuple):
    """The articulated line ends of a net (k of them), their joints and their state."""

    attach: np.ndarray      # (k,) int64 attachment (line end) of each joint
    dofs: np.ndarray        # (k,) int64 HINGE, UNIVERSAL or BALL
    axis_a: np.ndarray      # (k, 3) unit axis a in X (hinge, universal)
    axis_b: np.ndarray      # (k, 3) unit axis b in the joint frame (universal)
    bend: np.ndarray        # (k, 3) B = (E I1, E I2, G J) of the end's boundary Voronoi point (3.23)
    stiffness: np.ndarray   # (k, 3) spring per coordinate (N m / rad)
    rest: np.ndarray        # (k, 3) phi0 (rad)
    damping: np.ndarray     # (k, 3) damper per coordinate (N m s / rad)
    static: np.ndarray      # (k, 3) static friction torque (N m)
    kinetic: np.ndarray     # (k, 3) kinetic friction torque (N m)
    lower: np.ndarray       # (k, 3) limits (rad; -inf, +inf: none)
    upper: np.ndarray       # (k, 3)
    cone: np.ndarray        # (k,) a ball's cone: largest angle of its d3 from X's (rad; pi: none)
    table_offsets: np.ndarray  # (3 k + 1,) int64 CSR offsets of the spring table of coordinate (j, i) at 3 j + i
    table_angle: np.ndarray    # (m,) the tables' angles (rad, increasing within a table)
    table_torque: np.ndarray   # (m,) the torque resisting each angle (N m)
    phi: np.ndarray         # (k, 3) coordinates at the last evaluation
    rate: np.ndarray        # (k, 3) their rate over the last interval between evaluations (rad/s)
    sliding: np.ndarray     # (k, 3) 1.0 while a coordinate slides against its friction
    reaction: np.ndarray    # (k, 3) torque of the line on the node through the joint, lab
    last: np.ndarray        # (1,) clock of the last evaluation
    dissipated: np.ndarray  # (1,) energy the dampers and friction took (J)
    lanes: np.ndarray       # (LANE_ROWS, k) scratch of the vector lanes (kernels/joint_lanes.py)
    lane_constants: np.ndarray  # (LANE_CONSTANTS, k) the joints' constants by rows (lane_tables)
    lane_ends: np.ndarray   # (2, k) int64 each joint's node and end element (lane_tables)


@njit(**INNER)
def joint_turn(p, j, phi):
    """Return (R, c0, c1, c2): joint j's rotation relative to X (quaternion) at coordinates
    phi (3-tuple) and the body axes of its coordinates in the joint frame ((0, 0, 0) for those
    its kind lacks)."""
    a, b, n = p.axis_a[j], p.axis_b[j], p.dofs[j]
    zero = (0.0, 0.0, 0.0)
    if n == HINGE:
        return quat_exp(phi[0] * a[0], phi[0] * a[1], phi[0] * a[2]), (a[0], a[1], a[2]), zero, zero
    if n == UNIVERSAL or not BALLS:
        ra = quat_exp(phi[0] * a[0], phi[0] * a[1], phi[0] * a[2])
        rb = quat_exp(phi[1] * b[0], phi[1] * b[1], phi[1] * b[2])
        r = quat_mul(ra[0], ra[1], ra[2], ra[3], rb[0], rb[1], rb[2], rb[3])
        return r, quat_rotate_inv(rb[0], rb[1], rb[2], rb[3], a[0], a[1], a[2]), (b[0], b[1], b[2]), zero
    c0, c1, c2 = ball_axes(phi[0], phi[1], phi[2])
    return quat_exp(phi[0], phi[1], phi[2]), c0, c1, c2


@njit(**INNER)
def boundary_rotation(f, q, start, r):
    """Return (theta, cc, turn, small, rel) at a joint's boundary Voronoi point (boundary_quat's
    arguments): theta the rotation vector from its left frame to its right one and cc of the
    inverse Jacobians (bend_torques), with boundary_quat's values."""
    turn, small, rel = boundary_quat(f, q, start, r)
    tx, ty, tz, cc = rotation_of(turn[0], turn[1], turn[2], turn[3], small)
    return (tx, ty, tz), cc, turn, small, rel


@njit(**INNER)
def boundary_torques(p, j, model, state, f, r):
    """Return (tau_G, tau_E, kappa, m, rel): the body torques of joint j's boundary Voronoi
    point on the joint frame G = F R and on the end element, its strain kappa = theta/L - u0,
    its moment m = B kappa (3.22), and rel = G^T E (quaternion), given its end frame F = D X
    (f, end_frame: the same at every R the joint is tried at) and R (quaternions)."""
    a = p.attach[j]
    k, q = model.attach_vertex[a], state.q[model.attach_element[a]]
    start = a % 2 == 0
    (tx, ty, tz), c, _, _, rel = boundary_rotation(f, (q[0], q[1], q[2], q[3]), start, r)
    il, u0, bend = model.voronoi_inv_rest_length[k], model.voronoi_rest_curvature[k], p.bend[j]
    kx, ky, kz = tx * il - u0[0], ty * il - u0[1], tz * il - u0[2]
    mx, my, mz = bend[0] * kx, bend[1] * ky, bend[2] * kz
    tau, te = boundary_pair((tx, ty, tz), c, (mx, my, mz), start)
    return tau, te, (kx, ky, kz), (mx, my, mz), rel


@njit(**INNER)
def axis_stiffness(p, j, model, rel, ci, ck):
    """Return c_i^T B c_k / L at joint j's boundary point, B taken in the element's principal
    axes, c_i and c_k in the joint frame's (rel: G^T E, quaternion)."""
    k = model.attach_vertex[p.attach[j]]
    bend, il = p.bend[j], model.voronoi_inv_rest_length[k]
    ui = quat_rotate_inv(rel[0], rel[1], rel[2], rel[3], ci[0], ci[1], ci[2])
    uk = quat_rotate_inv(rel[0], rel[1], rel[2], rel[3], ck[0], ck[1], ck[2])
    return il * (bend[0] * ui[0] * uk[0] + bend[1] * ui[1] * uk[1] + bend[2] * ui[2] * uk[2])


@njit(**INLINE)
def start_motion(p, j, i, torque, prev, dt):
    """Return (moves, friction) of coordinate i of joint j given the torque on its axis at
    phi^- = prev (3-tuple): whether it may move in this evaluation, and the friction torque it
    then meets (module docstring)."""
    if i >= p.dofs[j]:
        return False, 0.0
    q0 = torque - p.stiffness[j, i] * (prev[i] - p.rest[j, i]) - spring_table(p, j, i, prev[i])[0]
    stays, fric = friction_weighed(q0, p.static[j, i], p.kinetic[j, i], p.sliding[j, i] != 0.0, p.damping[j, i], dt)
    return not stays, fric


@njit(**INNER)
def start_turning(p, j, model, state, f, prev, dt):
    """Return (moves, f0, f1, f2, node torque, tau_E) of ball joint j (its end frame f) at
    phi^- = prev: whether it may turn in this evaluation, the friction's generalised torques
    f_i = c_i . F on its coordinates (a ball joint's friction is one torque F on its rotation
    as a whole, not one per coordinate: joint_math.ball_weighed), and the loads found at phi^-
    (start_joint's held): the torque on the node, R tau_G, and tau_E."""
    r, c0, c1, c2 = joint_turn(p, j, prev)
    tau, te, _, _, _ = boundary_torques(p, j, model, state, f, r)
    q0 = dot3(c0, tau) - p.stiffness[j, 0] * (prev[0] - p.rest[j, 0]) - spring_table(p, j, 0, prev[0])[0]
    q1 = dot3(c1, tau) - p.stiffness[j, 1] * (prev[1] - p.rest[j, 1]) - spring_table(p, j, 1, prev[1])[0]
    q2 = dot3(c2, tau) - p.stiffness[j, 2] * (prev[2] - p.rest[j, 2]) - spring_table(p, j, 2, prev[2])[0]
    turning = p.sliding[j, 0] + p.sliding[j, 1] + p.sliding[j, 2] != 0.0
    damped = (p.damping[j, 0] + p.damping[j, 1] + p.damping[j, 2]) > 0.0
    stays, f0, f1, f2 = ball_weighed(c0, c1, c2, (q0, q1, q2), p.static[j, 0], p.kinetic[j, 0], turning, damped, dt)
    return not stays, f0, f1, f2, quat_rotate(r[0], r[1], r[2], r[3], tau[0], tau[1], tau[2]), te


@njit(**INLINE)
def table_segment(ang, tq, a0, a1, x):
    """Return (k, T, dT/dphi) at angle x of the spring table in ang / tq (p.table_angle /
    table_torque) a0 .. a1-1: its segment k (first point) and the torque on it, the end
    segments carried on beyond the table."""
    k = a0
    while k < a1 - 2 and x > ang[k + 1]:
        k += 1
    slope = (tq[k + 1] - tq[k]) / (ang[k + 1] - ang[k])
    return k, tq[k] + slope * (x - ang[k]), slope


@njit(**INNER)
def table_torque(ang, tq, a0, a1, x):
    """Return (T, dT/dphi) of the spring table ang / tq a0 .. a1-1 at angle x: piecewise linear
    through its points, its end segments carried on beyond them; (0, 0) without one."""
    if a1 - a0 < 2:
        return 0.0, 0.0
    return table_segment(ang, tq, a0, a1, x)[1:]


@njit(**INLINE)
def spring_table(p, j, i, x):
    """Return (T, dT/dphi) of coordinate i of joint j's spring table at angle x (table_torque)."""
    return table_torque(p.table_angle, p.table_torque, p.table_offsets[3 * j + i], p.table_offsets[3 * j + i + 1], x)


@njit(**INLINE)
def table_integral(p, a0, a1, x):
    """Return the integral of the spring table a0 .. a1-1 from its first angle to x."""
    ang, tq = p.table_angle, p.table_torque
    k, at, _ = table_segment(ang, tq, a0, a1, x)
    whole = 0.0
    for m in range(a0, k):
        whole += 0.5 * (tq[m] + tq[m + 1]) * (ang[m + 1] - ang[m])
    return whole + 0.5 * (tq[k] + at) * (x - ang[k])


@njit(**INLINE)
def spring_table_energy(p, j, i, x):
    """Return the integral of coordinate i of joint j's spring table from 0 to x (its energy);
    0 without one."""
    a0, a1 = p.table_offsets[3 * j + i], p.table_offsets[3 * j + i + 1]
    if a1 - a0 < 2:
        return 0.0
    return table_integral(p, a0, a1, x) - table_integral(p, a0, a1, 0.0)


@njit(**INLINE)
def free_joint(p, j):
    """Return whether joint j has neither friction nor dampers on any of its coordinates."""
    held = 0.0
    for i in range(p.dofs[j]):
        held += p.static[j, i] + p.kinetic[j, i] + p.damping[j, i]
    return held == 0.0


@njit(**INLINE)
def axis_constants(p, j, i, inv_dt):
    """Return coordinate i of joint j's constants as settle_hinge takes them: (spring, rest,
    damper / dt, lower, upper, its spring table's first and end offsets)."""
    return (p.stiffness[j, i], p.rest[j, i], p.damping[j, i] * inv_dt, p.lower[j, i], p.upper[j, i],
            p.table_offsets[3 * j + i], p.table_offsets[3 * j + i + 1])


@njit(**INNER)
def axis_balance(c, ang, tq, q, x, prev, fric):
    """Return (g, spring, slope) of a coordinate of constants c (axis_constants) at x given the
    line's generalised torque q on it: g = Q_i - f_i (the module's equation), the springs' and
    damper's part of the Newton diagonal, and the spring table's slope there."""
    table, slope = table_torque(ang, tq, c[5], c[6], x)
    g = q - c[0] * (x - c[1]) - table - c[2] * (x - prev) - fric
    return g, c[0] + max(slope, 0.0) + c[2], slope


@njit(**INLINE)
def coordinate_balance(p, j, i, moves, col, tau, rel, phi, prev, fric, inv_dt, model):
    """Return (Q_i - f_i, the Newton diagonal) of coordinate i of joint j (module docstring);
    (0, 1) for a coordinate that does not move."""
    if not moves:
        return 0.0, 1.0
    g, spring, _ = axis_balance(axis_constants(p, j, i, inv_dt), p.table_angle, p.table_torque, dot3(col, tau), phi,
                                prev, fric)
    return g, axis_stiffness(p, j, model, rel, col, col) + spring


@njit(**INLINE)
def coupling(p, j, model, rel, both, ci, ck):
    """Return the Newton off-diagonal of two coordinates that both move (else 0)."""
    return axis_stiffness(p, j, model, rel, ci, ck) if both else 0.0


@njit(**INLINE)
def clamp_step(p, j, i, moves, phi, step):
    """Return coordinate i of joint j after a Newton step, within its limits (unchanged if it
    does not move)."""
    return min(max(phi + step, p.lower[j, i]), p.upper[j, i]) if moves else phi


@njit(**INNER)
def within_cone(p, j, phi):
    """Return a ball joint's coordinates phi (3-tuple) with its d3 brought back within its cone
    (cone_cut); other joints' coordinates as given."""
    if not BALLS or p.dofs[j] != BALL:
        return phi
    return cone_cut(p.cone[j], phi)


@njit(**INNER)
def cone_cut(cone, phi):
    """Return a ball joint's coordinates phi (3-tuple) with its d3 brought back within its cone
    (rad; pi: none) about X's d3 if it has left it: R = swing twist (twist about d3), the
    swing's angle cut to the cone's, its axis and the twist kept."""
    if not cone < math.pi:
        return phi
    r = quat_exp(phi[0], phi[1], phi[2])
    dx, dy, dz = quat_rotate(r[0], r[1], r[2], r[3], 0.0, 0.0, 1.0)
    tilt = math.acos(min(max(dz, -1.0), 1.0))
    if tilt <= cone:
        return phi
    size = math.sqrt(dx * dx + dy * dy)
    nx, ny = (-dy / size, dx / size) if size > 0.0 else (1.0, 0.0)   # e3 x d, normalised
    sw = quat_exp(tilt * nx, tilt * ny, 0.0)
    tw = quat_mul(sw[0], -sw[1], -sw[2], -sw[3], r[0], r[1], r[2], r[3])
    cut = quat_exp(cone * nx, cone * ny, 0.0)
    q = quat_mul(cut[0], cut[1], cut[2], cut[3], tw[0], tw[1], tw[2], tw[3])
    return quat_log(q[0], q[1], q[2], q[3])


@njit(**INNER)
def boundary_turn(f, q, start, il, u0, bend, r):
    """Return (theta, cc, c2, m, rel, e) at a joint's boundary Voronoi point given the end
    frame F (quaternion f), the end element's q, whether the joint is at the line's start, the
    point's 1/L, rest curvature u0 and stiffness B, and R (quaternion): theta the rotation
    vector from its left frame to its right one (G = F R to E at a line's start, e = -1; E to
    G at its end, e = 1), cc and c2 = d cc / d |theta|^2 of the inverse Jacobians
    (bend_torques), its moment m = B (theta/L - u0) and rel = G^T E. (Scalars, not the
    records: a call passes these in registers where the records would take hundreds of
    arguments.)"""
    (tx, ty, tz), cc, (rw, rx, ry, rz), small, rel = boundary_rotation(f, q, start, r)
    t2 = tx * tx + ty * ty + tz * tz
    if small:
        c2 = small_rate(t2)
    else:   # d/d t^2 of cc = 1/t^2 - w/(2 t s), s = sin(t/2) = |r_vec|, w = cos(t/2)
        s2 = rx * rx + ry * ry + rz * rz
        ts = math.sqrt(t2 * s2)
        c2 = -1.0 / (t2 * t2) + 1.0 / (8.0 * t2 * s2) + rw / (4.0 * t2 * ts)
    return (tx, ty, tz), cc, c2, boundary_moment((tx, ty, tz), il, u0, bend), rel, (-1.0 if start else 1.0)


@njit(**INLINE)
def boundary_point(p, j, model, state, f):
    """Return (F, q, start, 1/L, u0, B) of joint j's boundary Voronoi point (boundary_turn's
    arguments but R), as tuples, given its end frame F = f (end_frame)."""
    a = p.attach[j]
    k = model.attach_vertex[a]
    q, u0, bend = state.q[model.attach_element[a]], model.voronoi_rest_curvature[k], p.bend[j]
    return (f, (q[0], q[1], q[2], q[3]), a % 2 == 0, model.voronoi_inv_rest_length[k],
            (u0[0], u0[1], u0[2]), (bend[0], bend[1], bend[2]))


@njit(**INNER)
def settle_hinge(point, a, c, ang, tq, x, prev, fric):
    """Return (phi, node torque, tau_E) of a hinge by Newton's method
    from x: the coordinate where its loads balance, the torque on the node (X's components)
    and the body torque on the end element; point: its boundary point (boundary_point), a its
    axis, c its coordinate's constants (axis_constants), ang / tq the spring tables. With
    w = J a (J the inverse Jacobian of the boundary point on the joint frame's side,
    inverse_jacobian) the generalised torque is Q = -e w . m, its derivative
    -(D_w J a . m + w^T B w / L), and the end element's torque tau_E = e J m changes by
    D_w J m + J B w / L per radian (jacobian_rate). A step is first taken with the leading
    term w^T B w / L, which ends the iteration below NEWTON_TOL as settle_joint's does; a
    larger one is taken again with the exact derivative, and if below ONE_STEP without
    evaluating again: tau_E carried along it to first order (carried_torque), the node
    receiving its opposite (node_torque), both within O(step^2) of their values at the
    balance. (Where the spring table's slope is negative, the exact derivative is not used.
    A hinge held by its friction does not come here: settle_axes.)"""
    f, q, start, il, u0, bend = point
    for it in range(NEWTON_STEPS):
        r = quat_exp(x * a[0], x * a[1], x * a[2])
        t, cc, c2, m, rel, e = boundary_turn(f, q, start, il, u0, bend, r)
        w, bw, torque, lead, soft = hinge_terms(t, cc, c2, e, m, a, il, bend)
        g, spring, slope = axis_balance(c, ang, tq, torque, x, prev, fric)
        lead += spring
        step = min(max(x + g / lead, c[3]), c[4]) - x
        carried = 0.0
        if abs(step) > NEWTON_TOL and it < NEWTON_STEPS - 1:
            stiff = soft + lead
            if slope < 0.0 or not stiff > 0.0:   # (far from a balance the elastic part may soften)
                x += step
                continue
            step = min(max(x + g / stiff, c[3]), c[4]) - x
            if abs(step) > ONE_STEP:
                x += step
                continue
            carried = step
        node, te = hinge_torques(t, cc, c2, e, m, w, bw, carried, r, rel)
        return x + carried, node, te
    return x, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)   # (not reached: the last iteration returns)


@njit(**INNER)
def settle_universal(point, a, b, c0, c1, ang, tq, phi, prev, moves, fric):
    """Return (phi, node torque, tau_E) of a universal joint of axes a and b, as settle_hinge
    does for a hinge, with its two coordinates (c0, c1 their constants; either may be held by
    its friction: ``moves``). Its first axis exp(-phi_1 b) a turns with the second
    coordinate, d/d phi_1 of it = -b x it, which adds e (J (d/d phi_1 of it)) . m to the
    derivative's coupling of the two."""
    f, q, start, il, u0, bend = point
    m0, m1 = moves[0], moves[1]
    x0, x1 = phi[0], phi[1]
    for it in range(NEWTON_STEPS):
        ra = quat_exp(x0 * a[0], x0 * a[1], x0 * a[2])
        rb = quat_exp(x1 * b[0], x1 * b[1], x1 * b[2])
        r = quat_mul(ra[0], ra[1], ra[2], ra[3], rb[0], rb[1], rb[2], rb[3])
        k0 = quat_rotate_inv(rb[0], rb[1], rb[2], rb[3], a[0], a[1], a[2])   # the first axis in the joint frame
        t, cc, c2, m, rel, e = boundary_turn(f, q, start, il, u0, bend, r)
        w0, w1 = inverse_jacobian(t, cc, e, k0), inverse_jacobian(t, cc, e, b)
        bw0, bw1 = bend_rate(il, bend, w0), bend_rate(il, bend, w1)
        g0, s0, slope0 = axis_balance(c0, ang, tq, -e * dot3(w0, m), x0, prev[0], fric[0])
        g1, s1, slope1 = axis_balance(c1, ang, tq, -e * dot3(w1, m), x1, prev[1], fric[1])
        g0, g1 = (g0 if m0 else 0.0), (g1 if m1 else 0.0)
        a00 = dot3(w0, bw0) + s0 if m0 else 1.0
        a11 = dot3(w1, bw1) + s1 if m1 else 1.0
        a01 = dot3(w0, bw1) if m0 and m1 else 0.0
        step = solve_sym3(a00, a01, 0.0, a11, 0.0, 1.0, g0, g1, 0.0)
        n0 = min(max(x0 + step[0], c0[3]), c0[4]) - x0 if m0 else 0.0
        n1 = min(max(x1 + step[1], c1[3]), c1[4]) - x1 if m1 else 0.0
        d0 = d1 = 0.0
        if max(abs(n0), abs(n1)) > NEWTON_TOL and it < NEWTON_STEPS - 1:
            if m0:
                a00 += dot3(jacobian_rate(t, cc, c2, e, w0, k0), m)
            if m1:
                a11 += dot3(jacobian_rate(t, cc, c2, e, w1, b), m)
            if m0 and m1:
                bk = cross(b[0], b[1], b[2], k0[0], k0[1], k0[2])
                a01 += dot3(jacobian_rate(t, cc, c2, e, w1, k0), m) - e * dot3(inverse_jacobian(t, cc, e, bk), m)
            if (m0 and slope0 < 0.0) or (m1 and slope1 < 0.0) or not (a00 > 0.0 and a00 * a11 > a01 * a01):
                x0, x1 = x0 + n0, x1 + n1
                continue
            step = solve_sym3(a00, a01, 0.0, a11, 0.0, 1.0, g0, g1, 0.0)
            n0 = min(max(x0 + step[0], c0[3]), c0[4]) - x0 if m0 else 0.0
            n1 = min(max(x1 + step[1], c1[3]), c1[4]) - x1 if m1 else 0.0
            if max(abs(n0), abs(n1)) > ONE_STEP:
                x0, x1 = x0 + n0, x1 + n1
                continue
            d0, d1 = n0, n1
        te = inverse_jacobian(t, cc, e, m)
        te = (e * te[0], e * te[1], e * te[2])
        if d0 != 0.0 or d1 != 0.0:
            u = (d0 * w0[0] + d1 * w1[0], d0 * w0[1] + d1 * w1[1], d0 * w0[2] + d1 * w1[2])
            d = carried_torque(t, cc, c2, e, m, u, bend_rate(il, bend, u), 1.0)   # (linear in the direction)
            te = (te[0] + d[0], te[1] + d[1], te[2] + d[2])
        return (x0 + d0, x1 + d1, 0.0), node_torque(r, rel, te), te
    return (x0, x1, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)   # (not reached: the last iteration returns)


@njit(**INNER)
def settle_ball(point, c0, c1, c2, ang, tq, phi, prev, fric, cone):
    """Return (phi, node torque, tau_E) of a ball joint by Newton's method from phi (3-tuple):
    its coordinates where its loads balance, the torque on the node (X's components) and the
    body torque on the end element; point: its boundary point (boundary_point), c0, c1, c2 its
    coordinates' constants (axis_constants), ang / tq the spring tables, ``fric`` the friction's
    generalised torques of a joint that turns (its friction holds all three coordinates or
    none: a held one takes its weighed loads), ``cone`` its cone (rad; pi: none). Each coordinate's body
    axis k_i (joint_math.ball_axes) maps to w_i = J k_i at the boundary point, the generalised
    torque -e w_i . m, and the derivative's leading term w_i^T B w_k / L: settle_hinge's terms
    for three axes that turn with phi. The steps take the leading term, to NEWTON_TOL, as
    settle_joint's do, and the loads are those of the point evaluated last; but where the
    exact derivative (joint_math.ball_exact) gives a step below ONE_STEP, it is taken without
    evaluating again, the loads carried along it to first order, as settle_hinge does. (Taken
    as the iteration's steps beyond that, exact steps left a spinning arm's loose joint 1e-8
    rad from its closed-form balance where leading-term steps left it 1e-9:
    test_loose_ball_joint_settles_in_closed_form_where_the_iteration_does.)"""
    f, q, start, il, u0, bend = point
    x0, x1, x2 = phi
    for it in range(NEWTON_STEPS):
        r = quat_exp(x0, x1, x2)
        k0, k1, k2 = ball_axes(x0, x1, x2)
        t, cc, c2r, m, rel, e = boundary_turn(f, q, start, il, u0, bend, r)
        w0, w1, w2 = inverse_jacobian(t, cc, e, k0), inverse_jacobian(t, cc, e, k1), inverse_jacobian(t, cc, e, k2)
        bw0, bw1, bw2 = bend_rate(il, bend, w0), bend_rate(il, bend, w1), bend_rate(il, bend, w2)
        g0, s0, slope0 = axis_balance(c0, ang, tq, -e * dot3(w0, m), x0, prev[0], fric[0])
        g1, s1, slope1 = axis_balance(c1, ang, tq, -e * dot3(w1, m), x1, prev[1], fric[1])
        g2, s2, slope2 = axis_balance(c2, ang, tq, -e * dot3(w2, m), x2, prev[2], fric[2])
        a00, a11, a22 = dot3(w0, bw0) + s0, dot3(w1, bw1) + s1, dot3(w2, bw2) + s2
        a01, a02, a12 = dot3(w0, bw1), dot3(w0, bw2), dot3(w1, bw2)
        step = solve_sym3(a00, a01, a02, a11, a12, a22, g0, g1, g2)
        n0, n1, n2 = cone_cut(cone, (min(max(x0 + step[0], c0[3]), c0[4]), min(max(x1 + step[1], c1[3]), c1[4]),
                                     min(max(x2 + step[2], c2[3]), c2[4])))
        # balanced where evaluated (a NaN ends it too: the watch reports it)
        if not max(abs(n0 - x0), abs(n1 - x1), abs(n2 - x2)) > NEWTON_TOL or it == NEWTON_STEPS - 1:
            break
        if cone < math.pi or slope0 < 0.0 or slope1 < 0.0 or slope2 < 0.0:   # (a cut step carries nothing)
            x0, x1, x2 = n0, n1, n2
            continue
        h = ball_exact(t, cc, c2r, e, m, (x0, x1, x2), (k0, k1, k2), (w0, w1, w2))   # the exact derivative
        a00, a11, a22, a01, a02, a12 = a00 + h[0], a11 + h[1], a22 + h[2], a01 + h[3], a02 + h[4], a12 + h[5]
        if not positive_sym3(a00, a01, a02, a11, a12, a22):
            x0, x1, x2 = n0, n1, n2
            continue
        step = solve_sym3(a00, a01, a02, a11, a12, a22, g0, g1, g2)
        d0 = min(max(x0 + step[0], c0[3]), c0[4]) - x0
        d1 = min(max(x1 + step[1], c1[3]), c1[4]) - x1
        d2 = min(max(x2 + step[2], c2[3]), c2[4]) - x2
        if max(abs(d0), abs(d1), abs(d2)) > ONE_STEP:
            x0, x1, x2 = n0, n1, n2
            continue
        te = inverse_jacobian(t, cc, e, m)
        u = (d0 * w0[0] + d1 * w1[0] + d2 * w2[0], d0 * w0[1] + d1 * w1[1] + d2 * w2[1],
             d0 * w0[2] + d1 * w1[2] + d2 * w2[2])
        d = carried_torque(t, cc, c2r, e, m, u, bend_rate(il, bend, u), 1.0)   # (linear in the direction)
        te = (e * te[0] + d[0], e * te[1] + d[1], e * te[2] + d[2])
        return (x0 + d0, x1 + d1, x2 + d2), node_torque(r, rel, te), te
    te = inverse_jacobian(t, cc, e, m)
    te = (e * te[0], e * te[1], e * te[2])
    return (x0, x1, x2), node_torque(r, rel, te), te


@njit(**INLINE)
def start_joint(p, j, model, state, dt, f):
    """Return (phi^-, moves, friction, phi, 1/dt, held) of joint j, its end frame f
    (settle_joint): its coordinates at the last evaluation, dt before this one; whether each
    may move and the friction torque it then meets; where its Newton iteration starts, those
    carried on at their last rate; and where the friction was weighed at phi^- (a joint with
    friction or a damper), what was found there (whether, the torque on the node, R tau_G, and
    tau_E): the joint's loads if no coordinate moves (settle_axes, settle_joint, settled)."""
    prev = (p.phi[j, 0], p.phi[j, 1], p.phi[j, 2])
    n = p.dofs[j]
    held = (False, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    if not HELD or free_joint(p, j):   # every coordinate moves: no torque to compare with a friction
        m0, m1, m2, f0, f1, f2 = n > 0, n > 1, n > 2, 0.0, 0.0, 0.0
    elif BALLS and n == BALL:
        m0, f0, f1, f2, torque, te = start_turning(p, j, model, state, f, prev, dt)
        m1, m2 = m0, m0
        held = (True, torque, te)
    else:
        r, c0, c1, c2 = joint_turn(p, j, prev)
        tau, te, _, _, _ = boundary_torques(p, j, model, state, f, r)
        held = (True, quat_rotate(r[0], r[1], r[2], r[3], tau[0], tau[1], tau[2]), te)
        m0, f0 = start_motion(p, j, 0, dot3(c0, tau), prev, dt)
        m1, f1 = start_motion(p, j, 1, dot3(c1, tau), prev, dt)
        m2, f2 = start_motion(p, j, 2, dot3(c2, tau), prev, dt)
    inv_dt = 1.0 / dt if dt > 0.0 else 0.0
    # start from the coordinates carried on at their last rate: Newton then needs a step or two
    ahead = dt if dt > 0.0 else 0.0
    phi = within_cone(p, j, (clamp_step(p, j, 0, m0, prev[0], ahead * p.rate[j, 0]),
                             clamp_step(p, j, 1, m1, prev[1], ahead * p.rate[j, 1]),
                             clamp_step(p, j, 2, m2, prev[2], ahead * p.rate[j, 2])))
    return prev, (m0, m1, m2), (f0, f1, f2), phi, inv_dt, held


@njit(**INNER)
def settle_joint(p, j, model, state, dt, f):
    """Return (phi, friction, moves, torque, tau_E) of joint j, its end frame f: its
    coordinates where its loads balance (the module's equation) from phi^- = p.phi[j] after
    dt, the friction torque on each and whether each moves (3-tuples), and at phi the torque
    on the node through the joint (X's components: R tau_G) and the body torque on the end
    element, by Newton's method with the leading term of the derivative (the energy and the
    fields settle every joint so; the load kernel a hinge or universal joint by settle_axes, a
    ball joint by settle_ball)."""
    prev, moves, fric, phi, inv_dt, held = start_joint(p, j, model, state, dt, f)
    m0, m1, m2 = moves
    f0, f1, f2 = fric
    if held[0] and not (m0 or m1 or m2):   # held where it was: its loads are the friction check's
        return prev, fric, moves, held[1], held[2]
    for it in range(NEWTON_STEPS):
        r, c0, c1, c2 = joint_turn(p, j, phi)
        tau, te, _, _, rel = boundary_torques(p, j, model, state, f, r)
        g0, a00 = coordinate_balance(p, j, 0, m0, c0, tau, rel, phi[0], prev[0], f0, inv_dt, model)
        g1, a11 = coordinate_balance(p, j, 1, m1, c1, tau, rel, phi[1], prev[1], f1, inv_dt, model)
        g2, a22 = coordinate_balance(p, j, 2, m2, c2, tau, rel, phi[2], prev[2], f2, inv_dt, model)
        a01 = coupling(p, j, model, rel, m0 and m1, c0, c1)
        a02 = coupling(p, j, model, rel, m0 and m2, c0, c2)
        a12 = coupling(p, j, model, rel, m1 and m2, c1, c2)
        s = solve_sym3(a00, a01, a02, a11, a12, a22, g0, g1, g2)
        new = within_cone(p, j, (clamp_step(p, j, 0, m0, phi[0], s[0]), clamp_step(p, j, 1, m1, phi[1], s[1]),
                                 clamp_step(p, j, 2, m2, phi[2], s[2])))
        size = max(abs(new[0] - phi[0]), abs(new[1] - phi[1]), abs(new[2] - phi[2]))
        # balanced where evaluated (a NaN ends it too: the watch reports it); the result is
        # always the point evaluated, so R and the torques belong to it
        if not size > NEWTON_TOL or it == NEWTON_STEPS - 1:
            break
        phi = new
    return phi, fric, moves, quat_rotate(r[0], r[1], r[2], r[3], tau[0], tau[1], tau[2]), te


@njit(**INLINE)
def settle_axes(p, j, model, state, dt, f):
    """Return settle_joint's values for hinge or universal joint j, its end frame f, by
    settle_hinge or settle_universal (a coordinate held by its friction does not move; a
    joint held whole takes the loads its friction was weighed with, at the same angles).
    (Inlined into the load kernel's loop, as start_joint is into it and into settle_joint: a
    call passing the records passes hundreds of arguments, about 40 ns a joint where LLVM
    does not inline it, and settle_joint with these in it was too long for LLVM to; the
    turning joints' functions take numbers, which a call passes in registers.)"""
    prev, moves, fric, phi, inv_dt, held = start_joint(p, j, model, state, dt, f)
    if held[0] and not (moves[0] or moves[1]):   # held where it was: its loads are the friction check's
        return phi, fric, moves, held[1], held[2]
    a, point = p.axis_a[j], boundary_point(p, j, model, state, f)
    if p.dofs[j] == HINGE:
        x, torque, te = settle_hinge(point, (a[0], a[1], a[2]), axis_constants(p, j, 0, inv_dt), p.table_angle,
                                     p.table_torque, phi[0], prev[0], fric[0])
        return (x, phi[1], phi[2]), fric, moves, torque, te
    b = p.axis_b[j]
    x, torque, te = settle_universal(point, (a[0], a[1], a[2]), (b[0], b[1], b[2]), axis_constants(p, j, 0, inv_dt),
                                     axis_constants(p, j, 1, inv_dt), p.table_angle, p.table_torque, phi, prev,
                                     (moves[0], moves[1]), (fric[0], fric[1]))
    return x, fric, moves, torque, te


@njit(**INLINE)
def loose_ball(p, j):
    """Return whether ball joint j turns freely but for its cone: no spring, spring table,
    damper, friction or limit."""
    held = 0.0
    for i in range(3):
        held += abs(p.stiffness[j, i]) + p.static[j, i] + p.kinetic[j, i] + p.damping[j, i]
        held += 0.0 if p.lower[j, i] == -math.inf and p.upper[j, i] == math.inf else 1.0
    return held == 0.0 and p.table_offsets[3 * j + 3] == p.table_offsets[3 * j]


@njit(**INLINE)
def settled(p, j, model, state, dt, f):
    """Return settle_joint's values for joint j, its end frame f, as the load kernel settles
    it: settle_axes for a hinge or a universal joint, the iteration for a ball joint, and a
    loose ball joint in closed form where it balances within its cone (loose_turn: its
    boundary point then passes no torque, to the line end or the node). (The energy and the
    fields take the iteration for every kind: articulation_energy.)"""
    if BALLS and p.dofs[j] == BALL:
        if loose_ball(p, j):
            _, q, start, il, u0, _ = boundary_point(p, j, model, state, f)
            phi, within = loose_turn(f, q, start, il, u0, (p.phi[j, 0], p.phi[j, 1], p.phi[j, 2]),
                                     cone_cosine(p.cone[j]))
            if within:
                zero = (0.0, 0.0, 0.0)
                return phi, zero, (True, True, True), zero, zero
        prev, moves, fric, phi, inv_dt, held = start_joint(p, j, model, state, dt, f)
        if held[0] and not moves[0]:   # held where it was: its loads are the friction check's
            return prev, fric, moves, held[1], held[2]
        x, torque, te = settle_ball(boundary_point(p, j, model, state, f), axis_constants(p, j, 0, inv_dt),
                                    axis_constants(p, j, 1, inv_dt), axis_constants(p, j, 2, inv_dt), p.table_angle,
                                    p.table_torque, phi, prev, fric, p.cone[j])
        return x, fric, moves, torque, te
    return settle_axes(p, j, model, state, dt, f)


@load_kernel(ArticulationParams)
@njit(**CACHED)
def add_articulations(p, model, state, loads):
    """Update loads.tau at the end elements and loads.end_tau at the articulated line ends
    given the state: each joint settles where its loads balance (module docstring), then its
    boundary Voronoi point bends between the joint frame and the end element (3.22)/(3.24);
    p.phi, rate, sliding, reaction, last and dissipated follow."""
    dt = state.clock[0] - p.last[0]
    inv_dt = 1.0 / dt if dt > 0.0 else 0.0   # (no rate, no damper's work, over no time)
    p.last[0] = state.clock[0]
    spent = 0.0
    L = p.lanes
    C = p.lane_constants
    W = L[WEIGHED:UNIVERSALS]   # (rows of their own: LLVM then needs no test of their overlap with the others)
    pinned = False   # whether the hinges' friction held so many that settle_hinges did not run
    if PINS:
        if HELD:
            weigh_hinges(p, model, state, dt, W)
            turning = 0
            for j in range(p.attach.shape[0]):
                turning += (C[C_HINGE, j] != 0.0) & (W[W_MOVES, j] != 0.0)
            pinned = turning * TURNING_SHARE < C.shape[1]
        if pinned:   # the held ones as weighed, the few that turn by the scalar iteration (TURNING_SHARE)
            L[OK, :] = 0.0
        else:
            settle_hinges(p, model, state, dt, L, W)
    if LOOSE:
        settle_balls(p, model, state, L)
    U = L[UNIVERSALS:GRIPPED]
    if CARDANS:
        settle_universals(p, model, state, dt, U)
    H, S = L[GRIPPED:SOCKETED], L[SOCKETED:]
    if GRIPS:
        weigh_balls(p, model, state, dt, H)
    if SOCKETS:
        turning = 0
        for j in range(p.attach.shape[0]):
            turning += (C[C_SOCKET, j] != 0.0) & ((C[C_HELD, j] == 0.0) | (H[G_OK, j] == AHEAD))
        if turning * TURNING_SHARE >= C.shape[1]:
            settle_sockets(p, model, state, dt, S, H)
        else:   # the few that turn by the scalar iteration (TURNING_SHARE)
            S[S_OK, :] = 0.0
    for j in range(p.attach.shape[0]):
        a = p.attach[j]
        e = model.attach_element[a]
        zero = (0.0, 0.0, 0.0)
        if LOOSE and L[BALL_OK, j] == SETTLED:   # in closed form: no torque
            phi, fric, moves, (tx, ty, tz), te = (L[TURN, j], L[TURN + 1, j], L[TURN + 2, j]), zero, \
                (True, True, True), zero, zero
            lab = zero
        elif PINS and L[OK, j] == SETTLED:   # a hinge's other coordinates stay where they are
            phi, fric, moves = (L[PHI, j], p.phi[j, 1], p.phi[j, 2]), (L[FRIC, j], 0.0, 0.0), \
                (L[MOVES, j] != 0.0, False, False)
            (tx, ty, tz), te, lab = lane_loads(L, NODE, j)
        elif PINS and HELD and pinned and (C[C_HINGE, j] != 0.0) & (W[W_MOVES, j] == 0.0) & (W[W_OK, j] != 0.0):
            # a hinge its friction holds, as weigh_hinges weighed it (settle_hinges' values there)
            phi, fric, moves = (p.phi[j, 0], p.phi[j, 1], p.phi[j, 2]), (W[W_FRIC, j], 0.0, 0.0), \
                (False, False, False)
            (tx, ty, tz), te, lab = lane_loads(W, W_NODE, j)
        elif GRIPS and H[G_OK, j] == SETTLED:   # held by its friction where it was
            phi, fric, moves = (p.phi[j, 0], p.phi[j, 1], p.phi[j, 2]), zero, (False, False, False)
            (tx, ty, tz), te, lab = lane_loads(H, G_NODE, j)
        elif SOCKETS and S[S_OK, j] == SETTLED:   # turning, against the friction weighed (if any)
            phi, moves = (S[S_PHI, j], S[S_PHI + 1, j], S[S_PHI + 2, j]), (True, True, True)
            fric = (H[G_FRIC, j], H[G_FRIC + 1, j], H[G_FRIC + 2, j]) if C[C_HELD, j] != 0.0 else zero
            (tx, ty, tz), te, lab = lane_loads(S, S_NODE, j)
        elif CARDANS and U[U_OK, j] == SETTLED:   # the third coordinate stays 0
            phi, fric = (U[U_PHI, j], U[U_PHI + 1, j], 0.0), (U[U_FRIC, j], U[U_FRIC + 1, j], 0.0)
            moves = (U[U_MOVES, j] != 0.0, U[U_MOVES + 1, j] != 0.0, False)
            (tx, ty, tz), te, lab = lane_loads(U, U_NODE, j)
        else:
            f = end_frame(model, state, a)   # (once: the balance and the reaction both take it)
            if PINS and L[OK, j] == AHEAD:   # on from the lanes' Newton step, as settle_axes would go
                ax = p.axis_a[j]
                x, (tx, ty, tz), te = settle_hinge(boundary_point(p, j, model, state, f), (ax[0], ax[1], ax[2]),
                                                   axis_constants(p, j, 0, inv_dt), p.table_angle, p.table_torque,
                                                   L[PHI, j], p.phi[j, 0], L[FRIC, j])
                phi, fric, moves = (x, p.phi[j, 1], p.phi[j, 2]), (L[FRIC, j], 0.0, 0.0), (True, False, False)
            elif SOCKETS and S[S_OK, j] == AHEAD:   # on from the lanes' Newton step, as settled would go
                fric = (H[G_FRIC, j], H[G_FRIC + 1, j], H[G_FRIC + 2, j]) if C[C_HELD, j] != 0.0 else zero
                moves = (True, True, True)
                phi, (tx, ty, tz), te = settle_ball(
                    boundary_point(p, j, model, state, f), axis_constants(p, j, 0, inv_dt),
                    axis_constants(p, j, 1, inv_dt), axis_constants(p, j, 2, inv_dt), p.table_angle, p.table_torque,
                    (S[S_PHI, j], S[S_PHI + 1, j], S[S_PHI + 2, j]), (p.phi[j, 0], p.phi[j, 1], p.phi[j, 2]), fric,
                    p.cone[j])
            elif CARDANS and U[U_OK, j] == AHEAD:   # on from the lanes' Newton step, as settle_axes would go
                ax, bx = p.axis_a[j], p.axis_b[j]
                fric = (U[U_FRIC, j], U[U_FRIC + 1, j], 0.0)
                moves = (U[U_MOVES, j] != 0.0, U[U_MOVES + 1, j] != 0.0, False)
                phi, (tx, ty, tz), te = settle_universal(
                    boundary_point(p, j, model, state, f), (ax[0], ax[1], ax[2]), (bx[0], bx[1], bx[2]),
                    axis_constants(p, j, 0, inv_dt), axis_constants(p, j, 1, inv_dt), p.table_angle, p.table_torque,
                    (U[U_PHI, j], U[U_PHI + 1, j], 0.0), (p.phi[j, 0], p.phi[j, 1], p.phi[j, 2]),
                    (moves[0], moves[1]), (fric[0], fric[1]))
            else:
                phi, fric, moves, (tx, ty, tz), te = settled(p, j, model, state, dt, f)
            lab = quat_rotate(f[0], f[1], f[2], f[3], tx, ty, tz)
        loads.tau[e, 0] += te[0]
        loads.tau[e, 1] += te[1]
        loads.tau[e, 2] += te[2]
        loads.end_tau[a, 0] += tx
        loads.end_tau[a, 1] += ty
        loads.end_tau[a, 2] += tz
        p.reaction[j, 0], p.reaction[j, 1], p.reaction[j, 2] = lab
        for i in range(3):
            turned = phi[i] - p.phi[j, i]
            if moves[i]:
                spent += p.damping[j, i] * turned * turned * inv_dt
            spent += fric[i] * turned     # the friction's work: it turns with the motion
            p.rate[j, i] = turned * inv_dt
            p.phi[j, i] = phi[i]
            p.sliding[j, i] = 1.0 if moves[i] and p.kinetic[j, i] != 0.0 else 0.0
    p.dissipated[0] += spent


@njit(**ENTRY)
def articulation_energy(p, model, state):
    """Return the bending energy of the articulated ends' boundary Voronoi points, L/2 kappa^T
    B kappa, plus the joints' springs, k (phi - phi0)^2 / 2 and the integral of their tables'
    torque from 0, with each joint settled where the next evaluation of the loads will settle
    it (nothing is stored), by settle_joint's iteration for every kind (a hinge's or universal
    joint's exact step, settle_axes, ends within the iteration's tolerance of the same
    balance, where the energy is stationary: the two differ by its square)."""
    dt = state.clock[0] - p.last[0]
    total = 0.0
    for j in range(p.attach.shape[0]):
        f = end_frame(model, state, p.attach[j])
        phi = settle_joint(p, j, model, state, dt, f)[0]
        r = joint_turn(p, j, phi)[0]
        _, _, kappa, m, _ = boundary_torques(p, j, model, state, f, r)
        k = model.attach_vertex[p.attach[j]]
        total += 0.5 * dot3(kappa, m) / model.voronoi_inv_rest_length[k]
        for i in range(3):
            total += 0.5 * p.stiffness[j, i] * (phi[i] - p.rest[j, i]) ** 2 + spring_table_energy(p, j, i, phi[i])
    return total


@njit(**ENTRY)
def articulation_fields(p, model, state, frames, moments, strains):
    """Update frames (k, 4), moments (k, 3) and strains (k, 3) with each articulated end's
    joint frame G, the internal torque m = G B kappa at its boundary point (lab) and kappa =
    theta/L - u0 (3.22), each joint settled as articulation_energy settles it."""
    dt = state.clock[0] - p.last[0]
    for j in range(p.attach.shape[0]):
        f = end_frame(model, state, p.attach[j])
        phi = settle_joint(p, j, model, state, dt, f)[0]
        r = joint_turn(p, j, phi)[0]
        _, _, kappa, m, _ = boundary_torques(p, j, model, state, f, r)
        g = quat_mul(f[0], f[1], f[2], f[3], r[0], r[1], r[2], r[3])
        frames[j, 0], frames[j, 1], frames[j, 2], frames[j, 3] = g
        moments[j, 0], moments[j, 1], moments[j, 2] = quat_rotate(g[0], g[1], g[2], g[3], m[0], m[1], m[2])
        strains[j, 0], strains[j, 1], strains[j, 2] = kappa


VARIANTS = Variants(ArticulationParams, lambda: (sys.modules[__name__], joint_lanes), OPTIONS,
                    lambda cls, kernels: load_kernel(cls)(kernels["add_articulations"]), __name__)


def articulation_record(p):
    """``p`` (an ArticulationParams) as the record of the variant its joints need, sharing its
    arrays."""
    k = p.attach.shape[0]
    balls = bool(np.any(p.dofs == BALL))
    held = not all(free_joint.py_func(p, j) for j in range(k))
    pins, loose, cardans, grips, sockets = (k >= LANE_MIN and bool(np.any(p.lane_constants[row] != 0.0))
                                            for row in (C_HINGE, C_LOOSE, C_UNIVERSAL, C_GRIP, C_SOCKET))
    return VARIANTS.record(p, (balls, held, pins, loose, cardans, grips, sockets))


__getattr__ = VARIANTS.module_getattr   # a variant's record class by its name, as pickle looks for it

