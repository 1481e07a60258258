"""Static obstacles with Coulomb friction: the lines' vertices, spheres of the section radius,
against a plane (half-space), sphere, capsule, box or closed triangle mesh.

Normal law. A vertex centre c at signed distance d from the surface (outward normal n)
overlaps it by eps = r - d; the normal force is fn = max(0, k eps - gamma v.n) along n (the
potential k eps^2 / 2 when gamma = 0). On a soft soil k, gamma and k_t are per unit of
contact area, and each vertex's are those times its area s = 2 r l (l its Voronoi length): the
law is homogeneous of degree one in the three, the friction's cone and anchors unchanged, so
the vertex's force, dashpot force, plastic work and energy are s times those of the law with
the constants per area (p.scale: s, or 1 where k is per vertex, whose variant leaves it
unread: SOIL).

Friction: elastic stick, plastic slip. Each contact keeps an anchor A (lab point) set where
the contact began; the tangential spring displacement is delta = P (c - A), P the projection
on the tangent plane, and the trial friction force -k_t delta - gamma v_t (a dashpot beside
the spring, so that a sudden load does not overshoot the stick). The Coulomb limit is an
ellipse in the tangent plane: along the line's tangent (forward or backward, by the sign of
delta's component) and across it (lateral),

    (k_t delta_long / mu_long)^2 + (k_t delta_lat / mu_lat)^2 <= fn^2.

A sticking contact whose trial force leaves the static ellipse (mu_s) starts sliding; the
trial displacement is then scaled back onto the kinetic ellipse (mu_k) and the anchor dragged
to c - delta, so a sliding contact carries exactly mu_k fn (no dashpot). A sliding contact whose trial force
falls inside the kinetic ellipse sticks again. A direction with mu = 0 carries no friction.
The work of the friction force on each drag of the anchor (and the spring energy left when
a contact opens) is added to `dissipated`, and the dashpots' work by the account kernel of
cosnet.kernels.segments, so kinetic + elastic + penalty + spring energy + dissipated is
conserved (to the integrator's error).

Forces act at the vertex centres (no rolling resistance). The elements between vertices
meet the obstacle too (cosnet.kernels.segments, whose kernel calls this one). Mesh
triangles are binned once into a uniform grid whose cells hold every triangle within the
largest radius of them, so a vertex scans one cell; a vertex outside the grid touches
nothing.
"""

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from .backend import ENTRY
from .contact import clamp01
from .friction import plane_tangent, slip_law
from .compiler import CACHED, CACHED_INNER, CACHED_LANES, noalias

PLANE, SPHERE, CAPSULE, BOX, MESH = 0, 1, 2, 3, 4
SHAPES = {"plane": PLANE, "sphere": SPHERE, "capsule": CAPSULE, "box": BOX, "mesh": MESH}

# Compile-time options (kernels/specialise.py): an obstacle's record is of the variant its shape
# needs (kernels.segments.VARIANTS), whose kernels leave out the shapes it is not. This module's
# own functions, and its record ObstacleParams, are the variant with every shape.
ROUND = True    # a shape other than a plane: its elements meet it as well as its vertices
MESHED = True   # a mesh: its triangles, their grid, the segment walking the grid
SOIL = True     # a soft soil: its contacts' results scaled by their areas (p.scale; else by 1, left out)
OPTIONS = ("ROUND", "MESHED", "SOIL")
FAR = 1e300  # the distance of a vertex no mesh triangle is near
FREE, STICK, SLIDE = 0, 1, 2  # contact modes
# rows of ObstacleParams.rows, the vertex contacts' columns: centre, velocity, overlap, normal,
# the line's direction there (x[next] - x[prev]) gathered; force, anchor, dashpot force and
# dissipated energy computed (the anchor's rows hold it before and after)
C, V, EPS, N, U, F, A, D, LOST = 0, 3, 6, 7, 10, 13, 16, 19, 22
ROWS = 23


