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

from .rotations import FAST, cross, quat_mul, quat_rotate, quat_rotate_inv, relative_rotation


@njit(cache=True, inline="always", fastmath=FAST)
def bend_moment(model, k, theta_x, theta_y, theta_z):
    """Return m = B (theta/L - u0) at Voronoi point k (principal frame) (3.22)."""
    inv_l = model.voronoi_inv_rest_length[k]
    b = model.voronoi_stiffness[k]
    u0 = model.voronoi_rest_curvature[k]
    return (b[0] * (theta_x * inv_l - u0[0]),
            b[1] * (theta_y * inv_l - u0[1]),
            b[2] * (theta_z * inv_l - u0[2]))


@njit(cache=True, inline="always", fastmath=FAST)
def bend_torques(tx, ty, tz, c, mx, my, mz):
    """Return the body torques on the left frame (+J_r^-1 m) and right frame (-J_l^-1 m) of a
    Voronoi point with relative rotation theta and bending moment m."""
    ax, ay, az = cross(tx, ty, tz, mx, my, mz)
    bx, by, bz = cross(tx, ty, tz, ax, ay, az)
    sx, sy, sz = mx + c * bx, my + c * by, mz + c * bz
    return (sx + 0.5 * ax, sy + 0.5 * ay, sz + 0.5 * az,
            -(sx - 0.5 * ax), -(sy - 0.5 * ay), -(sz - 0.5 * az))


@njit(cache=True, inline="always", fastmath=FAST)
def end_frame(model, state, a):
    """Return the quaternion of line end a's director frame D(nu) X(nu, lambda) (1.3)."""
    nq = state.node_q[model.attach_node[a]]
    xq = model.attach_frame[a]
    return quat_mul(nq[0], nq[1], nq[2], nq[3], xq[0], xq[1], xq[2], xq[3])


@njit(**STEP)  # not inline="always": called inside prange (see backend.py)
def compute_line_loads(l, model, state, loads):
    """Update loads.f, loads.tau, loads.end_tau of line l given state.x, state.q, state.node_q
    (3.2)-(3.3), (3.22)-(3.25)."""
    x, q, f, tau = state.x, state.q, loads.f, loads.tau
    v0 = model.line_vertex_offsets[l]
    e0 = model.line_element_offsets[l]
    n = model.line_element_offsets[l + 1] - e0
    pw, px, py, pz = end_frame(model, state, 2 * l)
    f[v0, 0] = 0.0
    f[v0, 1] = 0.0
    f[v0, 2] = 0.0
    for i in range(n):
        e = e0 + i
        qw, qx, qy, qz = q[e, 0], q[e, 1], q[e, 2], q[e, 3]
        # stretch and shear: sigma = D^T r'/l - e3, n = K sigma
        inv_l = model.element_inv_rest_length[e]
        sx, sy, sz = quat_rotate_inv(qw, qx, qy, qz, x[v0 + i + 1, 0] - x[v0 + i, 0],
                                     x[v0 + i + 1, 1] - x[v0 + i, 1], x[v0 + i + 1, 2] - x[v0 + i, 2])
        k = model.element_stiffness[e]
        nx, ny, nz = k[0] * sx * inv_l, k[1] * sy * inv_l, k[2] * (sz * inv_l - 1.0)
        fx, fy, fz = quat_rotate(qw, qx, qy, qz, nx, ny, nz)
        f[v0 + i, 0] += fx
        f[v0 + i, 1] += fy
        f[v0 + i, 2] += fz
        f[v0 + i + 1, 0] = -fx
        f[v0 + i + 1, 1] = -fy
        f[v0 + i + 1, 2] = -fz
        cx, cy, cz = cross(sx, sy, sz, nx, ny, nz)  # r' x n in the body frame (3.3)
        # bend and twist at the Voronoi point before element e
        tx, ty, tz, c = relative_rotation(pw, px, py, pz, qw, qx, qy, qz)
        mx, my, mz = bend_moment(model, v0 + i, tx, ty, tz)
        lx, ly, lz, rx, ry, rz = bend_torques(tx, ty, tz, c, mx, my, mz)
        if i == 0:
            et = loads.end_tau[2 * l]
            et[0], et[1], et[2] = lx, ly, lz
        else:
            tau[e - 1, 0] += lx
            tau[e - 1, 1] += ly
            tau[e - 1, 2] += lz
        tau[e, 0] = cx + rx
        tau[e, 1] = cy + ry
        tau[e, 2] = cz + rz
        pw, px, py, pz = qw, qx, qy, qz
    # the Voronoi point joining the last element to the end node's frame
    bw, bx, by, bz = end_frame(model, state, 2 * l + 1)
    tx, ty, tz, c = relative_rotation(pw, px, py, pz, bw, bx, by, bz)
    mx, my, mz = bend_moment(model, v0 + n, tx, ty, tz)
    lx, ly, lz, rx, ry, rz = bend_torques(tx, ty, tz, c, mx, my, mz)
    e = e0 + n - 1
    tau[e, 0] += lx
    tau[e, 1] += ly
    tau[e, 2] += lz
    et = loads.end_tau[2 * l + 1]
    et[0], et[1], et[2] = rx, ry, rz


@njit(**STEP)
def compute_internal_loads(model, state, loads):
    """Update loads.f (nv,3), loads.tau (ne,3), loads.end_tau (na,3) given the state: the
    internal force and torque balances (3.2)/(3.3) of every line."""
    for l in range(model.line_vertex_offsets.shape[0] - 1):
        compute_line_loads(l, model, state, loads)


@njit(cache=True, fastmath=FAST, parallel=True)
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
            k = model.element_stiffness[e]
            ex, ey, ez = sx / l0, sy / l0, sz / l0 - 1.0
            u += 0.5 * l0 * (k[0] * ex * ex + k[1] * ey * ey + k[2] * ez * ez)
        else:
            qw, qx, qy, qz = end_frame(model, state, 2 * l + 1)
        tx, ty, tz, c = relative_rotation(pw, px, py, pz, qw, qx, qy, qz)
        mx, my, mz = bend_moment(model, v0 + i, tx, ty, tz)
        b = model.voronoi_stiffness[v0 + i]
        u += 0.5 * model.voronoi_rest_length[v0 + i] * (mx * mx / b[0] + my * my / b[1] + mz * mz / b[2])
        pw, px, py, pz = qw, qx, qy, qz
    return u
