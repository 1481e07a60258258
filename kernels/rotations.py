"""Unit-quaternion algebra on scalars (no allocation).

Convention: q = (w, x, y, z) maps body components to lab components, D = R(q) with columns
d1 d2 d3 (2.16)-(2.19). A body-frame rotation vector phi updates q <- q * exp(phi), so the
body-frame angular velocity w obeys q' = q * (0, w) / 2, i.e. Lambda(w^d) = D^T D' (2.26).
"""

import hashlib
import math
import os
import pickle

import numba
from llvmlite import binding as llvm
from numba import njit
from numba.core import codegen


def _use_own_copies():
    """Make every compiled library call its own copies of the functions it links in.

    Numba links a callee into each caller's module as a ``linkonce_odr`` copy, and the copy is
    optimised again with its caller (inlined, or re-vectorised with fast-math: other
    instructions, other rounding). The JIT then resolves such a weak symbol to the first
    definition it has seen: in a process that compiled the callee first, that is the callee's
    own library; in one that loads the caller from the cache, the caller's copy. The same step
    thus ran different code cold and warm (and in a run resumed after a kill mid-compilation),
    and its results differed in the last bits. Internal copies are never shared, so a
    library's code is the same whether it was compiled here or loaded. (Numba's runtime
    helpers NRT_* keep their linkage: its reference-count pruning finds them by name.)"""
    cls = getattr(codegen, "CPUCodeLibrary", None)
    optimize = getattr(cls, "_optimize_final_module", None)
    if optimize is None or getattr(optimize, "own_copies", False):
        return   # already done, or a numba built otherwise: results stay correct, only not
                 # bit-identical between a cold and a warm cache (tests/test_reproducible.py)

    def optimize_own_copies(self):
        for fn in self._final_module.functions:
            if (not fn.is_declaration and fn.linkage == llvm.Linkage.linkonce_odr
                    and not fn.name.startswith("NRT_")):
                fn.linkage = llvm.Linkage.internal
        optimize(self)
    optimize_own_copies.own_copies = True
    cls._optimize_final_module = optimize_own_copies


_use_own_copies()


def _lock_cache_saves():
    """Make numba's on-disk cache safe for processes saving into one directory at once
    (the test workers, a sweep's workers, two runs started together).

    Numba saves an overload by reading the function's index, picking the first data-file
    name that index does not use, and writing both back. Two processes doing so at once
    each start from their own copy of the index: one's entry is dropped, or both pick one
    file name for different overloads, and the index can then send one signature to the
    other's code. Each save here holds an exclusive lock on a file beside the index from
    reading it to writing the data, so saves follow one another; loads need no lock (the
    index and data files are replaced atomically, and an index naming data not yet written
    reads as a cache miss). Where fcntl is missing (Windows) saves stay as numba makes them:
    give parallel processes separate NUMBA_CACHE_DIRs there."""
    try:
        import fcntl
    except ImportError:
        return
    from numba.core import caching
    cls = getattr(caching, "IndexDataCacheFile", None)
    save = getattr(cls, "save", None)
    if save is None or getattr(save, "locked", False):
        return

    def locked_save(self, key, data):
        with open(self._index_path + ".lock", "ab") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)   # released as the file closes, or the process dies
            save(self, key, data)
    locked_save.locked = True
    cls.save = locked_save


_lock_cache_saves()


def _describe(value):
    """Return a description of a closure cell that every process gives alike: a jitted
    function by its module, name, bytecode and own cells; anything else as it is."""
    py = getattr(value, "py_func", value)
    code = getattr(py, "__code__", None)
    if code is None:
        return value
    cells = tuple(_describe(c.cell_contents) for c in (py.__closure__ or ()))
    return (py.__module__, py.__qualname__, hashlib.sha256(code.co_code).hexdigest(), cells)


def stable_cache_key(dispatcher):
    """Give a closure compiled by ``njit(cache=True)`` a cache key that is the same in every
    process, and return it. Numba keys a closure by the pickle of its cells; a cell holding
    a jitted function pickles with a random id drawn per process, so such a closure never
    found itself in the cache: every process compiled it again and its index grew by one
    entry per process. The cells are described by what they compute instead (_describe)."""
    cache = dispatcher._cache
    if not hasattr(cache, "_index_key"):  # caching off (no cache directory)
        return dispatcher
    py = dispatcher.py_func
    cells = pickle.dumps(tuple(_describe(c.cell_contents) for c in (py.__closure__ or ())))
    code = hashlib.sha256(py.__code__.co_code).hexdigest()

    def index_key(sig, codegen):
        return (sig, codegen.magic_tuple(), (code, hashlib.sha256(cells).hexdigest()))
    cache._index_key = index_key
    return dispatcher