class ObstacleParams(NamedTuple):
    shape: int
    origin: np.ndarray      # (3,) plane point, sphere centre, capsule start, box centre
    axis: np.ndarray        # (3,) plane unit normal, capsule end
    size: np.ndarray        # (3,) sphere/capsule radius in [0]; box half sizes
    rot: np.ndarray         # (3, 3) box axes as rows (lab to box frame)
    tri: np.ndarray         # (nt, 3, 3) mesh triangles, wound outwards
    tri_normal: np.ndarray  # (nt, 3) their unit outward normals
    grid_origin: np.ndarray  # (3,) lowest corner of the triangle grid
    grid_h: float            # its cell size
    grid_dims: np.ndarray    # (3,) int64 its cells along x, y, z
    cell_start: np.ndarray   # (nc + 1,) int64 CSR offsets into cell_tri
    cell_tri: np.ndarray     # triangles near each cell
    k: float                 # normal penalty stiffness (N/m)
    gamma: float             # normal damping (N s/m)
    k_t: float               # tangential (stick) stiffness (N/m)
    mu_s: np.ndarray         # (3,) static coefficients: forward, backward, lateral
    mu_k: np.ndarray         # (3,) kinetic coefficients
    verts: np.ndarray        # (m,) int64 vertices taking part
    vprev: np.ndarray        # (m,) int64 their neighbours along the line (themselves at ends)
    vnext: np.ndarray        # (m,) int64
    radius: np.ndarray       # (m,) sphere radius of each vertex
    scale: np.ndarray        # (m,) each vertex's factor on k, gamma and k_t: 1, or on a soft soil its area (m^2)
    anchor: np.ndarray       # (m, 3) anchors of the tangential springs
    mode: np.ndarray         # (m,) int64 FREE, STICK or SLIDE
    dissipated: np.ndarray   # (1,) energy dissipated by friction (J)
    deepest: np.ndarray      # (1,) largest eps / r met so far
    active: np.ndarray       # (1,) int64 contacts at the last call
    elems: np.ndarray        # (ne, 2) int64 the elements: their two vertices' rows in verts
    edata: np.ndarray        # (ne, 7) element contacts' springs (3), t* at the last call, its point then (3)
    emode: np.ndarray        # (ne,) int64 FREE, STICK or SLIDE
    edamp: np.ndarray        # (ne, 2, 3) dashpot forces of the element contacts on their two vertices
    damp: np.ndarray         # (m, 3) dashpot forces of the vertex contacts
    rows: np.ndarray         # (ROWS, m) scratch of add_obstacle's passes, a row per column
    held: np.ndarray         # (2, m) int64 scratch of add_obstacle's passes: the vertices gathered, their modes


@njit(**CACHED)
def triangle_closest(px, py, pz, a, b, c):
    """Return the point of triangle (a, b, c) ((3,) arrays) closest to p (Ericson, Real-Time
    Collision Detection, 5.1.5)."""
    abx, aby, abz = b[0] - a[0], b[1] - a[1], b[2] - a[2]
    acx, acy, acz = c[0] - a[0], c[1] - a[1], c[2] - a[2]
    apx, apy, apz = px - a[0], py - a[1], pz - a[2]
    d1 = abx * apx + aby * apy + abz * apz
    d2 = acx * apx + acy * apy + acz * apz
    if d1 <= 0.0 and d2 <= 0.0:
        return a[0], a[1], a[2]
    bpx, bpy, bpz = px - b[0], py - b[1], pz - b[2]
    d3 = abx * bpx + aby * bpy + abz * bpz
    d4 = acx * bpx + acy * bpy + acz * bpz
    if d3 >= 0.0 and d4 <= d3:
        return b[0], b[1], b[2]
    vc = d1 * d4 - d3 * d2
    if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
        v = d1 / (d1 - d3)
        return a[0] + v * abx, a[1] + v * aby, a[2] + v * abz
    cpx, cpy, cpz = px - c[0], py - c[1], pz - c[2]
    d5 = abx * cpx + aby * cpy + abz * cpz
    d6 = acx * cpx + acy * cpy + acz * cpz
    if d6 >= 0.0 and d5 <= d6:
        return c[0], c[1], c[2]
    vb = d5 * d2 - d1 * d6
    if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
        w = d2 / (d2 - d6)
        return a[0] + w * acx, a[1] + w * acy, a[2] + w * acz
    va = d3 * d6 - d5 * d4
    if va <= 0.0 and d4 - d3 >= 0.0 and d5 - d6 >= 0.0:
        w = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        return b[0] + w * (c[0] - b[0]), b[1] + w * (c[1] - b[1]), b[2] + w * (c[2] - b[2])
    den = va + vb + vc
    if not den > 0.0:  # a degenerate triangle: its first vertex
        return a[0], a[1], a[2]
    v, w = vb / den, vc / den
    return a[0] + abx * v + acx * w, a[1] + aby * v + acy * w, a[2] + abz * v + acz * w


@njit(**CACHED, inline="always")
def _away(dx, dy, dz, d, radius, fx, fy, fz):
    """Signed distance and unit normal of a point offset (dx, dy, dz) from the nearest point of
    a core at distance d, surface at radius (fallback normal f when the point is on the core)."""
    if d > 0.0:
        return d - radius, dx / d, dy / d, dz / d
    return -radius, fx, fy, fz


