"""Kernels of the medium's Airy waves: the surface elevation and the particle velocity and
acceleration of a sum of linear components at the vertices of a line (kernels/fluid.py takes
them into its sample), in passes over a line's vertices that LLVM vectorises.

A component's kinematics take a sine, a cosine and an exponential at every vertex and kick;
the C library's are calls a loop cannot vectorise, which cost several times a dry line's
whole step. Those below are the C library's own algorithms (fdlibm's: Cody-Waite
reduction, then its minimax polynomials), written branch-free so that a loop over vertices
runs them in vector lanes, each within an ulp or two of the library's value. They are
compiled without fast-math: reassociation would undo the reduction's exact steps (LLVM
inlines them into the fast-math passes with their own flags)."""

import math

from numba import njit, types
from numba.extending import intrinsic
from llvmlite import ir

from .backend import PASS
from .compiler import CACHED_INLINE, CACHED_LANES
from .layout import uint

# pi/2 in three parts of 33 bits each: n * part is exact for |n| < 2**20, so the reduction of
# an argument below REDUCED_RANGE loses nothing (fdlibm's __ieee754_rem_pio2, medium case)
PIO2_1, PIO2_2, PIO2_3 = 1.57079632673412561417e+00, 6.07710050630396597660e-11, 2.02226624871116645580e-21
TWO_OVER_PI = 6.36619772367581382433e-01
REDUCED_RANGE = 2.0 ** 19 * math.pi   # |x| below which sin_cos is within two ulps
S1, S2, S3 = -1.66666666666666324348e-01, 8.33333333332248946124e-03, -1.98412698298579493134e-04
S4, S5, S6 = 2.75573137070700676789e-06, -2.50507602534068634195e-08, 1.58969099521155010221e-10
C1, C2, C3 = 4.16666666666666019037e-02, -1.38888888888741095749e-03, 2.48015872894767294178e-05
C4, C5, C6 = -2.75573143513906633035e-07, 2.08757232129817482790e-09, -1.13596475577881948265e-11
# exp: x = n ln2 + r, |r| <= ln2 / 2, ln2 in two parts (fdlibm's __ieee754_exp)
LN2_HI, LN2_LO, INV_LN2 = 6.93147180369123816490e-01, 1.90821492927058770002e-10, 1.44269504088896338700e+00
P1, P2, P3 = 1.66666666666666019037e-01, -2.77777777770155933842e-03, 6.61375632143793436117e-05
P4, P5 = -1.65339022054652515390e-06, 4.13813679705723846039e-08
EXP_FLOOR = -708.0   # exp_nonpositive's arguments are raised to this: 2**n stays a normal number


@intrinsic
def _double_of_bits(typingctx, bits):
    """The float64 whose IEEE bits are the int64 ``bits`` (a bitcast, which vectorises)."""
    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.DoubleType())
    return types.float64(types.int64), codegen


@njit(**CACHED_LANES)
def sin_cos(x):
    """Return (sin x, cos x), within two ulps for |x| < REDUCED_RANGE (beyond it the reduction
    keeps about 53 - log2(|x| / REDUCED_RANGE) bits)."""
    n = math.floor(x * TWO_OVER_PI + 0.5)
    r = ((x - n * PIO2_1) - n * PIO2_2) - n * PIO2_3
    z = r * r
    s = r + r * z * (S1 + z * (S2 + z * (S3 + z * (S4 + z * (S5 + z * S6)))))
    c = 1.0 - 0.5 * z + z * z * (C1 + z * (C2 + z * (C3 + z * (C4 + z * (C5 + z * C6)))))
    q = int(n) & 3   # the quadrant: x = q pi/2 + r (mod 2 pi)
    swap = (q & 1) == 1
    sign_s = 1.0 - 2.0 * ((q >> 1) & 1)
    sign_c = 1.0 - 2.0 * (((q + 1) >> 1) & 1)
    return sign_s * (c if swap else s), sign_c * (s if swap else c)


@njit(**CACHED_LANES)
def exp_nonpositive(x):
    """Return exp(max(x, EXP_FLOOR)) for x <= 0 (exp(-708) = 3e-308: below it, a depth
    factor's exponential is nil to any use), within an ulp of the library's exp."""
    x = min(max(x, EXP_FLOOR), 0.0)
    n = math.floor(x * INV_LN2 + 0.5)
    hi = x - n * LN2_HI
    lo = n * LN2_LO
    r = hi - lo
    t = r * r
    c = r - t * (P1 + t * (P2 + t * (P3 + t * (P4 + t * P5))))
    y = 1.0 - ((lo - (r * c) / (2.0 - c)) - hi)
    return y * _double_of_bits((int(n) + 1023) << 52)


