"""A net's hinges and loose ball joints settled all at once, in vector lanes
(kernels/articulation.py's module docstring says how, and which joints go on to its scalar
path): weigh_hinges, settle_hinges and settle_balls, whose rows the load kernel reads, and
the rows of constants they read (lane_tables)."""


import numpy as np
from numba import njit

from .backend import PASS
from .joint_math import BALL, HINGE, NEWTON_TOL, ONE_STEP, boundary_moment, boundary_pair, boundary_quat, dot3, \
    friction_weighed, hinge_terms, hinge_torques, loose_turn, small_rate
from .rotations import axis_quat, quat_mul, quat_rotate, small_rotation

# rows of p.lanes (settle_hinges): whether the joint settled there, its coordinate, the torques
# on its node (X's components) and end element, the first in the lab, its friction torque and
# whether it moved
OK, PHI, NODE, TAU_E, LAB, FRIC, MOVES = 0, 1, 2, 5, 8, 11, 12
# and of settle_balls: whether the joint settled there, its coordinates
BALL_OK, TURN = 13, 14
# and of weigh_hinges (from WEIGHED on: a block settle_hinges reads while writing the rows above)
WEIGHED = 17
W_OK, W_MOVES, W_FRIC, W_NODE, W_TAU_E = 0, 1, 2, 3, 6
LANE_ROWS = 26
SETTLED, AHEAD = 1.0, 2.0   # in rows OK and BALL_OK
# rows of p.lane_constants (lane_tables): the joints' constants settle_hinges and settle_balls
# read, a row for each number (kernels/articulation.py's docstring says why); C_CONE holds
# cone_cosine
C_AXIS, C_BEND, C_LOWER, C_UPPER, C_SPRING, C_REST, C_HINGE, C_IL, C_U0, C_FRAME, C_START, C_LOOSE, C_CONE = \
    0, 3, 6, 7, 8, 9, 10, 11, 12, 15, 19, 20, 21
C_DAMPER, C_STATIC, C_KINETIC = 22, 23, 24
LANE_CONSTANTS = 25

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


def lane_count(k: int) -> int:
    """The columns of the lanes' rows for k joints: k padded to a multiple of LANE_WIDTH."""
    return -(-k // LANE_WIDTH) * LANE_WIDTH


@njit(**PASS)
def weigh_hinges(p, model, state, dt, out):
    """Update out (LANE_ROWS - WEIGHED, k) for every joint by the friction of a hinge without a
    spring table weighed at phi^- (start_joint, start_motion), in vector lanes: rows W_MOVES
    and W_FRIC whether it may move and the friction torque it then meets (1.0 and 0.0 for a
    hinge without friction or a damper), W_NODE (3) and W_TAU_E (3) the torques on the node
    and the end element at phi^- (the loads of a hinge its friction holds), and W_OK whether
    its boundary point there turns by less than 0.2 rad (settle_hinges reads them)."""
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
        held = C[C_STATIC, j] + C[C_KINETIC, j] + C[C_DAMPER, j] != 0.0   # (not free_joint)
        q0 = dot3(a, tau) - C[C_SPRING, j] * (prev - C[C_REST, j])   # (start_motion's, without a table)
        stays, fric = friction_weighed(q0, C[C_STATIC, j], C[C_KINETIC, j], sliding[i] != 0.0, C[C_DAMPER, j], dt)
        out[W_OK, j] = 1.0 if small | (held == False) else 0.0  # noqa: E712
        out[W_MOVES, j] = 0.0 if held & stays else 1.0
        out[W_FRIC, j] = fric if held else 0.0
        out[W_NODE, j], out[W_NODE + 1, j], out[W_NODE + 2, j] = quat_rotate(r[0], r[1], r[2], r[3], tau[0], tau[1],
                                                                             tau[2])
        out[W_TAU_E, j], out[W_TAU_E + 1, j], out[W_TAU_E + 2, j] = te


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
        out[NODE, j], out[NODE + 1, j], out[NODE + 2, j] = node
        out[TAU_E, j], out[TAU_E + 1, j], out[TAU_E + 2, j] = te
        out[LAB, j], out[LAB + 1, j], out[LAB + 2, j] = quat_rotate(f[0], f[1], f[2], f[3], node[0], node[1], node[2])


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
    settle_balls, weigh_hinges): a column per joint, then its last repeated to the padding
    (lane_count), where no joint is a lane's hinge or loose ball."""
    C, a, k = p.lane_constants, p.attach, p.attach.shape[0]
    C[C_AXIS:C_AXIS + 3, :k] = p.axis_a.T
    C[C_BEND:C_BEND + 3, :k] = p.bend.T
    C[C_LOWER, :k], C[C_UPPER, :k], C[C_SPRING, :k], C[C_REST, :k] = (p.lower[:, 0], p.upper[:, 0],
                                                                      p.stiffness[:, 0], p.rest[:, 0])
    tables = p.table_offsets[1::3] - p.table_offsets[0:-1:3]
    C[C_HINGE, :k] = (p.dofs == HINGE) & (tables == 0)
    C[C_DAMPER, :k], C[C_STATIC, :k], C[C_KINETIC, :k] = p.damping[:, 0], p.static[:, 0], p.kinetic[:, 0]
    held = np.abs(p.stiffness) + p.static + p.kinetic + p.damping
    C[C_LOOSE, :k] = (p.dofs == BALL) & np.all(held == 0.0, axis=1) & np.all(p.lower == -np.inf, axis=1) & \
        np.all(p.upper == np.inf, axis=1) & (p.table_offsets[3::3] == p.table_offsets[0:-1:3])   # (loose_ball)
    C[C_CONE, :k] = np.where(p.cone < np.pi, np.cos(p.cone), -np.inf)   # (cone_cosine)
    kv = model.attach_vertex[a]
    C[C_IL, :k] = model.voronoi_inv_rest_length[kv]
    C[C_U0:C_U0 + 3, :k] = model.voronoi_rest_curvature[kv].T
    C[C_FRAME:C_FRAME + 4, :k] = model.attach_frame[a].T
    C[C_START, :k] = a % 2 == 0
    p.lane_ends[0, :k], p.lane_ends[1, :k] = model.attach_node[a], model.attach_element[a]
    if k > 0:
        C[:, k:] = C[:, k - 1:k]
        C[C_HINGE, k:] = C[C_LOOSE, k:] = 0.0
        p.lane_ends[:, k:] = p.lane_ends[:, k - 1:k]