@njit(**CACHED_INNER)
def _mesh_distance(p, cx, cy, cz):
    h, o, dims = p.grid_h, p.grid_origin, p.grid_dims
    ix = math.floor((cx - o[0]) / h) if abs(cx) < FAR else -1.0
    iy = math.floor((cy - o[1]) / h) if abs(cy) < FAR else -1.0
    iz = math.floor((cz - o[2]) / h) if abs(cz) < FAR else -1.0
    # also refuses NaN (every comparison False)
    if not (0.0 <= ix < dims[0] and 0.0 <= iy < dims[1] and 0.0 <= iz < dims[2]):
        return FAR, 0.0, 0.0, 1.0
    cell = int(ix) + dims[0] * (int(iy) + dims[1] * int(iz))
    best, bx, by, bz, bt = FAR, 0.0, 0.0, 0.0, -1
    for j in range(p.cell_start[cell], p.cell_start[cell + 1]):
        t = p.cell_tri[j]
        qx, qy, qz = triangle_closest(cx, cy, cz, p.tri[t, 0], p.tri[t, 1], p.tri[t, 2])
        d2 = (cx - qx) ** 2 + (cy - qy) ** 2 + (cz - qz) ** 2
        if d2 < best:
            best, bx, by, bz, bt = d2, qx, qy, qz, t
    if bt < 0:
        return FAR, 0.0, 0.0, 1.0
    n = p.tri_normal[bt]
    dx, dy, dz = cx - bx, cy - by, cz - bz
    side = 1.0 if dx * n[0] + dy * n[1] + dz * n[2] >= 0.0 else -1.0
    d = math.sqrt(best)
    if d > 0.0:
        return side * d, side * dx / d, side * dy / d, side * dz / d
    return 0.0, n[0], n[1], n[2]


@njit(**CACHED)
def obstacle_distance(p, cx, cy, cz):
    """Return (d, nx, ny, nz): the signed distance of point c from the obstacle's surface
    (positive outside) and the outward unit normal there (FAR for a mesh with no triangle
    near c)."""
    o, a, s = p.origin, p.axis, p.size
    if not ROUND or p.shape == PLANE:
        return (cx - o[0]) * a[0] + (cy - o[1]) * a[1] + (cz - o[2]) * a[2], a[0], a[1], a[2]
    if p.shape == SPHERE:
        dx, dy, dz = cx - o[0], cy - o[1], cz - o[2]
        return _away(dx, dy, dz, math.sqrt(dx * dx + dy * dy + dz * dz), s[0], 0.0, 0.0, 1.0)
    if p.shape == CAPSULE:
        ux, uy, uz = a[0] - o[0], a[1] - o[1], a[2] - o[2]
        uu = ux * ux + uy * uy + uz * uz
        t = clamp01(((cx - o[0]) * ux + (cy - o[1]) * uy + (cz - o[2]) * uz) / uu) if uu > 0.0 else 0.0
        dx, dy, dz = cx - o[0] - t * ux, cy - o[1] - t * uy, cz - o[2] - t * uz
        return _away(dx, dy, dz, math.sqrt(dx * dx + dy * dy + dz * dz), s[0], 0.0, 0.0, 1.0)
    if p.shape == BOX:
        r = p.rot
        dx, dy, dz = cx - o[0], cy - o[1], cz - o[2]
        q0 = r[0, 0] * dx + r[0, 1] * dy + r[0, 2] * dz
        q1 = r[1, 0] * dx + r[1, 1] * dy + r[1, 2] * dz
        q2 = r[2, 0] * dx + r[2, 1] * dy + r[2, 2] * dz
        e0, e1, e2 = q0 - max(-s[0], min(s[0], q0)), q1 - max(-s[1], min(s[1], q1)), q2 - max(-s[2], min(s[2], q2))
        out = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
        if out > 0.0:
            n0, n1, n2 = e0 / out, e1 / out, e2 / out
            d = out
        else:  # inside: out through the nearest face
            o0, o1, o2 = abs(q0) - s[0], abs(q1) - s[1], abs(q2) - s[2]
            n0 = n1 = n2 = 0.0
            if o0 >= o1 and o0 >= o2:
                d, n0 = o0, (1.0 if q0 >= 0.0 else -1.0)
            elif o1 >= o2:
                d, n1 = o1, (1.0 if q1 >= 0.0 else -1.0)
            else:
                d, n2 = o2, (1.0 if q2 >= 0.0 else -1.0)
        return (d, r[0, 0] * n0 + r[1, 0] * n1 + r[2, 0] * n2, r[0, 1] * n0 + r[1, 1] * n1 + r[2, 1] * n2,
                r[0, 2] * n0 + r[1, 2] * n1 + r[2, 2] * n2)
    if MESHED:
        return _mesh_distance(p, cx, cy, cz)
    return FAR, 0.0, 0.0, 1.0


