"""A net's hinges, universal joints and ball joints settled all at once, in lanes.

Branch-free loops over rows of one number a joint, which LLVM runs in vector lanes (all but
settle_universals); kernels/articulation.py's module docstring says how, and which joints go
on to its scalar path: weigh_hinges, settle_hinges, settle_universals, settle_balls,
weigh_balls and settle_sockets, whose rows the load kernel reads, and the rows of constants
they read (lane_tables)."""


import numpy as np
from numba import njit

from .backend import PASS
from .compiler import INLINE
from .joint_math import BALL, HINGE, NEWTON_TOL, ONE_STEP, UNIVERSAL, ball_axes, ball_exact, ball_weighed, \
    bend_rate, boundary_moment, boundary_pair, boundary_quat, carried_torque, dot3, friction_weighed, hinge_terms, \
    hinge_torques, inverse_jacobian, jacobian_rate, loose_turn, node_torque, positive_sym3, small_rate
from .rotations import axis_quat, cross, quat_exp, quat_mul, quat_rotate, quat_rotate_inv, small_rotation, solve_sym3

# rows of p.lanes (settle_hinges): whether the joint settled there, its coordinate, the torques
# on its node (X's components) and end element, the first in the lab (NODE, TAU_E and LAB, and
# each block's like rows below, in turn: put_loads), its friction torque and whether it moved
OK, PHI, NODE, TAU_E, LAB, FRIC, MOVES = 0, 1, 2, 5, 8, 11, 12
# and of settle_balls: whether the joint settled there, its coordinates
BALL_OK, TURN = 13, 14
# and of weigh_hinges (from WEIGHED on: a block settle_hinges reads while writing the rows above)
WEIGHED = 17
W_OK, W_MOVES, W_FRIC, W_NODE, W_TAU_E, W_LAB = 0, 1, 2, 3, 6, 9
# and of settle_universals (from UNIVERSALS on, a block of its own): whether the joint settled
# there, its two coordinates, the torques on its node and end element, the first in the lab,
# each coordinate's friction torque and whether it moved
UNIVERSALS = 29
U_OK, U_PHI, U_NODE, U_TAU_E, U_LAB, U_FRIC, U_MOVES = 0, 1, 3, 6, 9, 12, 14
# and of weigh_balls (from GRIPPED on): whether the joint's friction holds it there, the torques on
# its node and end element, the first in the lab, the friction's generalised torques
GRIPPED = 45
G_OK, G_NODE, G_TAU_E, G_LAB, G_FRIC = 0, 1, 4, 7, 10
# and of settle_sockets (from SOCKETED on): whether the joint settled there, its coordinates, the
# torques on its node and end element, the first in the lab
SOCKETED = 58
S_OK, S_PHI, S_NODE, S_TAU_E, S_LAB = 0, 1, 4, 7, 10
LANE_ROWS = 71
SETTLED, AHEAD = 1.0, 2.0   # in rows OK, BALL_OK, UNIVERSALS + U_OK, GRIPPED + G_OK and SOCKETED + S_OK
# rows of p.lane_constants (lane_tables): the joints' constants the lanes read, a row for each
# number (kernels/articulation.py's docstring says why); C_CONE holds cone_cosine; C_AXIS_B and
# the rows ending in 1, a universal joint's second axis and coordinate
C_AXIS, C_BEND, C_LOWER, C_UPPER, C_SPRING, C_REST, C_HINGE, C_IL, C_U0, C_FRAME, C_START, C_LOOSE, C_CONE = \
    0, 3, 6, 7, 8, 9, 10, 11, 12, 15, 19, 20, 21
C_DAMPER, C_STATIC, C_KINETIC = 22, 23, 24
C_AXIS_B, C_LOWER1, C_UPPER1, C_SPRING1, C_REST1, C_UNIVERSAL = 25, 28, 29, 30, 31, 32
C_DAMPER1, C_STATIC1, C_KINETIC1 = 33, 34, 35
C_HELD = 36   # not free_joint: some coordinate of the joint has friction or a damper
# a ball joint's third coordinate's spring, its dampers' sum, and the mark of a ball joint with
# friction or a damper and no spring table (weigh_balls)
C_SPRING2, C_REST2, C_DAMPERS, C_GRIP = 37, 38, 39, 40
# the third coordinate's damper, and the mark of a ball joint that is not loose, without a spring
# table or a cone (settle_sockets)
C_DAMPER2, C_SOCKET = 41, 42
LANE_CONSTANTS = 43

