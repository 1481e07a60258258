"""Internal loads of the lines: Kirchhoff constitutive law (3.22)-(3.25) on a staggered grid.

The discrete strain energy of a line is
    U = sum_e  l_e/2 (s_e/l_e - e3)^T K_e (s_e/l_e - e3)          s_e = D_e^T (x_{e+1} - x_e)
      + sum_k  L_k/2 (theta_k/L_k - u0_k)^T B_k (theta_k/L_k - u0_k)  theta_k = log(D_a^T D_b)
where D_a, D_b are the frames on either side of Voronoi point k (at the line ends, the node's
frame D(nu) X(nu, lambda) (1.3)). The forces and torques below are its exact gradient, so the
discrete contact force is n = D K (v - d3) and the contact torque m = D B (u - u0) (3.22),
and the time stepper is variational: energy has no secular drift.
"""

from numba import njit, prange

from .backend import STEP, dispatch3
from .layout import columns, quat_columns

from .rotations import (INLINE, KERNEL, cross, quat_mul, quat_rotate, quat_rotate_inv, relative_quat,
                        relative_rotation, small_rotation)


@njit(**INLINE)
def bend_moment(model, k, theta_x, theta_y, theta_z):
    """Return m = B (theta/L - u0) at Voronoi point k (principal frame) (3.22)."""
    inv_l = model.voronoi_inv_rest_length[k]
    b, u0 = model.voronoi_stiffness.T, model.voronoi_rest_curvature.T
    return (b[0, k] * (theta_x * inv_l - u0[0, k]),
            b[1, k] * (theta_y * inv_l - u0[1, k]),
            b[2, k] * (theta_z * inv_l - u0[2, k]))


@njit(**INLINE)
def bend_torques(tx, ty, tz, c, mx, my, mz):
    """Return the body torques on the left frame (+J_r^-1 m) and right frame (-J_l^-1 m) of a
    Voronoi point with relative rotation theta and bending moment m."""
    ax, ay, az = cross(tx, ty, tz, mx, my, mz)
    bx, by, bz = cross(tx, ty, tz, ax, ay, az)
    sx, sy, sz = mx + c * bx, my + c * by, mz + c * bz
    return (sx + 0.5 * ax, sy + 0.5 * ay, sz + 0.5 * az,
            -(sx - 0.5 * ax), -(sy - 0.5 * ay), -(sz - 0.5 * az))


@njit(**INLINE)
def store_bend(vor, k, tx, ty, tz, c, left, right):
    """Update left, right (column triples) at Voronoi point k of a line with the torques on
    its two frames given its rotation vector theta and c(theta); vor = (B, u0, 1/L) columns
    of the line's Voronoi points (3.22), (3.24)."""
    b, u0, inv_l = vor
    il = inv_l[k]
    mx = b[0][k] * (tx * il - u0[0][k])
    my = b[1][k] * (ty * il - u0[1][k])
    mz = b[2][k] * (tz * il - u0[2][k])
    lx, ly, lz, rx, ry, rz = bend_torques(tx, ty, tz, c, mx, my, mz)
    left[0][k], left[1][k], left[2][k] = lx, ly, lz
    right[0][k], right[1][k], right[2][k] = rx, ry, rz


@njit(**INLINE)
def end_frame(model, state, a):
    """Return the quaternion of line end a's director frame D(nu) X(nu, lambda) (1.3)."""
    nq = state.node_q[model.attach_node[a]]
    xq = model.attach_frame[a]
    return quat_mul(nq[0], nq[1], nq[2], nq[3], xq[0], xq[1], xq[2], xq[3])


