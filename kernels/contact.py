"""Rod-rod contact: capsules along the line elements pushed apart by a damped penalty force.

Every element (the segment from vertex i to vertex i+1 of a line) is a capsule of radius r_e.
For two capsules whose centre segments come within d_min < r_i + r_j, the overlap
eps = r_i + r_j - d_min drives a force along the unit normal n (from the closest point of j
to that of i):

    f_i = H(eps) max(0, k eps - gamma (v_i - v_j) . n) n,    f_j = -f_i,

applied at the two closest points and shared between each segment's end vertices with the
barycentric weights (1 - s, s) (Elastica's rod-collision penalty; the force is clamped at zero
so that the damping never pulls). Undamped, it is the gradient of the potential k eps^2 / 2,
which contact_energy evaluates.

Friction (k_t > 0): every touching pair of elements carries a tangential spring with the
elastic-stick / plastic-slip Coulomb law of cosnet.kernels.friction (isotropic coefficients
mu_s, mu_k, the dashpot gamma / k_t beside the spring). Its displacement delta is carried
from call to call: each call turns it into the new tangent plane (keeping its length), adds
the tangential part of the relative displacement, since the previous call, of the two
material points that touched then (the parameters s, t on the two segments and their offset
x_i(s) - x_j(t) are kept), and applies the law.
The friction force -k_t delta acts on the closest point of i and +k_t delta on that of j, so
momentum is conserved exactly (the couple that the surfaces' friction would put about the
rods' axes is not modelled). The springs live in a hash table keyed by the element pair
(lower element first, the spring's data oriented from it), of fixed capacity set at bind:
two sides, the pairs of the last call and those of this one, so a pair keeps its spring
while it touches and loses it (its spring energy counted as dissipated) the call it opens.
A call with more touching pairs than the capacity raises (nothing is dropped silently).

Dashpots (gamma > 0): each call keeps the dashpot share of the forces on every vertex (the
normal -gamma v_n, with the clamp's, and a sticking spring's -gamma u_t); the account
kernel, run just before and just after each kick, adds minus their work on the mean of the
velocities either side to `dissipated`, what the kick takes from the kinetic energy through
them.

Broad phase: segments are binned by their midpoints into a uniform grid of cell size
h >= max(segment length + 2 r) (recomputed at every call), counting-sorted into T ~ 2 m
buckets (CSR-style offsets): the cells themselves, in raster order, when the bounding box holds
at most T cells, else a spatial hash of the cell. Two segments can touch only if their cells
are neighbours, so each segment scans its own cell and the 13 "forward" neighbours, then a
bounding-sphere test, then the exclusions below, and only then the closest-point narrow
phase; the cost is linear in the number of segments m. Nothing is allocated per call: all
scratch arrays live in the parameter record.

Excluded pairs (both measured along the rest arc, r_sum = r_i + r_j):
  - same line, arc gap between the segments < self_gap r_sum (self_gap = pi/2 keeps out the
    neighbours and every pair that would touch only if the centre line bent tighter than the
    radius, while a loop of the line onto itself is still caught);
  - segments of lines sharing a node whose arc distance through that node (plus the distance
    between the two line ends on the node) < node_gap[node] r_sum: adjacency through a junction,
    widened at acute junctions where the capsules overlap near the node by construction.
"""

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from .backend import ENTRY
from .compose import account_kernel, load_kernel
from .friction import plane_tangent, stick_slip, turn_into_plane
from .compiler import CACHED, CACHED_INNER

HASH_X, HASH_Y, HASH_Z = 73856093, 19349663, 83492791
COORD_LIMIT = 2.0 ** 40  # cell coordinates are clamped here (far-away points)
# the cell of a segment whose midpoint is not finite: no other cell neighbours it, so the
# segment meets nothing (the instability watch reports the non-finite state)
PARKED = -(2 ** 41)
STICK, SLIDE, TAKEN = 1, 2, -1  # friction modes of a pair (TAKEN: carried to the new side)

# cells a hair wider than the longest segment's reach: round-off never puts a touching pair
# two cells apart
CELL_MARGIN = 1.0000001