HELD = True   # kernels/articulation.py's option: some joint has friction or a damper
# The lanes' rows hold the joints padded to a whole number of vector widths, the last joint
# repeated: a loop over fewer than a width ran its scalar remainder alone, which cost more than
# the scalar path. Padded, a net of a few joints pays for a whole vector, about what the scalar
# path costs three joints: nets of fewer than LANE_MIN joints keep to it. (A chain of free
# hinges, per joint a step, padded lanes against the scalar path: 1 joint 331 ns against 165, 3
# joints 134 against 130, 6 joints 77 against 115, 10 joints 55 against 96; unpadded, 6 joints
# took 125.)
LANE_WIDTH = 8
LANE_MIN = 4
# settle_hinges and settle_sockets run where at least one joint in TURNING_SHARE of the lanes'
# columns turns: their vector loops take every column, held joints too, where the scalar
# iteration takes only those that turn, each about five columns' cost (a chain of 100 ball
# joints with springs: 17-18 ns a joint in lanes, 84-88 by the scalar iteration; with friction,
# which holds 98 % of them, the lanes added 17 ns a joint to the step)
TURNING_SHARE = 5


def lane_count(k: int) -> int:
    """The columns of the lanes' rows for k joints: k padded to a multiple of LANE_WIDTH."""
    return -(-k // LANE_WIDTH) * LANE_WIDTH


@njit(**INLINE)
def put_loads(out, row, j, f, node, te):
    """Write column j's torques on the node (X's components) and on the end element, and the
    first in the lab (F node: the reaction), to out's rows row.. row + 8 (lane_loads reads them)."""
    out[row, j], out[row + 1, j], out[row + 2, j] = node
    out[row + 3, j], out[row + 4, j], out[row + 5, j] = te
    out[row + 6, j], out[row + 7, j], out[row + 8, j] = quat_rotate(f[0], f[1], f[2], f[3], node[0], node[1], node[2])


@njit(**INLINE)
def lane_loads(rows, row, j):
    """Return (node torque, tau_E, reaction) of column j as put_loads wrote them from row on."""
    return ((rows[row, j], rows[row + 1, j], rows[row + 2, j]), (rows[row + 3, j], rows[row + 4, j], rows[row + 5, j]),
            (rows[row + 6, j], rows[row + 7, j], rows[row + 8, j]))


@njit(**PASS)
def weigh_hinges(p, model, state, dt, out):
    """Update out (UNIVERSALS - WEIGHED, k) for every joint by the friction of a hinge without a
    spring table weighed at phi^- (start_joint, start_motion), in vector lanes: rows W_MOVES
    and W_FRIC whether it may move and the friction torque it then meets (1.0 and 0.0 for a
    hinge without friction or a damper), W_NODE (3), W_TAU_E (3) and W_LAB (3) the torques on
    the node and the end element at phi^-, the first in the lab (the loads of a hinge its
    friction holds), and W_OK whether its boundary point there turns by less than 0.2 rad
    (settle_hinges reads them, and the load kernel where settle_hinges does not run)."""
    C, ends, n = p.lane_constants, p.lane_ends, p.attach.shape[0]
    phi, sliding = p.phi.reshape(3 * n), p.sliding.reshape(3 * n)
    for j in range(C.shape[1]):
        i = 3 * min(j, n - 1)   # (a padding column: the last joint's state)
        nq, q = state.node_q[ends[0, j]], state.q[ends[1, j]]
        f = quat_mul(nq[0], nq[1], nq[2], nq[3], C[C_FRAME, j], C[C_FRAME + 1, j], C[C_FRAME + 2, j], C[C_FRAME + 3, j])
        a, prev, start = (C[C_AXIS, j], C[C_AXIS + 1, j], C[C_AXIS + 2, j]), phi[i], C[C_START, j] != 0.0
        r = axis_quat(prev, a)
        turn, small, _ = boundary_quat(f, q, start, r)
        t = small_rotation(turn[0], turn[1], turn[2], turn[3])
        m = boundary_moment((t[0], t[1], t[2]), C[C_IL, j], (C[C_U0, j], C[C_U0 + 1, j], C[C_U0 + 2, j]),
                            (C[C_BEND, j], C[C_BEND + 1, j], C[C_BEND + 2, j]))
        tau, te = boundary_pair((t[0], t[1], t[2]), t[3], m, start)
        # (& | and == False, not the short-circuit and, or, not: their branches kept the loop
        # out of vector lanes)
        held = C[C_HELD, j] != 0.0
        q0 = dot3(a, tau) - C[C_SPRING, j] * (prev - C[C_REST, j])   # (start_motion's, without a table)
        stays, fric = friction_weighed(q0, C[C_STATIC, j], C[C_KINETIC, j], sliding[i] != 0.0, C[C_DAMPER, j], dt)
        out[W_OK, j] = 1.0 if small | (held == False) else 0.0  # noqa: E712
        out[W_MOVES, j] = 0.0 if held & stays else 1.0
        out[W_FRIC, j] = fric if held else 0.0
        put_loads(out, W_NODE, j, f, quat_rotate(r[0], r[1], r[2], r[3], tau[0], tau[1], tau[2]), te)


@njit(**PASS)
def settle_hinges(p, model, state, dt, out, weighed):
    """Update out (LANE_ROWS, k) for every joint as settle_axes settles a hinge without a spring
    table, its branches taken as selects so that the joints go through it in vector lanes:
    with friction or a damper, as weigh_hinges weighed its friction (``weighed``: its rows),
    and a hinge that moves by settle_hinge's first evaluation. Row OK is SETTLED where that is
    the balance (a hinge its friction holds, or one whose Newton step from its carried
    coordinate ends the iteration or is taken without evaluating again), the boundary points
    turning by less than 0.2 rad: rows PHI, NODE (3), TAU_E (3), LAB (3), FRIC and MOVES then
    hold its coordinate, the torques on the node and the end element, the first in the lab
    (its reaction), the friction torque and whether it moved. It is AHEAD where the exact
    Newton step is too long to carry: row PHI then holds where the step goes, settle_hinge's
    next point (add_articulations goes on from there), and FRIC its friction; elsewhere 0.0,
    and the rows anything, NaN included."""
    C, ends, n = p.lane_constants, p.lane_ends, p.attach.shape[0]
    phi, rate = p.phi.reshape(3 * n), p.rate.reshape(3 * n)
    inv_dt = 1.0 / dt if dt > 0.0 else 0.0
    for j in range(C.shape[1]):
        i = 3 * min(j, n - 1)   # (a padding column: the last joint's state)
        nq, q = state.node_q[ends[0, j]], state.q[ends[1, j]]
        f = quat_mul(nq[0], nq[1], nq[2], nq[3], C[C_FRAME, j], C[C_FRAME + 1, j], C[C_FRAME + 2, j], C[C_FRAME + 3, j])
        a = (C[C_AXIS, j], C[C_AXIS + 1, j], C[C_AXIS + 2, j])
        lo, hi, k0, rest, prev = C[C_LOWER, j], C[C_UPPER, j], C[C_SPRING, j], C[C_REST, j], phi[i]
        start, es = C[C_START, j] != 0.0, (1.0 if C[C_START, j] == 0.0 else -1.0)
        il, b = C[C_IL, j], (C[C_BEND, j], C[C_BEND + 1, j], C[C_BEND + 2, j])
        damper, moves, fric, checked = C[C_DAMPER, j] * inv_dt, True, 0.0, True
        if HELD:   # (a variant's option: kernels/articulation.py) as weigh_hinges found it
            moves, fric, checked = weighed[W_MOVES, j] != 0.0, weighed[W_FRIC, j], weighed[W_OK, j] != 0.0
        x = min(max(prev + dt * rate[i], lo), hi) if moves else prev
        r = axis_quat(x, a)
        turn, small, rel = boundary_quat(f, q, start, r)
        tx, ty, tz, cc = small_rotation(turn[0], turn[1], turn[2], turn[3])
        t = (tx, ty, tz)
        m = boundary_moment(t, il, (C[C_U0, j], C[C_U0 + 1, j], C[C_U0 + 2, j]), b)
        c2 = small_rate(tx * tx + ty * ty + tz * tz)
        w, bw, torque, lead, soft = hinge_terms(t, cc, c2, es, m, a, il, b)
        g = torque - k0 * (x - rest) - 0.0 - damper * (x - prev) - fric   # (axis_balance's, without a table)
        lead += k0 + 0.0 + damper
        step = min(max(x + g / lead, lo), hi) - x
        stiff = soft + lead
        exact = min(max(x + g / stiff, lo), hi) - x
        done = not abs(step) > NEWTON_TOL
        carried = 0.0 if done else exact
        node, te = hinge_torques(t, cc, c2, es, m, w, bw, carried, r, rel)
        if HELD:   # a hinge its friction holds: the loads it was weighed with
            node = node if moves else (weighed[W_NODE, j], weighed[W_NODE + 1, j], weighed[W_NODE + 2, j])
            te = te if moves else (weighed[W_TAU_E, j], weighed[W_TAU_E + 1, j], weighed[W_TAU_E + 2, j])
        fits = C[C_HINGE, j] != 0.0 and checked and (not moves or (small and (done or stiff > 0.0)))
        out[OK, j] = (SETTLED if not moves or done or not abs(exact) > ONE_STEP else AHEAD) if fits else 0.0
        out[PHI, j] = x + carried if moves else prev
        out[FRIC, j], out[MOVES, j] = fric, (1.0 if moves else 0.0)
        # (written out, not put_loads: through it, this loop took a chain of 10 friction hinges
        # from +31 % to +56-65 % over the welded chain)
        out[NODE, j], out[NODE + 1, j], out[NODE + 2, j] = node
        out[TAU_E, j], out[TAU_E + 1, j], out[TAU_E + 2, j] = te
        out[LAB, j], out[LAB + 1, j], out[LAB + 2, j] = quat_rotate(f[0], f[1], f[2], f[3], node[0], node[1], node[2])


@njit(**INLINE)
def lane_point(C, ends, state, j):
    """Return (F, q, start, e, 1/L, B, u0) of column j's boundary Voronoi point from the lanes'
    rows (articulation.boundary_point's, and e = -1 at a line's start, 1 at its end)."""
    nq, qe = state.node_q[ends[0, j]], state.q[ends[1, j]]
    f = quat_mul(nq[0], nq[1], nq[2], nq[3], C[C_FRAME, j], C[C_FRAME + 1, j], C[C_FRAME + 2, j], C[C_FRAME + 3, j])
    return (f, (qe[0], qe[1], qe[2], qe[3]), C[C_START, j] != 0.0, (1.0 if C[C_START, j] == 0.0 else -1.0), C[C_IL, j],
            (C[C_BEND, j], C[C_BEND + 1, j], C[C_BEND + 2, j]), (C[C_U0, j], C[C_U0 + 1, j], C[C_U0 + 2, j]))


# boundary_quat inlined by numba where settle_universals takes it twice: called, LLVM left that
# loop several times slower (130 ns a joint against 24)
turned_boundary = njit(**INLINE)(boundary_quat.py_func)


@njit(**PASS)
def settle_universals(p, model, state, dt, out):
    """Update out (GRIPPED - UNIVERSALS, k) for every joint as settle_axes settles a
    universal joint without a spring table by settle_universal's first evaluation, its
    branches taken as selects (settle_hinges' way for its two coordinates): with friction or
    a damper, each coordinate's friction weighed at phi^- first, as start_joint weighs it (a
    joint held whole is settled there, with the loads it was weighed with). (LLVM keeps this
    loop scalar, which lets one loop take both evaluations; without branches the core still
    overlaps the joints' arithmetic, 19-20 ns a free joint on a chain of 100 where
    settle_universal took about 70; vectorised, with the reaction's rotation in a loop of its
    own, it ran no faster.)
    Row U_OK is SETTLED where that evaluation is the balance (its Newton step ends the
    iteration, or with the exact derivative is taken without evaluating again), the boundary
    points turning by less than 0.2 rad: rows U_PHI (2), U_NODE (3), U_TAU_E (3), U_LAB (3),
    U_FRIC (2) and U_MOVES (2) then hold its coordinates, the torques on the node and the end
    element, the first in the lab, the friction torques and whether each coordinate moved;
    AHEAD where the iteration goes on (U_PHI: settle_universal's next point; U_FRIC, U_MOVES as
    weighed); elsewhere 0.0, and the rows anything."""
    C, ends, n = p.lane_constants, p.lane_ends, p.attach.shape[0]
    phi, rate, sliding = p.phi.reshape(3 * n), p.rate.reshape(3 * n), p.sliding.reshape(3 * n)
    ahead = dt if dt > 0.0 else 0.0
    inv_dt = 1.0 / dt if dt > 0.0 else 0.0
    for j in range(C.shape[1]):
        i = 3 * min(j, n - 1)   # (a padding column: the last joint's state)
        f, q, start, e, il, bend, u0 = lane_point(C, ends, state, j)
        a, b = (C[C_AXIS, j], C[C_AXIS + 1, j], C[C_AXIS + 2, j]), (C[C_AXIS_B, j], C[C_AXIS_B + 1, j],
                                                                     C[C_AXIS_B + 2, j])
        lo0, hi0, lo1, hi1 = C[C_LOWER, j], C[C_UPPER, j], C[C_LOWER1, j], C[C_UPPER1, j]
        k0, k1, rest0, rest1 = C[C_SPRING, j], C[C_SPRING1, j], C[C_REST, j], C[C_REST1, j]
        d0, d1 = C[C_DAMPER, j] * inv_dt, C[C_DAMPER1, j] * inv_dt
        p0, p1 = phi[i], phi[i + 1]
        m0, m1, f0, f1, checked = True, True, 0.0, 0.0, True
        wnode, wte = (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
        if HELD:   # (a variant's option: kernels/articulation.py) start_joint's weighing at phi^-
            wa, wb = axis_quat(p0, a), axis_quat(p1, b)
            wr = quat_mul(wa[0], wa[1], wa[2], wa[3], wb[0], wb[1], wb[2], wb[3])
            c0 = quat_rotate_inv(wb[0], wb[1], wb[2], wb[3], a[0], a[1], a[2])
            wturn, wsmall, _ = turned_boundary(f, q, start, wr)
            wt = small_rotation(wturn[0], wturn[1], wturn[2], wturn[3])
            tau, wte = boundary_pair((wt[0], wt[1], wt[2]), wt[3], boundary_moment((wt[0], wt[1], wt[2]), il, u0, bend),
                                     start)
            held = C[C_HELD, j] != 0.0
            s0, w0f = friction_weighed(dot3(c0, tau) - k0 * (p0 - rest0), C[C_STATIC, j], C[C_KINETIC, j],
                                       sliding[i] != 0.0, C[C_DAMPER, j], dt)
            s1, w1f = friction_weighed(dot3(b, tau) - k1 * (p1 - rest1), C[C_STATIC1, j], C[C_KINETIC1, j],
                                       sliding[i + 1] != 0.0, C[C_DAMPER1, j], dt)
            m0, m1 = (held & s0) == False, (held & s1) == False  # noqa: E712
            f0, f1 = (w0f if held else 0.0), (w1f if held else 0.0)
            checked = wsmall | (held == False)  # noqa: E712
            wnode = quat_rotate(wr[0], wr[1], wr[2], wr[3], tau[0], tau[1], tau[2])
        x0 = min(max(p0 + ahead * rate[i], lo0), hi0) if m0 else p0
        x1 = min(max(p1 + ahead * rate[i + 1], lo1), hi1) if m1 else p1
        ra, rb = axis_quat(x0, a), axis_quat(x1, b)
        r = quat_mul(ra[0], ra[1], ra[2], ra[3], rb[0], rb[1], rb[2], rb[3])
        a1 = quat_rotate_inv(rb[0], rb[1], rb[2], rb[3], a[0], a[1], a[2])   # the first axis in the joint frame
        turn, small, rel = turned_boundary(f, q, start, r)
        tx, ty, tz, cc = small_rotation(turn[0], turn[1], turn[2], turn[3])
        t = (tx, ty, tz)
        m = boundary_moment(t, il, u0, bend)
        c2 = small_rate(tx * tx + ty * ty + tz * tz)
        w0, w1 = inverse_jacobian(t, cc, e, a1), inverse_jacobian(t, cc, e, b)
        bw0, bw1 = bend_rate(il, bend, w0), bend_rate(il, bend, w1)
        # (axis_balance's, without a table; a coordinate that does not move: 0 and 1)
        g0 = -e * dot3(w0, m) - k0 * (x0 - rest0) - d0 * (x0 - p0) - f0 if m0 else 0.0
        g1 = -e * dot3(w1, m) - k1 * (x1 - rest1) - d1 * (x1 - p1) - f1 if m1 else 0.0
        a00 = dot3(w0, bw0) + k0 + d0 if m0 else 1.0
        a11 = dot3(w1, bw1) + k1 + d1 if m1 else 1.0
        a01 = dot3(w0, bw1) if m0 & m1 else 0.0
        s = solve_sym3(a00, a01, 0.0, a11, 0.0, 1.0, g0, g1, 0.0)
        n0 = min(max(x0 + s[0], lo0), hi0) - x0 if m0 else 0.0
        n1 = min(max(x1 + s[1], lo1), hi1) - x1 if m1 else 0.0
        done = not max(abs(n0), abs(n1)) > NEWTON_TOL
        # the exact derivative (settle_universal's second step)
        a00 += dot3(jacobian_rate(t, cc, c2, e, w0, a1), m) if m0 else 0.0
        a11 += dot3(jacobian_rate(t, cc, c2, e, w1, b), m) if m1 else 0.0
        ba = cross(b[0], b[1], b[2], a1[0], a1[1], a1[2])
        a01 += dot3(jacobian_rate(t, cc, c2, e, w1, a1), m) - e * dot3(inverse_jacobian(t, cc, e, ba), m) \
            if m0 & m1 else 0.0
        stiff = (a00 > 0.0) & (a00 * a11 > a01 * a01)
        s = solve_sym3(a00, a01, 0.0, a11, 0.0, 1.0, g0, g1, 0.0)
        e0 = min(max(x0 + s[0], lo0), hi0) - x0 if m0 else 0.0
        e1 = min(max(x1 + s[1], lo1), hi1) - x1 if m1 else 0.0
        carried = (done == False) & stiff & (max(abs(e0), abs(e1)) <= ONE_STEP)  # noqa: E712
        dd0, dd1 = (e0, e1) if carried else (0.0, 0.0)
        u = (dd0 * w0[0] + dd1 * w1[0], dd0 * w0[1] + dd1 * w1[1], dd0 * w0[2] + dd1 * w1[2])
        te = inverse_jacobian(t, cc, e, m)
        dm = carried_torque(t, cc, c2, e, m, u, bend_rate(il, bend, u), 1.0)   # (linear in the direction)
        te = (e * te[0] + dm[0], e * te[1] + dm[1], e * te[2] + dm[2])
        node = node_torque(r, rel, te)
        still = (m0 | m1) == False   # noqa: E712  (held whole: the loads it was weighed with)
        node, te = (wnode, wte) if still else (node, te)
        # on from the first step where the exact derivative is not positive, else from the exact step
        nx0, nx1 = (x0 + dd0, x1 + dd1) if done | carried else ((x0 + e0, x1 + e1) if stiff else (x0 + n0, x1 + n1))
        fits = (C[C_UNIVERSAL, j] != 0.0) & checked & (still | small)
        out[U_OK, j] = (SETTLED if still | done | carried else AHEAD) if fits else 0.0
        out[U_PHI, j], out[U_PHI + 1, j] = nx0, nx1
        out[U_FRIC, j], out[U_FRIC + 1, j] = f0, f1
        out[U_MOVES, j], out[U_MOVES + 1, j] = (1.0 if m0 else 0.0), (1.0 if m1 else 0.0)
        put_loads(out, U_NODE, j, f, node, te)


@njit(**PASS)
def weigh_balls(p, model, state, dt, out):
    """Update out (SOCKETED - GRIPPED, k) for every joint by the friction of a ball joint without
    a spring table weighed at phi^- (start_joint, start_turning), in vector lanes: row G_OK
    SETTLED where the joint is such a ball joint with friction or a damper, its friction holds
    it (it stays at phi^-) and its boundary point there turns by less than 0.2 rad; rows
    G_NODE (3), G_TAU_E (3) and G_LAB (3) then hold the torques on the node and the end
    element there, the first in the lab (its reaction). AHEAD where such a joint turns, G_FRIC
    (3) the friction's generalised torques it meets (settle_sockets reads them). Elsewhere 0.0,
    and the rows anything."""
    C, ends, n = p.lane_constants, p.lane_ends, p.attach.shape[0]
    phi, sliding = p.phi.reshape(3 * n), p.sliding.reshape(3 * n)
    for j in range(C.shape[1]):
        i = 3 * min(j, n - 1)   # (a padding column: the last joint's state)
        f, q, start, _, il, bend, u0 = lane_point(C, ends, state, j)
        p0, p1, p2 = phi[i], phi[i + 1], phi[i + 2]
        r = quat_exp(p0, p1, p2)
        c0, c1, c2 = ball_axes(p0, p1, p2)
        turn, small, _ = boundary_quat(f, q, start, r)
        t = small_rotation(turn[0], turn[1], turn[2], turn[3])
        m = boundary_moment((t[0], t[1], t[2]), il, u0, bend)
        tau, te = boundary_pair((t[0], t[1], t[2]), t[3], m, start)
        # (start_turning's, without a table)
        q0 = dot3(c0, tau) - C[C_SPRING, j] * (p0 - C[C_REST, j])
        q1 = dot3(c1, tau) - C[C_SPRING1, j] * (p1 - C[C_REST1, j])
        q2 = dot3(c2, tau) - C[C_SPRING2, j] * (p2 - C[C_REST2, j])
        turning = sliding[i] + sliding[i + 1] + sliding[i + 2] != 0.0
        stays, f0, f1, f2 = ball_weighed(c0, c1, c2, (q0, q1, q2), C[C_STATIC, j], C[C_KINETIC, j], turning,
                                         C[C_DAMPERS, j] > 0.0, dt)
        out[G_OK, j] = (SETTLED if stays else AHEAD) if (C[C_GRIP, j] != 0.0) & small else 0.0
        out[G_FRIC, j], out[G_FRIC + 1, j], out[G_FRIC + 2, j] = f0, f1, f2
        put_loads(out, G_NODE, j, f, quat_rotate(r[0], r[1], r[2], r[3], tau[0], tau[1], tau[2]), te)


@njit(**PASS)
def settle_sockets(p, model, state, dt, out, gripped):
    """Update out (LANE_ROWS - SOCKETED, k) for every joint as settle_ball settles a ball joint
    without a spring table or a cone by one evaluation, from its coordinates carried on at
    their last rate, its branches taken as selects (settle_universals' way for three
    coordinates): the leading term's Newton step ends the iteration, or the exact derivative's
    (joint_math.ball_exact: the axes turn with phi) is taken without evaluating again. With
    friction or a damper, only where weigh_balls found it turning (``gripped``: its rows),
    against the friction torques it weighed. Row S_OK is SETTLED where that evaluation is the
    balance, the boundary point turning by less than 0.2 rad: rows S_PHI (3), S_NODE (3),
    S_TAU_E (3) and S_LAB (3) then hold its coordinates, the torques on the node and the end
    element, the first in the lab; AHEAD where the iteration goes on (S_PHI: the leading
    step's point, settle_ball's next); elsewhere 0.0 (the scalar iteration settles it), and
    the rows anything."""
    C, ends, n = p.lane_constants, p.lane_ends, p.attach.shape[0]
    phi, rate = p.phi.reshape(3 * n), p.rate.reshape(3 * n)
    ahead = dt if dt > 0.0 else 0.0
    inv_dt = 1.0 / dt if dt > 0.0 else 0.0
    for j in range(C.shape[1]):
        i = 3 * min(j, n - 1)   # (a padding column: the last joint's state)
        f, q, start, e, il, bend, u0 = lane_point(C, ends, state, j)
        d0, d1, d2 = C[C_DAMPER, j] * inv_dt, C[C_DAMPER1, j] * inv_dt, C[C_DAMPER2, j] * inv_dt
        k0, k1, k2 = C[C_SPRING, j], C[C_SPRING1, j], C[C_SPRING2, j]
        held = C[C_HELD, j] != 0.0
        turns = (held == False) | (gripped[G_OK, j] == AHEAD)  # noqa: E712
        f0, f1, f2 = ((gripped[G_FRIC, j], gripped[G_FRIC + 1, j], gripped[G_FRIC + 2, j]) if held
                      else (0.0, 0.0, 0.0))
        p0, p1, p2 = phi[i], phi[i + 1], phi[i + 2]
        x0, x1, x2 = p0 + ahead * rate[i], p1 + ahead * rate[i + 1], p2 + ahead * rate[i + 2]
        r = quat_exp(x0, x1, x2)
        a0, a1, a2 = ball_axes(x0, x1, x2)
        turn, small, rel = turned_boundary(f, q, start, r)
        tx, ty, tz, cc = small_rotation(turn[0], turn[1], turn[2], turn[3])
        t = (tx, ty, tz)
        m = boundary_moment(t, il, u0, bend)
        c2 = small_rate(tx * tx + ty * ty + tz * tz)
        w0, w1, w2 = inverse_jacobian(t, cc, e, a0), inverse_jacobian(t, cc, e, a1), inverse_jacobian(t, cc, e, a2)
        bw0, bw1, bw2 = bend_rate(il, bend, w0), bend_rate(il, bend, w1), bend_rate(il, bend, w2)
        # (axis_balance's, without a table)
        g0 = -e * dot3(w0, m) - k0 * (x0 - C[C_REST, j]) - d0 * (x0 - p0) - f0
        g1 = -e * dot3(w1, m) - k1 * (x1 - C[C_REST1, j]) - d1 * (x1 - p1) - f1
        g2 = -e * dot3(w2, m) - k2 * (x2 - C[C_REST2, j]) - d2 * (x2 - p2) - f2
        a00, a11, a22 = dot3(w0, bw0) + k0 + d0, dot3(w1, bw1) + k1 + d1, dot3(w2, bw2) + k2 + d2
        a01, a02, a12 = dot3(w0, bw1), dot3(w0, bw2), dot3(w1, bw2)
        lead = solve_sym3(a00, a01, a02, a11, a12, a22, g0, g1, g2)
        done = not max(abs(lead[0]), abs(lead[1]), abs(lead[2])) > NEWTON_TOL
        # the exact derivative (settle_ball's second step)
        h = ball_exact(t, cc, c2, e, m, (x0, x1, x2), (a0, a1, a2), (w0, w1, w2))
        a00, a11, a22, a01, a02, a12 = a00 + h[0], a11 + h[1], a22 + h[2], a01 + h[3], a02 + h[4], a12 + h[5]
        stiff = positive_sym3(a00, a01, a02, a11, a12, a22)
        s = solve_sym3(a00, a01, a02, a11, a12, a22, g0, g1, g2)
        carried = (done == False) & stiff & (max(abs(s[0]), abs(s[1]), abs(s[2])) <= ONE_STEP)  # noqa: E712
        dd0, dd1, dd2 = (s[0], s[1], s[2]) if carried else (0.0, 0.0, 0.0)
        u = (dd0 * w0[0] + dd1 * w1[0] + dd2 * w2[0], dd0 * w0[1] + dd1 * w1[1] + dd2 * w2[1],
             dd0 * w0[2] + dd1 * w1[2] + dd2 * w2[2])
        te = inverse_jacobian(t, cc, e, m)
        dm = carried_torque(t, cc, c2, e, m, u, bend_rate(il, bend, u), 1.0)   # (linear in the direction)
        te = (e * te[0] + dm[0], e * te[1] + dm[1], e * te[2] + dm[2])
        node = node_torque(r, rel, te)
        s0, s1, s2 = (dd0, dd1, dd2) if done | carried else lead   # (on from the leading step, as settle_ball)
        fits = (C[C_SOCKET, j] != 0.0) & turns & small
        out[S_OK, j] = (SETTLED if done | carried else AHEAD) if fits else 0.0
        out[S_PHI, j], out[S_PHI + 1, j], out[S_PHI + 2, j] = x0 + s0, x1 + s1, x2 + s2
        put_loads(out, S_NODE, j, f, node, te)


@njit(**PASS)
def settle_balls(p, model, state, out):
    """Update out (LANE_ROWS, k) for every joint by loose_turn, in vector lanes: row BALL_OK
    SETTLED at a loose ball joint (loose_ball) whose balance lies within its cone, its
    coordinates in rows TURN (3); elsewhere 0.0, and the rows anything."""
    C, ends, n = p.lane_constants, p.lane_ends, p.attach.shape[0]
    phi = p.phi.reshape(3 * n)
    for j in range(C.shape[1]):
        i = 3 * min(j, n - 1)   # (a padding column: the last joint's state)
        nq, q = state.node_q[ends[0, j]], state.q[ends[1, j]]
        f = quat_mul(nq[0], nq[1], nq[2], nq[3], C[C_FRAME, j], C[C_FRAME + 1, j], C[C_FRAME + 2, j], C[C_FRAME + 3, j])
        (tx, ty, tz), within = loose_turn(f, (q[0], q[1], q[2], q[3]), C[C_START, j] != 0.0, C[C_IL, j],
                                          (C[C_U0, j], C[C_U0 + 1, j], C[C_U0 + 2, j]),
                                          (phi[i], phi[i + 1], phi[i + 2]), C[C_CONE, j])
        out[BALL_OK, j] = SETTLED if C[C_LOOSE, j] != 0.0 and within else 0.0
        out[TURN, j], out[TURN + 1, j], out[TURN + 2, j] = tx, ty, tz


def lane_tables(p, model):
    """Fill p.lane_constants and p.lane_ends from the joints and the model (settle_hinges,
    settle_balls, weigh_hinges, settle_universals, weigh_balls, settle_sockets): a column per
    joint, then its last repeated to the padding (lane_count), where no joint is a lane's hinge,
    loose ball, universal joint or ball joint."""
    C, a, k = p.lane_constants, p.attach, p.attach.shape[0]
    C[C_AXIS:C_AXIS + 3, :k] = p.axis_a.T
    C[C_BEND:C_BEND + 3, :k] = p.bend.T
    C[C_LOWER, :k], C[C_UPPER, :k], C[C_SPRING, :k], C[C_REST, :k] = (p.lower[:, 0], p.upper[:, 0],
                                                                      p.stiffness[:, 0], p.rest[:, 0])
    tables = p.table_offsets[1::3] - p.table_offsets[0:-1:3]
    C[C_HINGE, :k] = (p.dofs == HINGE) & (tables == 0)
    C[C_DAMPER, :k], C[C_STATIC, :k], C[C_KINETIC, :k] = p.damping[:, 0], p.static[:, 0], p.kinetic[:, 0]
    C[C_AXIS_B:C_AXIS_B + 3, :k] = p.axis_b.T
    C[C_LOWER1, :k], C[C_UPPER1, :k], C[C_SPRING1, :k], C[C_REST1, :k] = (p.lower[:, 1], p.upper[:, 1],
                                                                          p.stiffness[:, 1], p.rest[:, 1])
    C[C_DAMPER1, :k], C[C_STATIC1, :k], C[C_KINETIC1, :k] = p.damping[:, 1], p.static[:, 1], p.kinetic[:, 1]
    C[C_UNIVERSAL, :k] = (p.dofs == UNIVERSAL) & (p.table_offsets[2::3] == p.table_offsets[0:-1:3])
    C[C_HELD, :k] = np.any((p.static + p.kinetic + p.damping != 0.0) & (np.arange(3) < p.dofs[:, None]),
                           axis=1)   # (free_joint)
    C[C_SPRING2, :k], C[C_REST2, :k], C[C_DAMPERS, :k] = p.stiffness[:, 2], p.rest[:, 2], p.damping.sum(axis=1)
    C[C_GRIP, :k] = (p.dofs == BALL) & (C[C_HELD, :k] != 0.0) & (p.table_offsets[3::3] == p.table_offsets[0:-1:3])
    C[C_DAMPER2, :k] = p.damping[:, 2]
    held = np.abs(p.stiffness) + p.static + p.kinetic + p.damping
    C[C_LOOSE, :k] = (p.dofs == BALL) & np.all(held == 0.0, axis=1) & np.all(p.lower == -np.inf, axis=1) & \
        np.all(p.upper == np.inf, axis=1) & (p.table_offsets[3::3] == p.table_offsets[0:-1:3])   # (loose_ball)
    C[C_CONE, :k] = np.where(p.cone < np.pi, np.cos(p.cone), -np.inf)   # (cone_cosine)
    C[C_SOCKET, :k] = (p.dofs == BALL) & (C[C_LOOSE, :k] == 0.0) & (p.cone >= np.pi) & \
        (p.table_offsets[3::3] == p.table_offsets[0:-1:3])
    kv = model.attach_vertex[a]
    C[C_IL, :k] = model.voronoi_inv_rest_length[kv]
    C[C_U0:C_U0 + 3, :k] = model.voronoi_rest_curvature[kv].T
    C[C_FRAME:C_FRAME + 4, :k] = model.attach_frame[a].T
    C[C_START, :k] = a % 2 == 0
    p.lane_ends[0, :k], p.lane_ends[1, :k] = model.attach_node[a], model.attach_element[a]
    if k > 0:
        C[:, k:] = C[:, k - 1:k]
        C[C_HINGE, k:] = C[C_LOOSE, k:] = C[C_UNIVERSAL, k:] = C[C_GRIP, k:] = C[C_SOCKET, k:] = 0.0
        p.lane_ends[:, k:] = p.lane_ends[:, k - 1:k]
