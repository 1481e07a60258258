"""The arithmetic of an articulated line end (kernels/articulation.py): its boundary Voronoi
point between the joint frame and the end element, a hinge's balance and a loose ball joint's,
shared by the scalar path (kernels/articulation.py) and the vector lanes (kernels/joint_lanes.py)
that settle a net's hinges, universal joints and ball joints all at once. The helpers take numbers and
tuples, not the records: a call passes these in registers, and LLVM inlines them into the lanes'
loops, which they leave free of branches where these run them."""

import math

import numpy as np
from numba import njit

from .compiler import INLINE, INNER
from .elastic import bend_torques
from .elementary import sin_cos
from .rotations import cross, quat_exp, quat_log, quat_mul, quat_rotate, relative_quat

HINGE, UNIVERSAL, BALL = 1, 2, 3   # the number of coordinates of each kind
NEWTON_TOL = 1e-13                 # rad: a Newton step below it ends the iteration
ONE_STEP = 1e-7                    # rad: a hinge's or universal joint's exact Newton step below it is taken
                                   # without evaluating again, its loads carried to first order (error O(step^2))


@njit(**INLINE)
def dot3(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@njit(**INNER)
def boundary_quat(f, q, start, r):
    """Return (turn, small, rel) at a joint's boundary Voronoi point given the end frame F
    (quaternion f), the end element's q, whether the joint is at the line's start, and R
    (quaternion): turn = left^T right (quaternion, w >= 0; its left frame G = F R and right
    one E at a line's start, E and G at its end), whether its angle is below 0.2 rad
    (relative_quat), rel = G^T E. (Selects, not branches: settle_hinges runs it in vector
    lanes.)"""
    g = quat_mul(f[0], f[1], f[2], f[3], r[0], r[1], r[2], r[3])
    lw, lx, ly, lz = (g[0] if start else q[0]), (g[1] if start else q[1]), (g[2] if start else q[2]), \
        (g[3] if start else q[3])
    bw, bx, by, bz = (q[0] if start else g[0]), (q[1] if start else g[1]), (q[2] if start else g[2]), \
        (q[3] if start else g[3])
    rw, rx, ry, rz, small = relative_quat(lw, lx, ly, lz, bw, bx, by, bz)
    rel = (rw, rx, ry, rz) if start else (rw, -rx, -ry, -rz)
    return (rw, rx, ry, rz), small, rel


@njit(**INNER)
def inverse_jacobian(t, cc, e, x):
    """Return J x, J = 1 + e/2 [theta]x + cc [theta]x^2: J_r^-1(theta) for e = 1, J_l^-1 for
    e = -1 (bend_torques)."""
    a = cross(t[0], t[1], t[2], x[0], x[1], x[2])
    b = cross(t[0], t[1], t[2], a[0], a[1], a[2])
    return (x[0] + 0.5 * e * a[0] + cc * b[0], x[1] + 0.5 * e * a[1] + cc * b[1],
            x[2] + 0.5 * e * a[2] + cc * b[2])


@njit(**INNER)
def jacobian_rate(t, cc, c2, e, v, x):
    """Return the derivative of inverse_jacobian(theta, ...) x along theta's direction v:
    e/2 v x x + 2 c2 (theta . v) theta x (theta x x) + cc (v x (theta x x) + theta x (v x x)),
    c2 = d cc / d |theta|^2."""
    vx = cross(v[0], v[1], v[2], x[0], x[1], x[2])
    tx = cross(t[0], t[1], t[2], x[0], x[1], x[2])
    ttx = cross(t[0], t[1], t[2], tx[0], tx[1], tx[2])
    vtx = cross(v[0], v[1], v[2], tx[0], tx[1], tx[2])
    tvx = cross(t[0], t[1], t[2], vx[0], vx[1], vx[2])
    k = 2.0 * c2 * dot3(t, v)
    return (0.5 * e * vx[0] + k * ttx[0] + cc * (vtx[0] + tvx[0]),
            0.5 * e * vx[1] + k * ttx[1] + cc * (vtx[1] + tvx[1]),
            0.5 * e * vx[2] + k * ttx[2] + cc * (vtx[2] + tvx[2]))


@njit(**INNER)
def small_rate(t2):
    """Return d cc / d |theta|^2 (bend_torques' cc) at |theta|^2 = t2 below 0.04, by series."""
    return 1.0 / 720.0 + t2 * (2.0 / 30240.0 + t2 * (3.0 / 1209600.0 + t2 * 4.0 / 47900160.0))


@njit(**INNER)
def boundary_moment(t, il, u0, bend):
    """Return the boundary point's moment m = B (theta/L - u0) (3.22), il = 1/L."""
    return bend[0] * (t[0] * il - u0[0]), bend[1] * (t[1] * il - u0[1]), bend[2] * (t[2] * il - u0[2])


@njit(**INLINE)
def bend_rate(il, bend, w):
    """Return B w / L (B the boundary point's stiffness, il = 1/L)."""
    return il * bend[0] * w[0], il * bend[1] * w[1], il * bend[2] * w[2]


@njit(**INNER)
def carried_torque(t, cc, c2, e, m, w, bw, step):
    """Return the change of the end element's torque tau_E = e J m along a step of a coordinate
    whose axis J maps to w (bw = B w / L): step (D_w J m + J B w / L) (settle_hinge)."""
    dm = jacobian_rate(t, cc, c2, e, w, m)
    jb = inverse_jacobian(t, cc, e, bw)
    return step * (dm[0] + jb[0]), step * (dm[1] + jb[1]), step * (dm[2] + jb[2])


@njit(**INNER)
def node_torque(r, rel, te):
    """Return the torque on the node through the joint (X's components), -(F^T E) tau_E, given
    R, rel = G^T E and the end element's torque tau_E: the boundary point's energy depends on
    G^T E alone, so its torques on G and E cancel in the lab."""
    fe = quat_mul(r[0], r[1], r[2], r[3], rel[0], rel[1], rel[2], rel[3])   # F^T E
    n = quat_rotate(fe[0], fe[1], fe[2], fe[3], te[0], te[1], te[2])
    return -n[0], -n[1], -n[2]


@njit(**INNER)
def hinge_terms(t, cc, c2, e, m, a, il, bend):
    """Return (w, bw, q, lead, soft) of a hinge of axis a given boundary_turn's values at its
    boundary point (il = 1/L, bend B): w = J a, bw = B w / L, the line's generalised torque
    q = -e w . m on the hinge, and the two terms of its derivative (settle_hinge): the
    leading one w^T B w / L and the rest, D_w J a . m."""
    w = inverse_jacobian(t, cc, e, a)
    bw = bend_rate(il, bend, w)
    return w, bw, -e * dot3(w, m), dot3(w, bw), dot3(jacobian_rate(t, cc, c2, e, w, a), m)


@njit(**INNER)
def hinge_torques(t, cc, c2, e, m, w, bw, carried, r, rel):
    """Return (node torque, tau_E) of a hinge at its balance given its terms there
    (boundary_turn, hinge_terms), tau_E = e J m carried along a last Newton step of
    ``carried`` to first order (carried_torque) and the node's its opposite (node_torque)."""
    te = inverse_jacobian(t, cc, e, m)
    d = carried_torque(t, cc, c2, e, m, w, bw, carried)
    te = (e * te[0] + d[0], e * te[1] + d[1], e * te[2] + d[2])
    return node_torque(r, rel, te), te


@njit(**INLINE)
def cone_cosine(cone):
    """Return the cosine of a ball joint's cone (the largest angle of its d3 from X's), -inf
    for none (pi): no tilt then leaves it, whatever the rounding of the tilt's cosine."""
    return math.cos(cone) if cone < math.pi else -math.inf


@njit(**INNER)
def loose_turn(f, q, start, il, u0, prev, cos_cone):
    """Return (phi, within) of a loose ball joint (loose_ball) given its boundary point
    (boundary_point's F, q, start, 1/L, u0), phi^- = prev and its cone's cosine (cone_cosine):
    with nothing on R but
    the boundary point, the balance is where that point is unstrained, theta = L u0, G^T E =
    exp(L u0) at a line's start (E^T G at its end), so R = F^T E exp(-L u0) (exp(L u0)), in
    closed form; it is the joint's balance if R's d3 is within the cone (``within``), which
    then does not act. phi is R's rotation vector on the branch nearest prev (a turn past pi
    goes on rather than jumping back by 2 pi)."""
    rw, rx, ry, rz, _ = relative_quat(f[0], f[1], f[2], f[3], q[0], q[1], q[2], q[3])   # F^T E
    s = -1.0 / il if start else 1.0 / il
    e = quat_exp(s * u0[0], s * u0[1], s * u0[2])
    r = quat_mul(rw, rx, ry, rz, e[0], e[1], e[2], e[3])
    tx, ty, tz = quat_log(r[0], r[1], r[2], r[3])
    t = math.sqrt(tx * tx + ty * ty + tz * tz)
    inv = 1.0 / t if t > 0.0 else 0.0   # (no turn: k = 1; a select, settle_balls runs it in lanes)
    # (np.floor, a float: math.floor's integer would turn a NaN angle into a finite one)
    turns = np.floor(((tx * prev[0] + ty * prev[1] + tz * prev[2]) * inv - t) / (2.0 * math.pi) + 0.5)
    k = 1.0 + 2.0 * math.pi * turns * inv
    tx, ty, tz = k * tx, k * ty, k * tz
    # d3 of R in X, its third component 1 - 2 (x^2 + y^2): the cosine of its tilt
    within = 1.0 - 2.0 * (r[1] * r[1] + r[2] * r[2]) >= cos_cone
    return (tx, ty, tz), within


@njit(**INNER)
def boundary_pair(t, cc, m, start):
    """Return (tau_G, tau_E): the body torques of a joint's boundary point, of rotation vector t
    (cc of bend_torques) and moment m, on the joint frame G and on the end element: its left
    and right frames at a line's start, right and left at its end."""
    lx, ly, lz, rx, ry, rz = bend_torques(t[0], t[1], t[2], cc, m[0], m[1], m[2])
    return ((lx, ly, lz) if start else (rx, ry, rz)), ((rx, ry, rz) if start else (lx, ly, lz))


@njit(**INNER)
def friction_weighed(q0, static, kinetic, sliding, damping, dt):
    """Return (stays, friction) of a coordinate whose generalised torque at phi^- is q0: whether
    it sticks, its torque within the static friction (the kinetic one while ``sliding``) or its
    damper holding it over no time (a damper gives way only over time), and the kinetic
    friction torque against q0 it meets if not (0 if it sticks). (& | == False, not the
    short-circuit and, or, not: their branches kept the lanes' loop out of vector lanes.)"""
    limit = kinetic if sliding else static
    stays = (abs(q0) <= limit) | ((damping > 0.0) & ((dt > 0.0) == False))  # noqa: E712
    return stays, (0.0 if stays else math.copysign(kinetic, q0))


@njit(**INLINE)
def ball_coefficients(t2):
    """Return (a, b, alpha, beta) of the right Jacobian of exp at |phi|^2 = t2 (ball_axes):
    a = (1 - cos t)/t^2, b = (t - sin t)/t^3 and their derivatives over t, alpha = a'/t,
    beta = b'/t, by series below t^2 = 0.01, in closed form above. (Both forms computed and one
    selected, the closed one kept finite where the series are taken: the lanes then run it
    without a branch; a caller that takes a and b alone leaves the rest to LLVM to drop.)"""
    sa = 0.5 - t2 * (1.0 / 24.0 - t2 * (1.0 / 720.0 - t2 / 40320.0))
    sb = 1.0 / 6.0 - t2 * (1.0 / 120.0 - t2 * (1.0 / 5040.0 - t2 / 362880.0))
    sal = -1.0 / 12.0 + t2 * (1.0 / 180.0 - t2 / 6720.0)
    sbe = -1.0 / 60.0 + t2 * (1.0 / 1260.0 - t2 / 60480.0)
    w2 = max(t2, 0.01)
    t = math.sqrt(w2)
    st, ct = sin_cos(t)
    small = t2 < 0.01
    return ((sa if small else (1.0 - ct) / w2), (sb if small else (t - st) / (w2 * t)),
            (sal if small else (t * st - 2.0 * (1.0 - ct)) / (w2 * w2)),
            (sbe if small else ((1.0 - ct) * t - 3.0 * (t - st)) / (w2 * w2 * t)))


@njit(**INNER)
def ball_axes(p0, p1, p2):
    """Return the columns of the right Jacobian J_r(phi) = (1 - b t^2) 1 - a [phi]x + b phi phi^T
    of exp (a, b: ball_coefficients, t = |phi|): the body axes turned by d phi_0, d phi_1,
    d phi_2 (3-tuples), a and b taken once for the three."""
    t2 = p0 * p0 + p1 * p1 + p2 * p2
    a, b, _, _ = ball_coefficients(t2)
    c = 1.0 - b * t2
    b0, b1, b2 = b * p0, b * p1, b * p2
    a0, a1, a2 = a * p0, a * p1, a * p2
    return ((c + b0 * p0, b1 * p0 - a2, b2 * p0 + a1),
            (b0 * p1 + a2, c + b1 * p1, b2 * p1 - a0),
            (b0 * p2 - a1, b1 * p2 + a0, c + b2 * p2))


@njit(**INNER)
def ball_weighed(c0, c1, c2, q, static, kinetic, turning, damped, dt):
    """Return (stays, f0, f1, f2) of a ball joint whose coordinates, of body axes c0, c1, c2,
    meet the generalised torques q (3-tuple) at phi^-: whether it sticks and the friction's
    generalised torques f_i = c_i . F if not (0 if it sticks). Its friction is one torque F on
    its rotation as a whole: the joint sticks while the torque T it carries (in G's components,
    C^T T = q, C's columns the c_i) stays within the static torque (the kinetic one while
    ``turning``), or its dampers (``damped``) hold it over no time, and turns against
    F = kinetic T / |T|. (& | == False, as friction_weighed.)"""
    a = cross(c1[0], c1[1], c1[2], c2[0], c2[1], c2[2])
    b = cross(c2[0], c2[1], c2[2], c0[0], c0[1], c0[2])
    c = cross(c0[0], c0[1], c0[2], c1[0], c1[1], c1[2])
    inv = 1.0 / dot3(c0, a)   # T = (q0 (c1 x c2) + q1 (c2 x c0) + q2 (c0 x c1)) / det C (Cramer's rule)
    tx = (q[0] * a[0] + q[1] * b[0] + q[2] * c[0]) * inv
    ty = (q[0] * a[1] + q[1] * b[1] + q[2] * c[1]) * inv
    tz = (q[0] * a[2] + q[1] * b[2] + q[2] * c[2]) * inv
    size = math.sqrt(tx * tx + ty * ty + tz * tz)
    limit = kinetic if turning else static
    stays = ((size > limit) == False) | (damped & ((dt > 0.0) == False))  # noqa: E712
    k = 0.0 if stays else kinetic / size
    return stays, k * q[0], k * q[1], k * q[2]


@njit(**INNER)
def ball_axes_rate(p0, p1, p2, y):
    """Return (H00, H11, H22, H01, H02, H12), H_ik = d k_i / d phi_k . y, k_i the columns of
    J_r(phi) (ball_axes) and y a vector: with a, b, alpha, beta of ball_coefficients,
    d k_i / d phi_k = phi_k (-(beta t^2 + 2 b) e_i - alpha phi x e_i + beta phi_i phi)
    - a e_k x e_i + b phi_i e_k + b delta_ik phi."""
    t2 = p0 * p0 + p1 * p1 + p2 * p2
    a, b, al, be = ball_coefficients(t2)
    ph = (p0, p1, p2)
    z = cross(y[0], y[1], y[2], p0, p1, p2)   # (phi x e_i) . y = (y x phi)_i
    pp = dot3(ph, y)
    u = (-(be * t2 + 2.0 * b) * y[0] - al * z[0] + be * pp * p0,
         -(be * t2 + 2.0 * b) * y[1] - al * z[1] + be * pp * p1,
         -(be * t2 + 2.0 * b) * y[2] - al * z[2] + be * pp * p2)   # u_i: the part along phi_k
    # (e_k x e_i) . y: e_0 x e_1 = e_2, e_0 x e_2 = -e_1, e_1 x e_2 = e_0
    h00 = p0 * u[0] + b * y[0] * p0 + b * pp
    h11 = p1 * u[1] + b * y[1] * p1 + b * pp
    h22 = p2 * u[2] + b * y[2] * p2 + b * pp
    h01 = p1 * u[0] - a * (-y[2]) + b * y[1] * p0   # i = 0, k = 1: e_1 x e_0 = -e_2
    h02 = p2 * u[0] - a * y[1] + b * y[2] * p0      # i = 0, k = 2: e_2 x e_0 = e_1
    h12 = p2 * u[1] - a * (-y[0]) + b * y[2] * p1   # i = 1, k = 2: e_2 x e_1 = -e_0
    return h00, h11, h22, h01, h02, h12


@njit(**INNER)
def ball_exact(t, cc, c2, e, m, x, k, w):
    """Return (A00, A11, A22, A01, A02, A12) to add to a ball joint's Newton matrix
    w_i^T B w_k / L for its exact derivative, -d/d phi_k of the generalised torque -e w_i . m
    (settle_ball) at coordinates x, its axes k = (k0, k1, k2) (ball_axes) and w_i = J k_i: D_w_k
    J k_i . m (jacobian_rate), and e (d k_i / d phi_k) . J^T m, the axes turning with phi
    (ball_axes_rate)."""
    h = ball_axes_rate(x[0], x[1], x[2], inverse_jacobian(t, cc, -e, m))
    k0, k1, k2 = k
    w0, w1, w2 = w
    return (dot3(jacobian_rate(t, cc, c2, e, w0, k0), m) + e * h[0],
            dot3(jacobian_rate(t, cc, c2, e, w1, k1), m) + e * h[1],
            dot3(jacobian_rate(t, cc, c2, e, w2, k2), m) + e * h[2],
            dot3(jacobian_rate(t, cc, c2, e, w1, k0), m) + e * h[3],
            dot3(jacobian_rate(t, cc, c2, e, w2, k0), m) + e * h[4],
            dot3(jacobian_rate(t, cc, c2, e, w2, k1), m) + e * h[5])


@njit(**INNER)
def positive_sym3(a00, a01, a02, a11, a12, a22):
    """Return whether the symmetric A is positive definite (its leading minors, Sylvester)."""
    minor = a00 * a11 - a01 * a01
    return (a00 > 0.0) & (minor > 0.0) & (minor * a22 - a00 * a12 * a12 + 2.0 * a01 * a02 * a12 - a11 * a02 * a02
                                          > 0.0)