class ContactParams(NamedTuple):
    k: float                  # penalty stiffness (N/m)
    gamma: float              # damping coefficient (N s/m)
    self_contact: bool        # contact between segments of the same line
    self_gap: float           # same-line exclusion: arc gap < self_gap * r_sum
    elements: np.ndarray      # (m,) int64 elements taking part
    elem_index: np.ndarray    # (ne, 2) int64 first vertex and line of each element
    elem_geom: np.ndarray     # (ne, 4) capsule radius; rest arc from the line start to the
                              # element start, to its end; rest arc from its end to the line end
    node_gap: np.ndarray      # (nn,) junction exclusion factor of each node
    narrow_tests: np.ndarray  # (1,) int64 narrow-phase pair tests, accumulated over calls
    active: np.ndarray        # (1,) int64 overlapping pairs found by the last call
    bucket_start: np.ndarray  # (T+1,) int64 CSR offsets of the buckets (T a power of 2)
    cursor: np.ndarray        # (T,) int64 counting-sort cursor
    slot_bucket: np.ndarray   # (m,) int64 bucket of each slot (index into elements)
    slot_mid: np.ndarray      # (m, 3) segment midpoints
    slot_reach: np.ndarray    # (m,) half length + radius
    slot_cell: np.ndarray     # (m, 3) int64 grid cell
    sorted_elem: np.ndarray   # (m,) int64 elements grouped by bucket; the same order for:
    sorted_cell: np.ndarray   # (m, 3) int64 their grid cells
    sorted_mid: np.ndarray    # (m, 3) their midpoints
    sorted_reach: np.ndarray  # (m,) their reaches
    k_t: float                # tangential (stick) stiffness (N/m); 0: no friction
    mu_s: np.ndarray          # (3,) static coefficient (the same forward, backward, lateral)
    mu_k: np.ndarray          # (3,) kinetic coefficient
    pair_key: np.ndarray      # (2, C, 3) int64 per side and slot: lower element, higher
                              # element (-1: empty slot), mode (STICK, SLIDE or TAKEN)
    pair_data: np.ndarray     # (2, C, 8) spring displacement delta (3), s, t on the lower and
                              # higher element, offset x_lower(s) - x_higher(t) (3)
    pair_used: np.ndarray     # (2, C) int64 occupied slots of each side, in insertion order
    pair_state: np.ndarray    # (3,) int64 side of the last call, pairs on side 0, on side 1
    dissipated: np.ndarray    # (1,) energy dissipated by friction and the dashpots (J)
    damp: np.ndarray          # (nv, 3) dashpot forces of the last call on the vertices (gamma > 0)


@njit(**CACHED, inline="always")
def clamp01(a):
    return 0.0 if a < 0.0 else (1.0 if a > 1.0 else a)


@njit(**CACHED_INNER)
def segment_closest(px, py, pz, qx, qy, qz, ax, ay, az, bx, by, bz):
    """Return (s, t): parameters of the closest points p + s (q - p), a + t (b - a) of two
    segments, clamped to [0, 1] (Ericson, Real-Time Collision Detection, 5.1.9). Parallel
    segments take the middle of their overlap (the end nearest the other when they do not
    overlap); degenerate segments are points."""
    d1x, d1y, d1z = qx - px, qy - py, qz - pz
    d2x, d2y, d2z = bx - ax, by - ay, bz - az
    rx, ry, rz = px - ax, py - ay, pz - az
    a = d1x * d1x + d1y * d1y + d1z * d1z
    e = d2x * d2x + d2y * d2y + d2z * d2z
    f = d2x * rx + d2y * ry + d2z * rz
    tiny = 1e-300
    if a <= tiny and e <= tiny:
        return 0.0, 0.0
    if a <= tiny:
        return 0.0, clamp01(f / e)
    c = d1x * rx + d1y * ry + d1z * rz
    if e <= tiny:
        return clamp01(-c / a), 0.0
    b = d1x * d2x + d1y * d2y + d1z * d2z
    denom = a * e - b * b
    if denom > 1e-12 * a * e:
        s = clamp01((b * f - c * e) / denom)
    else:  # parallel: the other segment's extent projected on this one, [-c, b - c] / a
        lo, hi = -c / a, (b - c) / a
        if lo > hi:
            lo, hi = hi, lo
        lo, hi = max(lo, 0.0), min(hi, 1.0)
        s = 0.5 * (lo + hi) if lo <= hi else (0.0 if hi < 0.0 else 1.0)
    t = (b * s + f) / e
    if t < 0.0:
        return clamp01(-c / a), 0.0
    if t > 1.0:
        return clamp01((b - c) / a), 1.0
    return s, t