@njit(**CACHED_LANES)
def add_obstacle(p, model, state, loads):
    """Update loads.f (nv, 3), p.anchor, p.mode, p.damp, p.dissipated, p.deepest, p.active
    given the vertex positions and velocities: the normal and friction forces of every vertex
    touching the obstacle (see the module docstring), and their dashpots' share (m, 3): the
    normal one (the clamp's included) and, while a contact sticks, -gamma v_t. In three
    passes: the geometry of the vertices in contact gathered into p.rows (p.held: which, and
    their modes), the contact law over them in vector lanes (contact_law), its results
    scattered; the same arithmetic, in the same order per vertex and over the sums, as one
    branching loop."""
    x, v, f, w, anchor, held = state.x, state.v, loads.f, p.rows, p.anchor, p.held
    # gathered: the vertices touching now or before (a contact that opens loses its spring);
    # the others (most of a line lying partly on the ground) only have their dashpot cleared
    k = np.int64(0)   # not the literal 0: contact_law, called with k, would compile for it too
    for j in range(p.verts.shape[0]):
        i, a, b = p.verts[j], p.vprev[j], p.vnext[j]
        cx, cy, cz = x[i, 0], x[i, 1], x[i, 2]
        d, nx, ny, nz = obstacle_distance(p, cx, cy, cz)
        eps = p.radius[j] - d
        if not eps > 0.0 and p.mode[j] == FREE:
            p.damp[j, 0] = p.damp[j, 1] = p.damp[j, 2] = 0.0   # a gathered vertex's is set below
            continue
        held[0, k], held[1, k] = j, p.mode[j]
        w[C, k], w[C + 1, k], w[C + 2, k] = cx, cy, cz
        w[V, k], w[V + 1, k], w[V + 2, k] = v[i, 0], v[i, 1], v[i, 2]
        w[EPS, k], w[N, k], w[N + 1, k], w[N + 2, k] = eps, nx, ny, nz
        w[U, k], w[U + 1, k], w[U + 2, k] = x[b, 0] - x[a, 0], x[b, 1] - x[a, 1], x[b, 2] - x[a, 2]
        w[A, k], w[A + 1, k], w[A + 2, k] = anchor[j, 0], anchor[j, 1], anchor[j, 2]
        k += 1
    # the rows as arrays of their own, which the law's options declare apart (noalias):
    # LLVM then runs its loop in vector lanes without testing at run time that they do not overlap
    rows = (w[0], w[1], w[2], w[3], w[4], w[5], w[6], w[7], w[8], w[9], w[10], w[11], w[12], w[13], w[14], w[15],
            w[16], w[17], w[18], w[19], w[20], w[21], w[22])
    contact_law(rows, held[1], k, p.k, p.gamma, p.k_t, p.mu_s[0], p.mu_s[1], p.mu_s[2], p.mu_k[0], p.mu_k[1],
                p.mu_k[2])
    # held in a register: stored at every contact, p.deepest would chain each vertex to the
    # one before through memory
    active, lost, deepest = 0, 0.0, p.deepest[0]
    for q in range(k):
        j = held[0, q]
        i = p.verts[j]
        s = p.scale[j] if SOIL else 1.0   # (the law's outputs scale with its constants)
        p.mode[j] = held[1, q]
        anchor[j, 0], anchor[j, 1], anchor[j, 2] = w[A, q], w[A + 1, q], w[A + 2, q]
        p.damp[j, 0], p.damp[j, 1], p.damp[j, 2] = s * w[D, q], s * w[D + 1, q], s * w[D + 2, q]
        lost += s * w[LOST, q]   # 0 where nothing was lost: lost is never -0, so adding 0 leaves it as it is
        if w[EPS, q] > 0.0:
            active += 1
            deepest = max(deepest, w[EPS, q] / p.radius[j])
            f[i, 0] += s * w[F, q]
            f[i, 1] += s * w[F + 1, q]
            f[i, 2] += s * w[F + 2, q]
    p.dissipated[0] += lost
    p.deepest[0] = deepest
    p.active[0] = active


