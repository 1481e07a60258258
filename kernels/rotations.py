"""Unit-quaternion algebra, and the small linear algebra beside it, on scalars (no allocation).

Convention: q = (w, x, y, z) maps body components to lab components, D = R(q) with columns
d1 d2 d3 (2.16)-(2.19). A body-frame rotation vector phi updates q <- q * exp(phi), so the
body-frame angular velocity w obeys q' = q * (0, w) / 2, i.e. Lambda(w^d) = D^T D' (2.26).
"""

import math

from numba import njit

from .compiler import INNER
from .elementary import atan_ratio, sin_cos

OPTS = INNER   # the scalar helpers below


@njit(**OPTS)
def quat_mul(aw, ax, ay, az, bw, bx, by, bz):
    """Return the Hamilton product a * b."""
    return (aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw)


@njit(**OPTS)
def quat_exp(px, py, pz):
    """Return exp(phi) for the rotation vector phi (angle |phi| about phi/|phi|)."""
    a2 = px * px + py * py + pz * pz
    if a2 < 1e-12:
        # cos(a/2), sin(a/2)/a to O(a^4)
        c = 1.0 - a2 / 8.0 + a2 * a2 / 384.0
        s = 0.5 - a2 / 48.0 + a2 * a2 / 3840.0
    else:
        a = math.sqrt(a2)
        s, c = sin_cos(0.5 * a)   # (kernels/elementary.py: inlined where the library's are calls)
        s /= a
    return c, s * px, s * py, s * pz


@njit(**OPTS)
def axis_quat(x, a):
    """Return exp(x a) for the unit axis a (a 3-tuple): (cos x/2, sin x/2 a), without
    quat_exp's norm, division and branch (the joints' lanes, kernels/joint_lanes.py: a loop
    calling quat_exp twice did not get it inlined)."""
    s, c = sin_cos(0.5 * x)
    return c, s * a[0], s * a[1], s * a[2]


@njit(**OPTS)
def quat_normalize(w, x, y, z):
    """Return q / |q|."""
    n = 1.0 / math.sqrt(w * w + x * x + y * y + z * z)
    return w * n, x * n, y * n, z * n


@njit(**OPTS)
def quat_log(w, x, y, z):
    """Return the rotation vector theta (|theta| <= pi) of the unit quaternion q. (Selects, not
    branches, and atan_ratio for the library's atan2, a call: a loop over joints runs it in
    vector lanes, kernels/joint_lanes.settle_balls.)"""
    sg = -1.0 if w < 0.0 else 1.0
    w, x, y, z = sg * w, sg * x, sg * y, sg * z
    s2 = x * x + y * y + z * z
    s = math.sqrt(s2)
    r = s2 / (w * w)
    series = (2.0 / w) * (1.0 - r / 3.0 + r * r / 5.0)
    f = series if s < 1e-4 * w else 2.0 * atan_ratio(s, w) / s
    return f * x, f * y, f * z


@njit(**OPTS)
def quat_rotate(w, x, y, z, vx, vy, vz):
    """Return R(q) v (body -> lab)."""
    # t = 2 q_vec x v ; v' = v + w t + q_vec x t
    tx = 2.0 * (y * vz - z * vy)
    ty = 2.0 * (z * vx - x * vz)
    tz = 2.0 * (x * vy - y * vx)
    return (vx + w * tx + (y * tz - z * ty),
            vy + w * ty + (z * tx - x * tz),
            vz + w * tz + (x * ty - y * tx))


@njit(**OPTS)
def quat_rotate_inv(w, x, y, z, vx, vy, vz):
    """Return R(q)^T v (lab -> body)."""
    return quat_rotate(w, -x, -y, -z, vx, vy, vz)


@njit(**OPTS)
def cross(ax, ay, az, bx, by, bz):
    """Return a x b."""
    return ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx


# |r_vec|^2 < SMALL_TURN2 r_w^2, i.e. tan(|theta|/2) < 0.1: |theta| below about 0.2 rad,
# where small_rotation's series holds to round-off
SMALL_TURN2 = 0.01


@njit(**OPTS)
def relative_quat(aw, ax, ay, az, bw, bx, by, bz):
    """Return (r, small): r = A^T B with r_w >= 0, and whether |theta| < 0.2 (the range of
    small_rotation)."""
    rw, rx, ry, rz = quat_mul(aw, -ax, -ay, -az, bw, bx, by, bz)
    sg = 1.0 if rw >= 0.0 else -1.0   # a select, not a branch: the loops stay vectorisable
    rw, rx, ry, rz = sg * rw, sg * rx, sg * ry, sg * rz
    return rw, rx, ry, rz, rx * rx + ry * ry + rz * rz < SMALL_TURN2 * rw * rw


@njit(**OPTS)
def small_rotation(rw, rx, ry, rz):
    """Return (theta, c) of relative_rotation for a unit quaternion r with r_w > 0 and
    |theta| < 0.2, by series (no branch, no trig): theta = (2/w) atan(x)/x r_vec, x = s/w."""
    s2 = rx * rx + ry * ry + rz * rz
    iw = 1.0 / rw   # (one division for x2 and f: a bending pass's costliest operation)
    x2 = s2 * (iw * iw)
    # atan(x)/x = sum (-x2)^j / (2j + 1), Horner to j = 8 (written out: loops over tuples
    # become switches, which stop vectorisation)
    p = 1.0 / 15.0 - x2 / 17.0
    p = 1.0 / 13.0 - x2 * p
    p = 1.0 / 11.0 - x2 * p
    p = 1.0 / 9.0 - x2 * p
    p = 1.0 / 7.0 - x2 * p
    p = 1.0 / 5.0 - x2 * p
    p = 1.0 / 3.0 - x2 * p
    p = 1.0 - x2 * p
    f = 2.0 * p * iw
    t2 = f * f * s2
    c = 1.0 / 12.0 + t2 * (1.0 / 720.0 + t2 * (1.0 / 30240.0 + t2 * (1.0 / 1209600.0 + t2 / 47900160.0)))
    return f * rx, f * ry, f * rz, c