@njit(**CACHED)
def closest_points(p, q, a, b):
    """Return (s, t, distance) of the closest points of segments [p, q] and [a, b] ((3,) arrays)."""
    s, t = segment_closest(p[0], p[1], p[2], q[0], q[1], q[2], a[0], a[1], a[2], b[0], b[1], b[2])
    d = 0.0
    for k in range(3):
        u = p[k] + s * (q[k] - p[k]) - a[k] - t * (b[k] - a[k])
        d += u * u
    return s, t, math.sqrt(d)


@njit(**CACHED, inline="always")
def _hash(cx, cy, cz, mask):
    return ((cx * HASH_X) ^ (cy * HASH_Y) ^ (cz * HASH_Z)) & mask


@njit(**CACHED, inline="always")
def _cell(x, x0, h):
    y = (x - x0) / h
    if not y >= -COORD_LIMIT:  # also catches NaN (build_grid parks those segments first)
        y = -COORD_LIMIT
    elif y > COORD_LIMIT:
        y = COORD_LIMIT
    return np.int64(math.floor(y))


@njit(**CACHED, inline="always")
def _bucket(cx, cy, cz, nx, ny, nz, mask):
    """Bucket of cell (cx, cy, cz): its raster index in a dense grid (nx > 0; -1 outside the
    grid), else its hash."""
    if nx > 0:
        if cx < 0 or cy < 0 or cz < 0 or cx >= nx or cy >= ny or cz >= nz:
            return -1
        return cx + nx * (cy + ny * cz)
    return _hash(cx, cy, cz, mask)


@njit(**CACHED)
def build_grid(p, x):
    """Update the grid scratch of p given the vertex positions x: bin the segments by their
    midpoints into cells of size h >= max(length + 2 r) and counting-sort them by bucket into
    the sorted_* arrays. The buckets are the cells of a dense grid over the bounding box when
    it has at most T cells (raster order keeps neighbours close in memory), else a spatial hash
    into T buckets. Return (nx, ny, nz): the dense grid's shape, or (0, 0, 0) when hashed."""
    m = p.elements.shape[0]
    mid, reach, cell, radius = p.slot_mid, p.slot_reach, p.slot_cell, p.elem_geom
    h = 0.0
    x0 = y0 = z0 = np.inf
    x1 = y1 = z1 = -np.inf
    for i in range(m):
        e = p.elements[i]
        v = p.elem_index[e, 0]
        s2 = 0.0
        for k in range(3):
            mid[i, k] = 0.5 * (x[v, k] + x[v + 1, k])
            d = x[v + 1, k] - x[v, k]
            s2 += d * d
        x0, y0, z0 = min(x0, mid[i, 0]), min(y0, mid[i, 1]), min(z0, mid[i, 2])
        x1, y1, z1 = max(x1, mid[i, 0]), max(y1, mid[i, 1]), max(z1, mid[i, 2])
        reach[i] = 0.5 * math.sqrt(s2) + radius[e, 0]
        h = max(h, 2.0 * reach[i])
    h = CELL_MARGIN * h + 1e-300
    size = p.cursor.shape[0]
    nx = ny = nz = 0
    cells = ((x1 - x0) / h + 1.0) * ((y1 - y0) / h + 1.0) * ((z1 - z0) / h + 1.0)
    if m > 0 and cells <= size:  # False for NaN
        nx, ny, nz = int((x1 - x0) / h) + 1, int((y1 - y0) / h) + 1, int((z1 - z0) / h) + 1
    else:
        x0 = y0 = z0 = 0.0
    start, cursor, bucket = p.bucket_start, p.cursor, p.slot_bucket
    start[:] = 0
    for i in range(m):
        if abs(mid[i, 0]) + abs(mid[i, 1]) + abs(mid[i, 2]) < np.inf:
            cx, cy, cz = _cell(mid[i, 0], x0, h), _cell(mid[i, 1], y0, h), _cell(mid[i, 2], z0, h)
            if nx > 0:  # round-off at the faces of the box: every bucket index stays in range
                cx, cy, cz = min(max(cx, 0), nx - 1), min(max(cy, 0), ny - 1), min(max(cz, 0), nz - 1)
            b = _bucket(cx, cy, cz, nx, ny, nz, size - 1)
        else:  # NaN or infinite: parked in bucket 0, in a cell no other segment can share
            cx = cy = cz = PARKED
            b = 0
        cell[i, 0], cell[i, 1], cell[i, 2] = cx, cy, cz
        bucket[i] = b
        start[b + 1] += 1
    for b in range(size):
        start[b + 1] += start[b]
        cursor[b] = start[b]
    for i in range(m):
        n = cursor[bucket[i]]
        cursor[bucket[i]] += 1
        p.sorted_elem[n] = p.elements[i]
        for k in range(3):
            p.sorted_cell[n, k] = cell[i, k]
            p.sorted_mid[n, k] = mid[i, k]
        p.sorted_reach[n] = reach[i]
    return nx, ny, nz


