"""A net's pins and loose ball joints settled all at once, in vector lanes
(kernels/articulation.py's module docstring says how, and which joints go on to its scalar
path): settle_hinges and settle_balls, whose rows the load kernel reads, and the rows of
constants they read (lane_tables)."""

import numpy as np
from numba import njit

from .backend import PASS
from .joint_math import BALL, HINGE, NEWTON_TOL, ONE_STEP, boundary_moment, boundary_quat, hinge_terms, \
    hinge_torques, loose_turn, small_rate
from .rotations import quat_exp, quat_mul, quat_rotate, small_rotation

# rows of p.lanes (settle_hinges): whether the joint settled there, its coordinate, the torques
# on its node (X's components) and end element, and the first in the lab
OK, PHI, NODE, TAU_E, LAB = 0, 1, 2, 5, 8
# and of settle_balls: whether the joint settled there, its coordinates
BALL_OK, TURN = 11, 12
LANE_ROWS = 15
SETTLED, AHEAD = 1.0, 2.0   # in rows OK and BALL_OK
# rows of p.lane_constants (lane_tables): the joints' constants settle_hinges and settle_balls
# read, a row for each number (kernels/articulation.py's docstring says why); C_CONE holds
# cone_cosine
C_AXIS, C_BEND, C_LOWER, C_UPPER, C_SPRING, C_REST, C_PIN, C_IL, C_U0, C_FRAME, C_START, C_LOOSE, C_CONE = \
    0, 3, 6, 7, 8, 9, 10, 11, 12, 15, 19, 20, 21
LANE_CONSTANTS = 22


@njit(**PASS)
def settle_hinges(p, model, state, dt, out):
    """Update out (LANE_ROWS, k) for every joint by settle_hinge's first evaluation, taken
    without a branch so that the joints go through it in vector lanes: row OK is 1.0 where
    that evaluation is the balance (a hinge whose balance has neither a damper, friction nor
    a spring table, whose boundary point turns by less than 0.2 rad, and whose Newton step
    from its carried coordinate ends the iteration or is taken without evaluating again:
    settle_hinge): SETTLED, and rows PHI, NODE (3), TAU_E (3) and LAB (3) hold its
    coordinate, the torques on the node and the end element and the first in the lab (its
    reaction); where that hinge's exact Newton step is too long to carry, AHEAD, and row PHI
    holds where the step goes, settle_hinge's next point (add_articulations goes on from
    there); elsewhere 0.0, and the rows anything, NaN included."""
    C, ends = p.lane_constants, p.lane_ends
    phi, rate = p.phi.reshape(3 * p.attach.shape[0]), p.rate.reshape(3 * p.attach.shape[0])
    for j in range(p.attach.shape[0]):
        nq, q = state.node_q[ends[0, j]], state.q[ends[1, j]]
        f = quat_mul(nq[0], nq[1], nq[2], nq[3], C[C_FRAME, j], C[C_FRAME + 1, j], C[C_FRAME + 2, j], C[C_FRAME + 3, j])
        ax, ay, az = C[C_AXIS, j], C[C_AXIS + 1, j], C[C_AXIS + 2, j]
        lo, hi, k0, rest = C[C_LOWER, j], C[C_UPPER, j], C[C_SPRING, j], C[C_REST, j]
        x = min(max(phi[3 * j] + dt * rate[3 * j], lo), hi)
        r = quat_exp(x * ax, x * ay, x * az)
        start = C[C_START, j] != 0.0
        turn, small, rel = boundary_quat(f, q, start, r)
        tx, ty, tz, cc = small_rotation(turn[0], turn[1], turn[2], turn[3])
        t, es = (tx, ty, tz), (-1.0 if start else 1.0)
        il, b = C[C_IL, j], (C[C_BEND, j], C[C_BEND + 1, j], C[C_BEND + 2, j])
        m = boundary_moment(t, il, (C[C_U0, j], C[C_U0 + 1, j], C[C_U0 + 2, j]), b)
        c2 = small_rate(tx * tx + ty * ty + tz * tz)
        w, bw, torque, lead, soft = hinge_terms(t, cc, c2, es, m, (ax, ay, az), il, b)
        g = torque - k0 * (x - rest)
        lead += k0
        step = min(max(x + g / lead, lo), hi) - x
        stiff = soft + lead
        exact = min(max(x + g / stiff, lo), hi) - x
        done = not abs(step) > NEWTON_TOL
        carried = 0.0 if done else exact
        node, te = hinge_torques(t, cc, c2, es, m, w, bw, carried, r, rel)
        fits = C[C_PIN, j] != 0.0 and small and (done or stiff > 0.0)
        out[OK, j] = (SETTLED if done or not abs(exact) > ONE_STEP else AHEAD) if fits else 0.0
        out[PHI, j] = x + carried
        out[NODE, j], out[NODE + 1, j], out[NODE + 2, j] = node
        out[TAU_E, j], out[TAU_E + 1, j], out[TAU_E + 2, j] = te
        out[LAB, j], out[LAB + 1, j], out[LAB + 2, j] = quat_rotate(f[0], f[1], f[2], f[3], node[0], node[1], node[2])