@njit(**CACHED_LANES, **noalias(), no_cpython_wrapper=True)
def contact_law(w, mode, count, k, gamma, k_t, s_fwd, s_back, s_lat, k_fwd, k_back, k_lat):
    """Update mode (m,) and the rows F, A, D, LOST of w (ROWS arrays (m,), none the same) in
    their first count columns given its rows C, V, EPS, N, U, A there: each vertex contact's
    force, anchor, dashpot force and plastic work (module docstring), a vertex out of contact
    FREE with no force and, if it was in contact, the spring's energy lost. Branch-free over
    the vertices (selects), so that it runs in vector lanes."""
    for j in range(min(count, mode.shape[0])):
        cx, cy, cz, vx, vy, vz = w[C][j], w[C + 1][j], w[C + 2][j], w[V][j], w[V + 1][j], w[V + 2][j]
        eps, nx, ny, nz = w[EPS][j], w[N][j], w[N + 1][j], w[N + 2][j]
        hx, hy, hz = w[A][j], w[A + 1][j], w[A + 2][j]
        was = mode[j]
        # the spring displacement: the anchor's offset in the tangent plane
        ax, ay, az = cx - hx, cy - hy, cz - hz
        an = ax * nx + ay * ny + az * nz
        ax, ay, az = ax - an * nx, ay - an * ny, az - an * nz
        opened = 0.5 * k_t * (ax * ax + ay * ay + az * az)   # the cone shrank to nothing as it opened
        touching, fresh = eps > 0.0, was == FREE
        ax, ay, az = (0.0 if fresh else ax), (0.0 if fresh else ay), (0.0 if fresh else az)
        hx, hy, hz = (cx if fresh else hx), (cy if fresh else hy), (cz if fresh else hz)
        vn = vx * nx + vy * ny + vz * nz
        fn = max(k * eps - gamma * vn, 0.0)
        dn = fn - k * eps
        dx, dy, dz = dn * nx, dn * ny, dn * nz
        slides, slip = False, 0.0
        if k_t > 0.0:
            # trial force -k_t e: the spring and the dashpot beside it, while it sticks
            c_t = gamma / k_t
            ex, ey, ez = ax + c_t * (vx - vn * nx), ay + c_t * (vy - vn * ny), az + c_t * (vz - vn * nz)
            tx, ty, tz = plane_tangent(w[U][j], w[U + 1][j], w[U + 2][j], nx, ny, nz)
            ax, ay, az, slides, slip = slip_law(ax, ay, az, ex, ey, ez, tx, ty, tz, was == SLIDE, s_fwd, s_back,
                                                s_lat, k_fwd, k_back, k_lat, k_t, fn)
            hx, hy, hz = (cx - ax if slides else hx), (cy - ay if slides else hy), (cz - az if slides else hz)
            dx = dx if slides else dx - gamma * (vx - vn * nx)
            dy = dy if slides else dy - gamma * (vy - vn * ny)
            dz = dz if slides else dz - gamma * (vz - vn * nz)
        now = (SLIDE if slides else STICK) if k_t > 0.0 else (STICK if fresh else was)
        mode[j] = now if touching else FREE
        w[F][j], w[F + 1][j], w[F + 2][j] = fn * nx - k_t * ax, fn * ny - k_t * ay, fn * nz - k_t * az
        w[A][j] = hx if touching else w[A][j]
        w[A + 1][j] = hy if touching else w[A + 1][j]
        w[A + 2][j] = hz if touching else w[A + 2][j]
        w[D][j], w[D + 1][j], w[D + 2][j] = (dx if touching else 0.0), (dy if touching else 0.0), \
            (dz if touching else 0.0)
        w[LOST][j] = slip if touching else (0.0 if fresh else opened)


@njit(**ENTRY)
def obstacle_energy(p, state):
    """Return the stored energy: k eps^2 / 2 over the overlapping vertices plus the spring
    energy k_t |delta|^2 / 2 of their anchors (each times the vertex's p.scale)."""
    x, anchor = state.x, p.anchor
    e = 0.0
    for j in range(p.verts.shape[0]):
        i = p.verts[j]
        d, nx, ny, nz = obstacle_distance(p, x[i, 0], x[i, 1], x[i, 2])
        eps = p.radius[j] - d
        if not eps > 0.0:
            continue
        s = p.scale[j] if SOIL else 1.0
        e += s * (0.5 * p.k * eps * eps)
        if p.mode[j] != FREE:
            ax, ay, az = x[i, 0] - anchor[j, 0], x[i, 1] - anchor[j, 1], x[i, 2] - anchor[j, 2]
            an = ax * nx + ay * ny + az * nz
            e += s * (0.5 * p.k_t * ((ax - an * nx) ** 2 + (ay - an * ny) ** 2 + (az - an * nz) ** 2))
    return e