@njit(**INLINE)
def bend_interior(n, vor, q, left, right):
    """Update left, right at the interior Voronoi points 1 .. n-1 of a line given its n
    element quaternions q (column quadruple), by the series log map (vectorised); return how
    many points turned by 0.2 rad or more (their values are then meaningless)."""
    large = 0
    for k in range(1, n):
        rw, rx, ry, rz, small = relative_quat(q[0][k - 1], q[1][k - 1], q[2][k - 1], q[3][k - 1],
                                              q[0][k], q[1][k], q[2][k], q[3][k])
        large += 0 if small else 1
        tx, ty, tz, c = small_rotation(rw, rx, ry, rz)
        store_bend(vor, k, tx, ty, tz, c, left, right)
    return large


@njit(**INLINE)
def bend_interior_large(n, vor, q, left, right):
    """Update left, right at the interior Voronoi points of a line turned by 0.2 rad or
    more, by the exact log map."""
    for k in range(1, n):
        aw, ax, ay, az = q[0][k - 1], q[1][k - 1], q[2][k - 1], q[3][k - 1]
        bw, bx, by, bz = q[0][k], q[1][k], q[2][k], q[3][k]
        if not relative_quat(aw, ax, ay, az, bw, bx, by, bz)[4]:
            tx, ty, tz, c = relative_rotation(aw, ax, ay, az, bw, bx, by, bz)
            store_bend(vor, k, tx, ty, tz, c, left, right)


@njit(**INLINE)
def stretch_elements(n, x, q, stiff, inv_len, left, right, force, tau):
    """Update force, the lab contact force n = D K (D^T r'/l - e3), and tau, the body torque
    r' x n plus the bending torques of the Voronoi points on either side, of the n elements
    of a line (3.2)/(3.3), (3.22) (vectorised; column tuples of the line's items)."""
    for e in range(n):
        qw, qx, qy, qz = q[0][e], q[1][e], q[2][e], q[3][e]
        il = inv_len[e]
        sx, sy, sz = quat_rotate_inv(qw, qx, qy, qz, x[0][e + 1] - x[0][e], x[1][e + 1] - x[1][e],
                                     x[2][e + 1] - x[2][e])
        nx, ny, nz = stiff[0][e] * sx * il, stiff[1][e] * sy * il, stiff[2][e] * (sz * il - 1.0)
        fx, fy, fz = quat_rotate(qw, qx, qy, qz, nx, ny, nz)
        force[0][e], force[1][e], force[2][e] = fx, fy, fz
        cx, cy, cz = cross(sx, sy, sz, nx, ny, nz)
        tau[0][e] = cx + right[0][e] + left[0][e + 1]
        tau[1][e] = cy + right[1][e] + left[1][e + 1]
        tau[2][e] = cz + right[2][e] + left[2][e + 1]


@njit(**INLINE)
def vertex_forces(n, force, f):
    """Update f at the n + 1 vertices of a line with the difference of the contact forces of
    the elements on either side (3.2) (vectorised; column tuples of the line's items)."""
    for v in range(1, n):
        f[0][v] = force[0][v] - force[0][v - 1]
        f[1][v] = force[1][v] - force[1][v - 1]
        f[2][v] = force[2][v] - force[2][v - 1]
    for k in range(3):
        f[k][0] = force[k][0]
        f[k][n] = -force[k][n - 1]