@njit(**PASS)
def settle_balls(p, model, state, out):
    """Update out (LANE_ROWS, k) for every joint by loose_turn, in vector lanes: row BALL_OK
    SETTLED at a loose ball joint (loose_ball) whose balance lies within its cone, its
    coordinates in rows TURN (3); elsewhere 0.0, and the rows anything."""
    C, ends = p.lane_constants, p.lane_ends
    phi = p.phi.reshape(3 * p.attach.shape[0])
    for j in range(p.attach.shape[0]):
        nq, q = state.node_q[ends[0, j]], state.q[ends[1, j]]
        f = quat_mul(nq[0], nq[1], nq[2], nq[3], C[C_FRAME, j], C[C_FRAME + 1, j], C[C_FRAME + 2, j], C[C_FRAME + 3, j])
        (tx, ty, tz), within = loose_turn(f, (q[0], q[1], q[2], q[3]), C[C_START, j] != 0.0, C[C_IL, j],
                                          (C[C_U0, j], C[C_U0 + 1, j], C[C_U0 + 2, j]),
                                          (phi[3 * j], phi[3 * j + 1], phi[3 * j + 2]), C[C_CONE, j])
        out[BALL_OK, j] = SETTLED if C[C_LOOSE, j] != 0.0 and within else 0.0
        out[TURN, j], out[TURN + 1, j], out[TURN + 2, j] = tx, ty, tz


def lane_tables(p, model):
    """Fill p.lane_constants and p.lane_ends from the joints and the model (settle_hinges,
    settle_balls)."""
    C, a = p.lane_constants, p.attach
    C[C_AXIS:C_AXIS + 3] = p.axis_a.T
    C[C_BEND:C_BEND + 3] = p.bend.T
    C[C_LOWER], C[C_UPPER], C[C_SPRING], C[C_REST] = p.lower[:, 0], p.upper[:, 0], p.stiffness[:, 0], p.rest[:, 0]
    tables = p.table_offsets[1::3] - p.table_offsets[0:-1:3]
    C[C_PIN] = (p.dofs == HINGE) & (p.damping[:, 0] == 0.0) & (p.static[:, 0] == 0.0) & \
        (p.kinetic[:, 0] == 0.0) & (tables == 0)
    held = np.abs(p.stiffness) + p.static + p.kinetic + p.damping
    C[C_LOOSE] = (p.dofs == BALL) & np.all(held == 0.0, axis=1) & np.all(p.lower == -np.inf, axis=1) & \
        np.all(p.upper == np.inf, axis=1) & (p.table_offsets[3::3] == p.table_offsets[0:-1:3])   # (loose_ball)
    C[C_CONE] = np.where(p.cone < np.pi, np.cos(p.cone), -np.inf)   # (cone_cosine)
    kv = model.attach_vertex[a]
    C[C_IL] = model.voronoi_inv_rest_length[kv]
    C[C_U0:C_U0 + 3] = model.voronoi_rest_curvature[kv].T
    C[C_FRAME:C_FRAME + 4] = model.attach_frame[a].T
    C[C_START] = a % 2 == 0
    p.lane_ends[0], p.lane_ends[1] = model.attach_node[a], model.attach_element[a]