@njit(**OPTS)
def relative_rotation(aw, ax, ay, az, bw, bx, by, bz):
    """Return (theta, c): the rotation vector of A^T B (its components agree in both frames)
    and c(theta) = 1/theta^2 - (1 + cos theta)/(2 theta sin theta) of the inverse Jacobians."""
    rw, rx, ry, rz, small = relative_quat(aw, ax, ay, az, bw, bx, by, bz)
    return rotation_of(rw, rx, ry, rz, small)


@njit(**OPTS, inline="always")
def rotation_of(rw, rx, ry, rz, small):
    """Return relative_rotation's (theta, c) of the unit quaternion r (r_w >= 0) and whether
    |theta| < 0.2, as relative_quat gives them (inlined: relative_rotation's code as before)."""
    if small:
        return small_rotation(rw, rx, ry, rz)
    s2 = rx * rx + ry * ry + rz * rz
    tx, ty, tz = quat_log(rw, rx, ry, rz)
    theta2 = tx * tx + ty * ty + tz * tz
    # with cos(theta/2) = w and sin(theta/2) = s: (1 + cos)/(2 theta sin) = w/(2 theta s)
    c = 1.0 / theta2 - rw / (2.0 * math.sqrt(theta2 * s2))
    return tx, ty, tz, c


@njit(**OPTS)
def exp_rates(rx, ry, rz, dx, dy, dz, ex, ey, ez):
    """Return (omega, alpha), each a 3-tuple: the lab angular velocity and acceleration of
    R(t) = exp(r(t)) given r, r' = d and r'' = e. omega = J(r) r' with the left Jacobian
    J = 1 + a [r] + b [r]^2, a = (1 - cos t)/t^2, b = (t - sin t)/t^3 (t = |r|); alpha is its
    time derivative. a, b and their derivatives in t^2 are smooth at t = 0 (series there)."""
    x = rx * rx + ry * ry + rz * rz
    if x < 0.01:
        a = 0.5 - x * (1.0 / 24.0 - x * (1.0 / 720.0 - x / 40320.0))
        b = 1.0 / 6.0 - x * (1.0 / 120.0 - x * (1.0 / 5040.0 - x / 362880.0))
        da = -1.0 / 24.0 + x * (2.0 / 720.0 - x * (3.0 / 40320.0 - x * 4.0 / 3628800.0))
        db = -1.0 / 120.0 + x * (2.0 / 5040.0 - x * (3.0 / 362880.0 - x * 4.0 / 39916800.0))
    else:
        t = math.sqrt(x)
        s, c = sin_cos(t)
        a = (1.0 - c) / x
        b = (t - s) / (x * t)
        da = (t * s - 2.0 + 2.0 * c) / (2.0 * x * x)
        db = ((1.0 - c) * t - 3.0 * (t - s)) / (2.0 * x * x * t)
    rd = 2.0 * (rx * dx + ry * dy + rz * dz)   # d(t^2)/dt
    ux, uy, uz = cross(rx, ry, rz, dx, dy, dz)               # r x r'
    vx, vy, vz = cross(rx, ry, rz, ux, uy, uz)               # r x (r x r')
    wx, wy, wz = cross(rx, ry, rz, ex, ey, ez)               # r x r''
    yx, yy, yz = cross(rx, ry, rz, wx, wy, wz)               # r x (r x r'')
    zx, zy, zz = cross(dx, dy, dz, ux, uy, uz)               # r' x (r x r')
    omega = (dx + a * ux + b * vx, dy + a * uy + b * vy, dz + a * uz + b * vz)
    fa, fb = da * rd, db * rd
    alpha = (ex + fa * ux + a * wx + fb * vx + b * (zx + yx),
             ey + fa * uy + a * wy + fb * vy + b * (zy + yy),
             ez + fa * uz + a * wz + fb * vz + b * (zz + yz))
    return omega, alpha


@njit(**OPTS, inline="always")
def inverse_sym3(a00, a01, a02, a11, a12, a22):
    """Return A^-1 (b00, b01, b02, b11, b12, b22) of the symmetric invertible A (its adjugate
    over its determinant)."""
    c00, c01, c02 = a11 * a22 - a12 * a12, a02 * a12 - a01 * a22, a01 * a12 - a02 * a11
    c11, c12, c22 = a00 * a22 - a02 * a02, a01 * a02 - a00 * a12, a00 * a11 - a01 * a01
    inv = 1.0 / (a00 * c00 + a01 * c01 + a02 * c02)
    return c00 * inv, c01 * inv, c02 * inv, c11 * inv, c12 * inv, c22 * inv


@njit(**OPTS, inline="always")
def solve_sym3(a00, a01, a02, a11, a12, a22, b0, b1, b2):
    """Return x with A x = b for the symmetric positive definite A (Cramer's rule)."""
    c00 = a11 * a22 - a12 * a12
    c01 = a02 * a12 - a01 * a22
    c02 = a01 * a12 - a02 * a11
    c11 = a00 * a22 - a02 * a02
    c12 = a01 * a02 - a00 * a12
    c22 = a00 * a11 - a01 * a01
    inv = 1.0 / (a00 * c00 + a01 * c01 + a02 * c02)
    return ((c00 * b0 + c01 * b1 + c02 * b2) * inv, (c01 * b0 + c11 * b1 + c12 * b2) * inv,
            (c02 * b0 + c12 * b1 + c22 * b2) * inv)