@njit(**CACHED_INNER)
def excluded(eidx, egeom, attach_node, attach_offset, node_gap, self_contact, self_gap, e1, e2, r_sum):
    """True if elements e1, e2 are neighbours along a line or through a junction node."""
    l1, l2 = eidx[e1, 1], eidx[e2, 1]
    if l1 == l2:
        if not self_contact:
            return True
        gap = egeom[e2, 1] - egeom[e1, 2] if e1 < e2 else egeom[e1, 1] - egeom[e2, 2]
        if gap < self_gap * r_sum:
            return True
    for a in range(2):
        nd = attach_node[2 * l1 + a]
        da = egeom[e1, 1] if a == 0 else egeom[e1, 3]
        for b in range(2):
            if (l1 == l2 and a == b) or attach_node[2 * l2 + b] != nd:
                continue
            db = egeom[e2, 1] if b == 0 else egeom[e2, 3]
            off = 0.0
            for k in range(3):
                u = attach_offset[2 * l1 + a, k] - attach_offset[2 * l2 + b, k]
                off += u * u
            if da + db + math.sqrt(off) < node_gap[nd] * r_sum:
                return True
    return False


@njit(**CACHED, inline="always")
def _spread(f, a, wa, wb, gx, gy, gz):
    """Add the force g (lab) to vertices a, a + 1 with weights wa, wb."""
    f[a, 0] += wa * gx
    f[a, 1] += wa * gy
    f[a, 2] += wa * gz
    f[a + 1, 0] += wb * gx
    f[a + 1, 1] += wb * gy
    f[a + 1, 2] += wb * gz


@njit(**CACHED_INNER)
def pair_load(x, v, f, a, b, r_sum, k, gamma, dx, dy, dz, apply):
    """Narrow phase of the segments starting at vertices a and b (radii summing to r_sum,
    midpoints dx, dy, dz apart): return (energy, s, t, nx, ny, nz, fn): the energy
    k eps^2 / 2 (0 when apart), the closest points' parameters and, if apply, the unit normal
    and the normal force, added to f."""
    s, t = segment_closest(x[a, 0], x[a, 1], x[a, 2], x[a + 1, 0], x[a + 1, 1], x[a + 1, 2],
                           x[b, 0], x[b, 1], x[b, 2], x[b + 1, 0], x[b + 1, 1], x[b + 1, 2])
    nx = (1 - s) * x[a, 0] + s * x[a + 1, 0] - (1 - t) * x[b, 0] - t * x[b + 1, 0]
    ny = (1 - s) * x[a, 1] + s * x[a + 1, 1] - (1 - t) * x[b, 1] - t * x[b + 1, 1]
    nz = (1 - s) * x[a, 2] + s * x[a + 1, 2] - (1 - t) * x[b, 2] - t * x[b + 1, 2]
    d = math.sqrt(nx * nx + ny * ny + nz * nz)
    eps = r_sum - d
    if eps <= 0.0:
        return 0.0, s, t, 0.0, 0.0, 0.0, 0.0
    fn = 0.0
    if apply:
        if d > 1e-9 * r_sum:
            nx, ny, nz = nx / d, ny / d, nz / d
        else:  # centre lines cross: push along the midpoint offset (a subgradient)
            nx, ny, nz = dx, dy, dz
            dn = math.sqrt(nx * nx + ny * ny + nz * nz)
            if dn == 0.0:
                nx, ny, nz, dn = 0.0, 0.0, 1.0, 1.0
            nx, ny, nz = nx / dn, ny / dn, nz / dn
        vn = (nx * ((1 - s) * v[a, 0] + s * v[a + 1, 0] - (1 - t) * v[b, 0] - t * v[b + 1, 0])
              + ny * ((1 - s) * v[a, 1] + s * v[a + 1, 1] - (1 - t) * v[b, 1] - t * v[b + 1, 1])
              + nz * ((1 - s) * v[a, 2] + s * v[a + 1, 2] - (1 - t) * v[b, 2] - t * v[b + 1, 2]))
        fn = k * eps - gamma * vn
        if fn > 0.0:
            _spread(f, a, 1.0 - s, s, fn * nx, fn * ny, fn * nz)
            _spread(f, b, t - 1.0, -t, fn * nx, fn * ny, fn * nz)
        else:
            fn = 0.0
    return 0.5 * k * eps * eps, s, t, nx, ny, nz, fn