@njit(**STEP)  # not inline="always": called inside prange (see backend.py)
def compute_line_loads(l, model, state, loads):
    """Update loads.f, loads.tau, loads.end_tau of line l given state.x, state.q, state.node_q
    (3.2)-(3.3), (3.22)-(3.25), in vectorised passes over the line's Voronoi points, elements
    and vertices (through the scratch loads.bend_left, bend_right, elem_force)."""
    v0, v1 = model.line_vertex_offsets[l], model.line_vertex_offsets[l + 1]
    e0, e1 = model.line_element_offsets[l], model.line_element_offsets[l + 1]
    n = e1 - e0
    q = quat_columns(state.q, e0, e1)
    left, right = columns(loads.bend_left, v0, v1), columns(loads.bend_right, v0, v1)
    vor = (columns(model.voronoi_stiffness, v0, v1), columns(model.voronoi_rest_curvature, v0, v1),
           model.voronoi_inv_rest_length[v0:v1])
    if bend_interior(n, vor, q, left, right):
        bend_interior_large(n, vor, q, left, right)
    # the boundary points join the end elements to their nodes' frames D(nu) X(nu, lambda)
    aw, ax, ay, az = end_frame(model, state, 2 * l)
    tx, ty, tz, c = relative_rotation(aw, ax, ay, az, q[0][0], q[1][0], q[2][0], q[3][0])
    store_bend(vor, 0, tx, ty, tz, c, left, right)
    bw, bx, by, bz = end_frame(model, state, 2 * l + 1)
    tx, ty, tz, c = relative_rotation(q[0][n - 1], q[1][n - 1], q[2][n - 1], q[3][n - 1], bw, bx, by, bz)
    store_bend(vor, n, tx, ty, tz, c, left, right)
    force = columns(loads.elem_force, e0, e1)
    stretch_elements(n, columns(state.x, v0, v1), q, columns(model.element_stiffness, e0, e1),
                     model.element_inv_rest_length[e0:e1], left, right, force, columns(loads.tau, e0, e1))
    vertex_forces(n, force, columns(loads.f, v0, v1))
    ends = loads.end_tau
    for k in range(3):
        ends[2 * l, k] = left[k][0]
        ends[2 * l + 1, k] = right[k][n]


@njit(**STEP)
def compute_internal_loads(model, state, loads):
    """Update loads.f (nv,3), loads.tau (ne,3), loads.end_tau (na,3) given the state: the
    internal force and torque balances (3.2)/(3.3) of every line."""
    for l in range(model.line_vertex_offsets.shape[0] - 1):
        compute_line_loads(l, model, state, loads)


@njit(**KERNEL, parallel=True)
def compute_internal_loads_parallel(model, state, loads):
    """Update loads.f, loads.tau, loads.end_tau as compute_internal_loads, a line per task."""
    for l in prange(model.line_vertex_offsets.shape[0] - 1):
        compute_line_loads(l, model, state, loads)


internal_loads_on = dispatch3(compute_internal_loads, compute_internal_loads_parallel)


@njit(**STEP)
def line_strain_energy(l, model, state):
    """Return the strain energy (3.25) of line l given state.x, state.q, state.node_q."""
    x, q = state.x, state.q
    v0 = model.line_vertex_offsets[l]
    e0 = model.line_element_offsets[l]
    n = model.line_element_offsets[l + 1] - e0
    u = 0.0
    pw, px, py, pz = end_frame(model, state, 2 * l)
    for i in range(n + 1):
        if i < n:
            e = e0 + i
            qw, qx, qy, qz = q[e, 0], q[e, 1], q[e, 2], q[e, 3]
            l0 = model.element_rest_length[e]
            sx, sy, sz = quat_rotate_inv(qw, qx, qy, qz, x[v0 + i + 1, 0] - x[v0 + i, 0],
                                         x[v0 + i + 1, 1] - x[v0 + i, 1], x[v0 + i + 1, 2] - x[v0 + i, 2])
            k = model.element_stiffness
            ex, ey, ez = sx / l0, sy / l0, sz / l0 - 1.0
            u += 0.5 * l0 * (k[e, 0] * ex * ex + k[e, 1] * ey * ey + k[e, 2] * ez * ez)
        else:
            qw, qx, qy, qz = end_frame(model, state, 2 * l + 1)
        tx, ty, tz, c = relative_rotation(pw, px, py, pz, qw, qx, qy, qz)
        mx, my, mz = bend_moment(model, v0 + i, tx, ty, tz)
        b = model.voronoi_stiffness.T
        k = v0 + i
        u += 0.5 * model.voronoi_rest_length[k] * (mx * mx / b[0, k] + my * my / b[1, k] + mz * mz / b[2, k])
        pw, px, py, pz = qw, qx, qy, qz
    return u