def _cache_options() -> dict:
    """Return the options every kernel starts from, and point numba's on-disk cache at a
    directory of this exact kernel source: "cosnet-<digest of kernels/*.py>" under
    NUMBA_CACHE_DIR, else under numba's user cache. Numba checks a cached function against
    its own file only, so a step kernel cached before a kernel it calls (in another file)
    changed would go on running the old code; a new source digest starts a fresh directory.

    Debug mode: with COSNET_BOUNDSCHECK=1 in the environment every kernel checks its indices
    (numba's boundscheck: an IndexError instead of a read or write out of bounds). Numba's
    cache keys ignore such options, so the checked builds get a directory of their own
    ("...-boundscheck"): a normal run never loads a checked kernel, nor a debug run an
    unchecked one. Likewise a build at another LLVM optimisation level (NUMBA_OPT) than
    numba's default 3 ("...-opt1"): a run at full speed never loads a less optimised kernel."""
    from numba.misc.appdirs import AppDirs
    here = os.path.dirname(os.path.abspath(__file__))
    digest = hashlib.sha256()
    for name in sorted(os.listdir(here)):
        if name.endswith(".py"):
            with open(os.path.join(here, name), "rb") as f:
                digest.update(name.encode() + b"\0" + f.read())
    check = os.environ.get("COSNET_BOUNDSCHECK", "0") not in ("", "0")
    base = numba.config.CACHE_DIR or AppDirs("numba", appauthor=False).user_cache_dir
    level = getattr(numba.config.OPT, "_raw_value", numba.config.OPT)   # 0..3 or "max"
    opt = "" if level == 3 else f"-opt{level}"
    numba.config.CACHE_DIR = os.path.join(base, f"cosnet-{digest.hexdigest()[:16]}"
                                          + ("-boundscheck" if check else "") + opt)
    return dict(cache=True, boundscheck=True) if check else dict(cache=True)


# Options every kernel starts from. The contact, joint and checksum kernels use them as they
# are, without fast-math or numpy's error model: their results are pinned bit for bit (the
# reproducibility tests, --resume), and reassociation would change them; the checksum's
# integer passes gain nothing from either.
CACHED = _cache_options()
# the same, inlined by numba where called (the joints' helpers)
CACHED_INLINE = dict(CACHED, inline="always")
# the same, for helpers called only from other kernels: without the Python entry wrapper,
# whose compilation (unboxing a record of dozens of arrays) costs more than a small body's
CACHED_INNER = dict(CACHED, no_cpython_wrapper=True, no_cfunc_wrapper=True)
# fast-math without nnan/ninf: contraction and reassociation, while NaN and infinity still
# propagate so that a blow-up stays visible to the instability watch
FAST = {"contract", "arcp", "reassoc", "nsz"}
# Division by zero gives inf/NaN (numpy's error model) rather than raising: the zero test
# python's model puts before every division is an early exit, which stops vectorisation.
KERNEL = dict(CACHED, fastmath=FAST, error_model="numpy")
# Kernels called only from other kernels: no Python entry wrapper. Numba otherwise builds and
# compiles, for every function, a wrapper unboxing its arguments from Python objects; for a
# function taking the model, state and loads records (47 arrays) that alone is most of a
# second of compilation, even for a body of one line.
INNER = dict(KERNEL, no_cpython_wrapper=True, no_cfunc_wrapper=True)
# Inlined by numba where called: for the bodies of vectorised loops whose arguments are
# tuples of arrays (left to LLVM, such calls, passing dozens of array fields, slowed the
# vectorised passes by half). Numba types an inlined body afresh at every call site, so the
# scalar helpers below are plain functions instead: compiled once, inlined by LLVM.
INLINE = dict(INNER, inline="always")
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
        c = math.cos(0.5 * a)
        s = math.sin(0.5 * a) / a
    return c, s * px, s * py, s * pz


@njit(**OPTS)
def quat_normalize(w, x, y, z):
    """Return q / |q|."""
    n = 1.0 / math.sqrt(w * w + x * x + y * y + z * z)
    return w * n, x * n, y * n, z * n


@njit(**OPTS)
def quat_log(w, x, y, z):
    """Return the rotation vector theta (|theta| <= pi) of the unit quaternion q."""
    if w < 0.0:
        w, x, y, z = -w, -x, -y, -z
    s2 = x * x + y * y + z * z
    s = math.sqrt(s2)
    if s < 1e-4 * w:
        r = s2 / (w * w)
        f = (2.0 / w) * (1.0 - r / 3.0 + r * r / 5.0)
    else:
        f = 2.0 * math.atan2(s, w) / s
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
    x2 = s2 / (rw * rw)
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
    f = 2.0 * p / rw
    t2 = f * f * s2
    c = 1.0 / 12.0 + t2 * (1.0 / 720.0 + t2 * (1.0 / 30240.0 + t2 * (1.0 / 1209600.0 + t2 / 47900160.0)))
    return f * rx, f * ry, f * rz, c


@njit(**OPTS)
def relative_rotation(aw, ax, ay, az, bw, bx, by, bz):
    """Return (theta, c): the rotation vector of A^T B (its components agree in both frames)
    and c(theta) = 1/theta^2 - (1 + cos theta)/(2 theta sin theta) of the inverse Jacobians."""
    rw, rx, ry, rz, small = relative_quat(aw, ax, ay, az, bw, bx, by, bz)
    if small:
        return small_rotation(rw, rx, ry, rz)
    s2 = rx * rx + ry * ry + rz * rz
    tx, ty, tz = quat_log(rw, rx, ry, rz)
    theta2 = tx * tx + ty * ty + tz * tz
    # with cos(theta/2) = w and sin(theta/2) = s: (1 + cos)/(2 theta sin) = w/(2 theta s)
    c = 1.0 / theta2 - rw / (2.0 * math.sqrt(theta2 * s2))
    return tx, ty, tz, c


@njit(**OPTS)
def quat_cayley(px, py, pz):
    """Return the unit quaternion (1, phi/2)/|.|: a rotation about phi by 2 atan(|phi|/2)."""
    n = 1.0 / math.sqrt(1.0 + 0.25 * (px * px + py * py + pz * pz))
    return n, 0.5 * n * px, 0.5 * n * py, 0.5 * n * pz


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
        c, s = math.cos(t), math.sin(t)
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
