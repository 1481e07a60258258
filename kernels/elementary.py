"""Elementary functions written so that a loop over vertices or elements runs them in vector
lanes, and a scalar caller inlines them: the C library's sine, cosine, exponential and
arctangent are calls, which no loop vectorises and which a scalar kernel (a joint's
rotation, at every step) pays as calls all the same. These are the C library's own algorithms (fdlibm's:
Cody-Waite reduction, then its minimax polynomials), branch-free, each within an ulp or two
of the library's value. They are compiled without fast-math: reassociation would undo the
reduction's exact steps (LLVM inlines them into fast-math callers with their own flags)."""

import math

from llvmlite import ir
from numba import njit, types
from numba.extending import intrinsic

from .compiler import CACHED_LANES

# pi/2 in three parts of 33 bits each: n * part is exact for |n| < 2**20, so the reduction of
# an argument below REDUCED_RANGE loses nothing (fdlibm's __ieee754_rem_pio2, medium case)
PIO2_1, PIO2_2, PIO2_3 = 1.57079632673412561417e+00, 6.07710050630396597660e-11, 2.02226624871116645580e-21
TWO_OVER_PI = 6.36619772367581382433e-01
REDUCED_RANGE = 2.0 ** 19 * math.pi   # |x| below which sin_cos is within two ulps (sin_cos)
S1, S2, S3 = -1.66666666666666324348e-01, 8.33333333332248946124e-03, -1.98412698298579493134e-04
S4, S5, S6 = 2.75573137070700676789e-06, -2.50507602534068634195e-08, 1.58969099521155010221e-10
C1, C2, C3 = 4.16666666666666019037e-02, -1.38888888888741095749e-03, 2.48015872894767294178e-05
C4, C5, C6 = -2.75573143513906633035e-07, 2.08757232129817482790e-09, -1.13596475577881948265e-11
# exp: x = n ln2 + r, |r| <= ln2 / 2, ln2 in two parts (fdlibm's __ieee754_exp)
LN2_HI, LN2_LO, INV_LN2 = 6.93147180369123816490e-01, 1.90821492927058770002e-10, 1.44269504088896338700e+00
P1, P2, P3 = 1.66666666666666019037e-01, -2.77777777770155933842e-03, 6.61375632143793436117e-05
P4, P5 = -1.65339022054652515390e-06, 4.13813679705723846039e-08
EXP_FLOOR = -708.0   # exp_nonpositive's arguments are raised to this: 2**n stays a normal number
# atan on |t| <= 7/16 (fdlibm's s_atan.c), pi/4 and pi/2 in two parts
AT0, AT1, AT2 = 3.33333333333329318027e-01, -1.99999999998764832476e-01, 1.42857142725034663711e-01
AT3, AT4, AT5 = -1.11111104054623557880e-01, 9.09088713343650656196e-02, -7.69187620504482999495e-02
AT6, AT7, AT8 = 6.66107313738753120669e-02, -5.83357013379057348645e-02, 4.97687799461593236017e-02
AT9, AT10 = -3.65315727442169155270e-02, 1.62858201153657823623e-02
QUARTER_PI_HI, QUARTER_PI_LO = 7.85398163397448278999e-01, 3.06161699786838301793e-17
HALF_PI_HI, HALF_PI_LO = 1.57079632679489655800e+00, 6.12323399573676603587e-17
TAN_PI_8 = 0.41421356237309503   # above it atan t = pi/4 + atan((t - 1)/(t + 1)), that within 7/16


@intrinsic
def _double_of_bits(typingctx, bits):
    """The float64 whose IEEE bits are the int64 ``bits`` (a bitcast, which vectorises)."""
    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.DoubleType())
    return types.float64(types.int64), codegen


@njit(**CACHED_LANES)
def sin_cos(x):
    """Return (sin x, cos x), within two ulps for |x| < REDUCED_RANGE, or 1e-30 per radian of
    x near a zero (the reduction's residue; beyond REDUCED_RANGE it keeps about
    53 - log2(|x| / REDUCED_RANGE) bits)."""
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


@njit(**CACHED_LANES)
def atan_ratio(y, x):
    """Return atan2(y, x) for y >= 0 and x >= 0, in [0, pi/2] (0 for y = x = 0), within an ulp
    or two of the library's: the smaller over the larger, reduced below tan(pi/8) about pi/4,
    then fdlibm's polynomial, with pi/2 less it where y > x."""
    big = y > x
    num, den = (x if big else y), (y if big else x)
    z = num / den if den > 0.0 else 0.0
    mid = z > TAN_PI_8
    t = (z - 1.0) / (z + 1.0) if mid else z
    tt = t * t
    w = tt * tt
    s1 = tt * (AT0 + w * (AT2 + w * (AT4 + w * (AT6 + w * (AT8 + w * AT10)))))
    s2 = w * (AT1 + w * (AT3 + w * (AT5 + w * (AT7 + w * AT9))))
    a = t - t * (s1 + s2)
    a = QUARTER_PI_HI - ((t * (s1 + s2) - QUARTER_PI_LO) - t) if mid else a
    return HALF_PI_HI - (a - HALF_PI_LO) if big else a