@njit(**CACHED, inline="always")
def _pair_hash(lo, hi, mask):
    return ((lo * HASH_X) ^ (hi * HASH_Y)) & mask


@njit(**CACHED, inline="always")   # called with literal axes: one compile each otherwise
def _offset(x, a, b, s, t, k):
    """Component k of x_a(s) - x_b(t), the points at s, t on the segments from a and b."""
    return (1 - s) * x[a, k] + s * x[a + 1, k] - (1 - t) * x[b, k] - t * x[b + 1, k]


@njit(**CACHED_INNER)
def begin_pairs(p):
    """Update p's pair table: empty the side this call fills (the side before the last).
    Return (old, new): the side of the last call and this call's."""
    old = 1 if p.pair_state[0] == 1 else 0
    new = 1 - old
    keys, used = p.pair_key, p.pair_used
    mask = keys.shape[1] - 1
    for j in range(p.pair_state[1 + new]):
        keys[new, used[new, j] & mask, 0] = -1
    p.pair_state[1 + new] = 0
    return old, new


@njit(**CACHED_INNER)
def end_pairs(p, old, new):
    """Update p's pair table: make new the current side; return the spring energy of the
    pairs of the old side that no longer touch (their springs are released)."""
    keys, data, used = p.pair_key, p.pair_data, p.pair_used
    mask = keys.shape[1] - 1
    lost = 0.0
    for j in range(p.pair_state[1 + old]):
        slot = used[old, j] & mask
        if keys[old, slot, 2] != TAKEN:
            lost += 0.5 * p.k_t * (data[old, slot, 0] ** 2 + data[old, slot, 1] ** 2 + data[old, slot, 2] ** 2)
    p.pair_state[0] = new
    return lost