@njit(**CACHED_INLINE)
def depth_factors(k, zs, e2, inv_s):
    """Return cosh(k (zs + d)) / sinh(k d) and sinh(k (zs + d)) / sinh(k d) at zs <= 0 below
    the still surface over depth d, given e2 = exp(-2 k d) and inv_s = 1 / (1 - e2) (wave_depth;
    e2 = 0, inv_s = 1 in deep water), written with one exponential, which neither overflows
    in deep water nor loses the finite-depth term."""
    e = exp_nonpositive(k * zs)
    r = e2 / e
    return (e + r) * inv_s, (e - r) * inv_s


@njit(**CACHED_INLINE)
def wave_depth(k, d):
    """Return (e2, inv_s) of depth_factors for wave number k over depth d (inf: deep)."""
    if math.isinf(d):
        return 0.0, 1.0
    e2 = math.exp(-2.0 * k * d)
    return e2, 1.0 / (1.0 - e2)


@njit(**CACHED_LANES)
def wave_phase(w, phase, t):
    """Return phase - w t reduced to [-pi, pi]: the time's share of a component's argument, so
    that the argument at a vertex stays small however long the run."""
    a = phase - w * t
    n = math.floor(a * (0.25 * TWO_OVER_PI) + 0.5)   # whole turns: 2 pi = 4 (pi/2), in the parts above
    return ((a - n * (4.0 * PIO2_1)) - n * (4.0 * PIO2_2)) - n * (4.0 * PIO2_3)


@njit(**PASS)
def add_elevation(x, y, eta, lo, n, a, kx, ky, phi):
    """Update eta at the n vertices lo.. by one component's elevation a cos(kx x + ky y + phi)
    (x, y: the position columns)."""
    for k in range(n):
        i = lo + uint(k)
        eta[i] += a * sin_cos(kx * x[i] + ky * y[i] + phi)[1]


@njit(**CACHED_INLINE)
def stretched(zeta, eta, depth, stretch):
    """Return the height below the still surface at which the waves' kinematics are taken at
    a wet point zeta above it under the waved surface eta: Wheeler's (stretch 1: the wet
    column [-depth, eta] mapped onto [-depth, 0]) or zeta held at the still surface above it."""
    if stretch == 1:
        s = zeta - eta if math.isinf(depth) else depth * (zeta - eta) / (depth + eta)
    else:
        s = zeta
    return min(s, 0.0)


@njit(**CACHED_INLINE)
def component(a, w, k, cos_h, sin_h, th, zs, e2, inv_s):
    """Return the velocity and acceleration (ux, uy, uz, ax, ay, az) of one Airy component
    (amplitude a, angular frequency w, wave number k, heading (cos_h, sin_h); e2, inv_s:
    wave_depth) at a point of argument th at the height zs (stretched)."""
    st, ct = sin_cos(th)
    ch, sh = depth_factors(k, zs, e2, inv_s)
    uh, ah = a * w * ch * ct, a * w * w * ch * st
    return uh * cos_h, uh * sin_h, a * w * sh * st, ah * cos_h, ah * sin_h, -a * w * w * sh * ct


@njit(**PASS)
def sample_depths(z, eta, wet, zs, lo, n, surface, depth, stretch):
    """Update wet (1 below the waved surface eta, else 0) and zs (stretched: the height at
    which the waves' kinematics are taken, 0 where dry) at the n vertices lo.. given their
    heights z."""
    for k in range(n):
        i = lo + uint(k)
        zeta = z[i] - surface
        under = zeta <= eta[i]
        wet[i] = 1.0 if under else 0.0
        zs[i] = stretched(zeta, eta[i], depth, stretch) if under else 0.0


@njit(**PASS)
def add_kinematics(x, y, zs, wet, U, A, lo, n, a, w, k, cos_h, sin_h, phi, e2, inv_s):
    """Update U and A (three columns each: the medium's velocity and acceleration) at the n
    vertices lo.. by one component's (component; phi its phase at this time, wave_phase) where
    they are wet, at the heights zs (sample_depths)."""
    kx, ky = k * cos_h, k * sin_h
    for j in range(n):
        i = lo + uint(j)
        ux, uy, uz, ax, ay, az = component(a, w, k, cos_h, sin_h, kx * x[i] + ky * y[i] + phi, zs[i], e2, inv_s)
        m = wet[i]
        U[0][i] += ux * m
        U[1][i] += uy * m
        U[2][i] += uz * m
        A[0][i] += ax * m
        A[1][i] += ay * m
        A[2][i] += az * m