@njit(**CACHED_INNER)
def pair_friction(p, x, v, f, ei, ej, a, b, s, t, nx, ny, nz, fn, old, new):
    """Update f (nv, 3) and the pair table's side new given the touching elements ei, ej
    (first vertices a, b), their closest points' parameters s, t, the unit normal n (from j
    to i) and the normal force fn: the friction forces, -k_t delta on i and +k_t delta on j
    (see the module docstring). Return the plastic work of the slip."""
    keys, data, used = p.pair_key, p.pair_data, p.pair_used
    size = keys.shape[1]
    mask = size - 1
    lo, hi, sg = (ei, ej, 1.0) if ei < ej else (ej, ei, -1.0)
    h = _pair_hash(lo, hi, mask)
    slot, found = h, -1
    for _ in range(size):
        if keys[old, slot, 0] == -1:
            break
        if keys[old, slot, 0] == lo and keys[old, slot, 1] == hi:
            found = slot
            break
        slot = (slot + 1) & mask
    ax = ay = az = 0.0
    sliding = False
    if found >= 0:  # the spring carried over: add the relative displacement of its points
        sliding = keys[old, found, 2] == SLIDE
        keys[old, found, 2] = TAKEN
        s0, t0 = (data[old, found, 3], data[old, found, 4]) if sg > 0 else (data[old, found, 4], data[old, found, 3])
        # the spring turned into the new tangent plane, its length kept (a projection would
        # shed energy at every turn of the normal), plus the points' tangential displacement
        ax, ay, az = sg * data[old, found, 0], sg * data[old, found, 1], sg * data[old, found, 2]
        ax, ay, az = turn_into_plane(ax, ay, az, nx, ny, nz)
        ux = _offset(x, a, b, s0, t0, 0) - sg * data[old, found, 5]
        uy = _offset(x, a, b, s0, t0, 1) - sg * data[old, found, 6]
        uz = _offset(x, a, b, s0, t0, 2) - sg * data[old, found, 7]
        un = ux * nx + uy * ny + uz * nz
        ax, ay, az = ax + ux - un * nx, ay + uy - un * ny, az + uz - un * nz
    # the trial: the spring and the dashpot beside it, on the relative tangential velocity
    ux = (1 - s) * v[a, 0] + s * v[a + 1, 0] - (1 - t) * v[b, 0] - t * v[b + 1, 0]
    uy = (1 - s) * v[a, 1] + s * v[a + 1, 1] - (1 - t) * v[b, 1] - t * v[b + 1, 1]
    uz = (1 - s) * v[a, 2] + s * v[a + 1, 2] - (1 - t) * v[b, 2] - t * v[b + 1, 2]
    un = ux * nx + uy * ny + uz * nz
    c_t = p.gamma / p.k_t
    ex, ey, ez = ax + c_t * (ux - un * nx), ay + c_t * (uy - un * ny), az + c_t * (uz - un * nz)
    tx, ty, tz = plane_tangent(x[a + 1, 0] - x[a, 0], x[a + 1, 1] - x[a, 1], x[a + 1, 2] - x[a, 2], nx, ny, nz)
    bx, by, bz, slides, slip = stick_slip(ax, ay, az, ex, ey, ez, tx, ty, tz, sliding, p.mu_s, p.mu_k, p.k_t, fn)
    if slides:
        ax, ay, az = bx, by, bz
    else:
        slip = 0.0
        if p.gamma > 0.0:   # sticking: the dashpot's share of -k_t b, for the account
            g = -p.k_t
            _spread(p.damp, a, 1.0 - s, s, g * (bx - ax), g * (by - ay), g * (bz - az))
            _spread(p.damp, b, t - 1.0, -t, g * (bx - ax), g * (by - ay), g * (bz - az))
    g = -p.k_t
    _spread(f, a, 1.0 - s, s, g * bx, g * by, g * bz)
    _spread(f, b, t - 1.0, -t, g * bx, g * by, g * bz)
    count = p.pair_state[1 + new]
    if 2 * count >= size:
        raise RuntimeError("Contact: more element pairs touch than its friction table holds; "
                           "give Contact a larger pairs_per_element")
    slot = h
    for _ in range(size):
        if keys[new, slot, 0] == -1:
            break
        slot = (slot + 1) & mask
    keys[new, slot, 0], keys[new, slot, 1], keys[new, slot, 2] = lo, hi, (SLIDE if slides else STICK)
    data[new, slot, 0], data[new, slot, 1], data[new, slot, 2] = sg * ax, sg * ay, sg * az
    data[new, slot, 3], data[new, slot, 4] = (s, t) if sg > 0 else (t, s)
    for k in range(3):
        data[new, slot, 5 + k] = sg * _offset(x, a, b, s, t, k)
    used[new, count] = slot
    p.pair_state[1 + new] = count + 1
    return slip


@njit(**CACHED_INNER)
def pair_springs(p):
    """Return the spring energy k_t |delta|^2 / 2 of the pairs of the last call."""
    side = 1 if p.pair_state[0] == 1 else 0
    mask = p.pair_key.shape[1] - 1
    e = 0.0
    for j in range(p.pair_state[1 + side]):
        slot = p.pair_used[side, j] & mask
        e += 0.5 * p.k_t * (p.pair_data[side, slot, 0] ** 2 + p.pair_data[side, slot, 1] ** 2
                            + p.pair_data[side, slot, 2] ** 2)
    return e


# the 13 neighbour offsets with (dz, dy, dx) lexicographically positive: with the own cell
# they visit every pair of neighbouring cells exactly once
FORWARD = np.array([(dx, dy, dz) for dz in (-1, 0, 1) for dy in (-1, 0, 1) for dx in (-1, 0, 1)
                    if (dz, dy, dx) > (0, 0, 0)], dtype=np.int64)


@njit(**CACHED_INNER)
def sweep(p, model, state, f, apply):
    """Visit every candidate pair once (grid broad phase, bounding spheres, exclusions, then
    the narrow phase); return the contact energy and, if apply, add the contact forces to f
    (nv, 3) and count the narrow-phase tests and the contacts."""
    nx, ny, nz = build_grid(p, state.x)
    mask = p.cursor.shape[0] - 1
    forward = FORWARD
    # every array the loops touch, taken out of the records once (no attribute access inside)
    start, elem, cell, mid, reach = p.bucket_start, p.sorted_elem, p.sorted_cell, p.sorted_mid, p.sorted_reach
    eidx, egeom, node_gap = p.elem_index, p.elem_geom, p.node_gap
    attach_node, attach_offset, x, v = model.attach_node, model.attach_offset, state.x, state.v
    k, gamma, self_contact, self_gap = p.k, p.gamma, p.self_contact, p.self_gap
    energy, tests, active, lost = 0.0, 0, 0, 0.0
    friction = apply and p.k_t > 0.0
    damped = apply and gamma > 0.0
    if damped:
        p.damp[:] = 0.0
    old = new = 0
    if friction:
        old, new = begin_pairs(p)
    for i in range(elem.shape[0]):
        cx, cy, cz = cell[i, 0], cell[i, 1], cell[i, 2]
        if cx == PARKED:
            continue
        for o in range(-1, forward.shape[0]):  # -1: own cell (the later segments of the bucket)
            if o < 0:
                ox, oy, oz = cx, cy, cz
                first, last = i + 1, start[_bucket(cx, cy, cz, nx, ny, nz, mask) + 1]
            else:
                ox, oy, oz = cx + forward[o, 0], cy + forward[o, 1], cz + forward[o, 2]
                b = _bucket(ox, oy, oz, nx, ny, nz, mask)
                if b < 0:
                    continue
                first, last = start[b], start[b + 1]
            for j in range(first, last):
                if cell[j, 0] != ox or cell[j, 1] != oy or cell[j, 2] != oz:
                    continue  # another cell sharing the hash bucket
                dx, dy, dz = mid[i, 0] - mid[j, 0], mid[i, 1] - mid[j, 1], mid[i, 2] - mid[j, 2]
                rr = reach[i] + reach[j]
                if dx * dx + dy * dy + dz * dz > rr * rr:
                    continue
                ei, ej = elem[i], elem[j]
                r_sum = egeom[ei, 0] + egeom[ej, 0]
                if excluded(eidx, egeom, attach_node, attach_offset, node_gap, self_contact, self_gap,
                            ei, ej, r_sum):
                    continue
                tests += 1
                va, vb = eidx[ei, 0], eidx[ej, 0]
                e, s, t, unx, uny, unz, fn = pair_load(x, v, f, va, vb, r_sum, k, gamma, dx, dy, dz, apply)
                energy += e
                active += e > 0.0
                if damped and e > 0.0:   # the dashpot's share of the normal force (clamp included)
                    dn = fn - k * math.sqrt(2.0 * e / k)
                    _spread(p.damp, va, 1.0 - s, s, dn * unx, dn * uny, dn * unz)
                    _spread(p.damp, vb, t - 1.0, -t, dn * unx, dn * uny, dn * unz)
                if friction and e > 0.0:
                    lost += pair_friction(p, x, v, f, ei, ej, va, vb, s, t, unx, uny, unz, fn, old, new)
    if friction:
        p.dissipated[0] += lost + end_pairs(p, old, new)
    if apply:
        p.narrow_tests[0] += tests
        p.active[0] = active
    return energy


@load_kernel(ContactParams)
@njit(**CACHED)
def add_contact(p, model, state, loads):
    """Update loads.f (nv, 3) given the vertex positions and velocities: the penalty contact
    forces of every overlapping pair of capsules and, with k_t > 0, their friction, updating
    the pair table and p.dissipated (see the module docstring); p.narrow_tests and p.active
    count the narrow-phase tests and the contacts."""
    # a run-time flag, not a literal: the step and the energy share one compilation of the sweep
    sweep(p, model, state, loads.f, np.bool_(True))


@account_kernel(ContactParams)
@njit(**CACHED)
def account_contact_dashpots(p, model, state, hh):
    """Update p.dissipated by -hh times the power of the last call's dashpot forces (p.damp)
    at the current velocities: on both sides of a kick of 2 hh, the kinetic energy the kick's
    dashpot share takes."""
    if not p.gamma > 0.0:
        return
    v, damp = state.v, p.damp
    power = 0.0
    for i in range(min(v.shape[0], damp.shape[0])):
        power += damp[i, 0] * v[i, 0] + damp[i, 1] * v[i, 1] + damp[i, 2] * v[i, 2]
    p.dissipated[0] -= hh * power


@njit(**ENTRY)
def contact_energy(p, model, state):
    """Return the contact potential: the sum of k eps^2 / 2 over overlapping pairs, plus the
    friction springs' energy k_t |delta|^2 / 2."""
    e = sweep(p, model, state, state.x, np.bool_(False))
    return e + pair_springs(p) if p.k_t > 0.0 else e
