"""Line elements against static obstacles, and the work of the obstacles' dashpots.

The vertex contacts (cosnet.kernels.obstacles) test the lines' vertices only; an element
longer than a sphere's radius or a mesh's edge could pass between its vertices. Each element
(the segment from vertex a to vertex b, a capsule of the section radius) therefore also
meets sphere, capsule, box and mesh obstacles (a plane needs nothing more: the deepest point
of a capsule in a half-space is an end sphere, which the vertex contact already is).

The element's deepest point c(t*) = (1 - t*) x_a + t* x_b is where its centre line comes
closest to the obstacle (one minimisation for a convex shape, whose distance is convex along
the segment; for a mesh, the segment against the triangles of the grid cells it crosses).
Its overlap eps* = r(t*) - d(c(t*)) (r interpolated between the end radii) adds a contact
for the excess over the end vertices' own overlaps,

    eps_int = eps* - max(eps_a, eps_b, 0),

which vanishes as t* reaches an end, so the contact grows continuously out of the vertex
contacts. Its potential k eps_int^2 / 2 has the gradient G_a = (1 - t*) n* - [a] n_a,
G_b = t* n* - [b] n_b ([a]: the end whose overlap is subtracted, n_a its normal; by the
envelope theorem t* does not move the gradient), so the force fn G on the two vertices
conserves energy, with fn = max(0, k eps_int - gamma (G_a . v_a + G_b . v_b)).

Friction: each element contact carries a tangential spring, stick / slip as the vertices'
(cosnet.kernels.friction), acting at c(t*) and shared (1 - t*, t*). Its displacement is
carried from call to call as the line-line contact's is: turned into the new tangent plane
(length kept) plus the tangential displacement of the material point at the previous t*
since then, so a line sliding over a rod is resisted although its deepest point stays put.
The normal force it holds against is the normal part of the contact's net push,
fn (G_a + G_b) . n* (fn itself when no end vertex touches; a contact wrapping a vertex's
own adds only its excess).

Dashpots: every force evaluation keeps the dashpot share of the forces (what is neither
the penalty nor the friction spring: the normal -gamma rate and the sticking -gamma v_t) on
each vertex; the account kernel, called just before and just after every kick, adds to
`dissipated` minus its work on the mean of the velocities either side, which is exactly what
the kick takes from the kinetic energy through it. The vertex contacts keep theirs in p.damp,
the elements' in p.edamp.
"""

import math
import sys

import numpy as np
from numba import njit

from .backend import ENTRY
from .compose import account_kernel, load_kernel
from .contact import clamp01, segment_closest
from .friction import plane_tangent, stick_slip, turn_into_plane
from . import obstacles
from .obstacles import (BOX, CAPSULE, FAR, FREE, MESH, MESHED, OPTIONS, PLANE, ROUND, SLIDE, SPHERE, STICK,
                        ObstacleParams, add_obstacle, obstacle_distance, triangle_closest)
from .specialise import Variants
from .compiler import CACHED, CACHED_INNER

BISECTIONS = 48  # of a box's distance slope along the segment: t* to 4e-15
TINY = 1e-300


@njit(**CACHED)
def segment_triangle(ax, ay, az, bx, by, bz, a, b, c):
    """Return (t, qx, qy, qz, d2): the parameter of the point of segment [a_, b_] (given by
    its ends) nearest triangle (a, b, c) ((3,) arrays), the triangle's nearest point q and the
    squared distance (0 where the segment pierces the triangle). Without a piercing the
    nearest pair is an end against the face or the segment against an edge."""
    wx, wy, wz = bx - ax, by - ay, bz - az
    best, bt, qx, qy, qz = FAR, 0.0, 0.0, 0.0, 0.0
    for end in range(2):
        px, py, pz = (ax, ay, az) if end == 0 else (bx, by, bz)
        sx, sy, sz = triangle_closest(px, py, pz, a, b, c)
        d2 = (px - sx) ** 2 + (py - sy) ** 2 + (pz - sz) ** 2
        if d2 < best:
            best, bt, qx, qy, qz = d2, float(end), sx, sy, sz
    for k in range(3):
        u = a if k == 0 else (b if k == 1 else c)
        w = b if k == 0 else (c if k == 1 else a)
        s, e = segment_closest(ax, ay, az, bx, by, bz, u[0], u[1], u[2], w[0], w[1], w[2])
        px, py, pz = ax + s * wx, ay + s * wy, az + s * wz
        sx, sy, sz = u[0] + e * (w[0] - u[0]), u[1] + e * (w[1] - u[1]), u[2] + e * (w[2] - u[2])
        d2 = (px - sx) ** 2 + (py - sy) ** 2 + (pz - sz) ** 2
        if d2 < best:
            best, bt, qx, qy, qz = d2, s, sx, sy, sz
    # a piercing: the segment crosses the triangle's plane inside it
    nx = (b[1] - a[1]) * (c[2] - a[2]) - (b[2] - a[2]) * (c[1] - a[1])
    ny = (b[2] - a[2]) * (c[0] - a[0]) - (b[0] - a[0]) * (c[2] - a[2])
    nz = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
    da = (ax - a[0]) * nx + (ay - a[1]) * ny + (az - a[2]) * nz
    db = (bx - a[0]) * nx + (by - a[1]) * ny + (bz - a[2]) * nz
    if da * db < 0.0:
        t = da / (da - db)
        px, py, pz = ax + t * wx, ay + t * wy, az + t * wz
        sx, sy, sz = triangle_closest(px, py, pz, a, b, c)
        d2 = (px - sx) ** 2 + (py - sy) ** 2 + (pz - sz) ** 2
        if d2 <= 1e-24 * (wx * wx + wy * wy + wz * wz):
            return t, px, py, pz, 0.0
    return bt, qx, qy, qz, best


@njit(**CACHED_INNER)
def _cell_triangles(p, cell, ax, ay, az, bx, by, bz, best, bt, bq, btri):
    """Scan one grid cell's triangles against the segment; return the improved nearest."""
    for j in range(p.cell_start[cell], p.cell_start[cell + 1]):
        tr = p.cell_tri[j]
        if tr < 0 or tr >= p.tri.shape[0]:
            continue
        t, qx, qy, qz, d2 = segment_triangle(ax, ay, az, bx, by, bz, p.tri[tr, 0], p.tri[tr, 1], p.tri[tr, 2])
        if d2 < best:
            best, bt, btri = d2, t, tr
            bq = (qx, qy, qz)
    return best, bt, bq, btri


@njit(**CACHED, inline="always")
def _walk_axis(a, w, o, h, n, t0):
    """Start of a grid walk along one axis from a + t0 w: (cell, step, t of the next cell
    face, t between faces)."""
    c = min(max(int(math.floor((a + t0 * w - o) / h)), 0), n - 1)
    if w > TINY:
        return c, 1, (o + (c + 1) * h - a) / w, h / w
    if w < -TINY:
        return c, -1, (o + c * h - a) / w, -h / w
    return c, 0, math.inf, math.inf


@njit(**CACHED, inline="always")
def _bump(v, k, by):
    """The triple v with `by` added to its entry k."""
    return v[0] + (by if k == 0 else 0), v[1] + (by if k == 1 else 0), v[2] + (by if k == 2 else 0)


@njit(**CACHED_INNER)
def mesh_segment(p, ax, ay, az, bx, by, bz):
    """Return (t, qx, qy, qz, d2, tri): the segment's point nearest the mesh among the
    triangles listed in the grid cells the segment crosses (a 3-D digital differential
    analyser walk: cost linear in the cells crossed), the triangle's point, the squared
    distance and the triangle (-1: none near)."""
    o, h, dims = p.grid_origin, p.grid_h, p.grid_dims
    start = (ax, ay, az)
    w = (bx - ax, by - ay, bz - az)
    t0, t1 = 0.0, 1.0
    for k in range(3):   # clip to the grid's box (NaN and infinities never enter it)
        if not (abs(start[k]) < FAR and abs(w[k]) < FAR):
            return 0.0, 0.0, 0.0, 0.0, FAR, -1
        lo, hi = o[k], o[k] + dims[k] * h
        if abs(w[k]) <= TINY:
            if not lo <= start[k] <= hi:
                return 0.0, 0.0, 0.0, 0.0, FAR, -1
            continue
        ta, tb = (lo - start[k]) / w[k], (hi - start[k]) / w[k]
        if ta > tb:
            ta, tb = tb, ta
        t0, t1 = max(t0, ta), min(t1, tb)
    if not t0 <= t1:
        return 0.0, 0.0, 0.0, 0.0, FAR, -1
    # the walk's state per axis in tuples (cell, step, t of the next cell face, t between
    # faces), rebuilt as it steps: nothing is allocated in a step
    wx = _walk_axis(ax, bx - ax, o[0], h, dims[0], t0)
    wy = _walk_axis(ay, by - ay, o[1], h, dims[1], t0)
    wz = _walk_axis(az, bz - az, o[2], h, dims[2], t0)
    cell, step, face, per = (wx[0], wy[0], wz[0]), (wx[1], wy[1], wz[1]), (wx[2], wy[2], wz[2]), (wx[3], wy[3], wz[3])
    # np.int64: with the literal -1, _cell_triangles would compile once more, for its type
    best, bt, bq, btri = FAR, 0.0, (0.0, 0.0, 0.0), np.int64(-1)
    for _ in range(dims[0] + dims[1] + dims[2] + 3):
        c = cell[0] + dims[0] * (cell[1] + dims[1] * cell[2])
        best, bt, bq, btri = _cell_triangles(p, c, ax, ay, az, bx, by, bz, best, bt, bq, btri)
        k = 0   # the axis whose next cell face comes first (x before y before z on a tie)
        if face[1] < face[k]:
            k = 1
        if face[2] < face[k]:
            k = 2
        if not face[k] <= t1:
            break
        cell, face = _bump(cell, k, step[k]), _bump(face, k, per[k])
        if cell[k] < 0 or cell[k] >= dims[k]:
            break
    return bt, bq[0], bq[1], bq[2], best, btri


@njit(**CACHED_INNER)
def _box_deepest(p, ax, ay, az, bx, by, bz, reach):
    """Return t* (or -1: the segment cannot reach the box): the minimum of the box's signed
    distance along the segment, convex, so bisection of its slope n . (b - a) finds it."""
    o, s = p.origin, p.size
    wx, wy, wz = bx - ax, by - ay, bz - az
    ww = wx * wx + wy * wy + wz * wz
    t = clamp01(((o[0] - ax) * wx + (o[1] - ay) * wy + (o[2] - az) * wz) / ww) if ww > 0.0 else 0.0
    cx, cy, cz = ax + t * wx - o[0], ay + t * wy - o[1], az + t * wz - o[2]
    if cx * cx + cy * cy + cz * cz > (math.sqrt(s[0] ** 2 + s[1] ** 2 + s[2] ** 2) + reach) ** 2:
        return -1.0
    d, nx, ny, nz = obstacle_distance(p, ax, ay, az)
    if nx * wx + ny * wy + nz * wz >= 0.0:
        return 0.0
    d, nx, ny, nz = obstacle_distance(p, bx, by, bz)
    if nx * wx + ny * wy + nz * wz <= 0.0:
        return 1.0
    lo, hi = 0.0, 1.0
    for _ in range(BISECTIONS):
        mid = 0.5 * (lo + hi)
        d, nx, ny, nz = obstacle_distance(p, ax + mid * wx, ay + mid * wy, az + mid * wz)
        if nx * wx + ny * wy + nz * wz < 0.0:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


@njit(**CACHED_INNER)
def deepest_point(p, ax, ay, az, bx, by, bz, reach):
    """Return (t, d, nx, ny, nz): the parameter of the segment's point nearest the
    obstacle's surface, its signed distance and the outward normal there (d = FAR: nothing
    within reach of the segment; reach bounds the radii)."""
    o, a = p.origin, p.axis
    wx, wy, wz = bx - ax, by - ay, bz - az
    ww = wx * wx + wy * wy + wz * wz
    if p.shape == SPHERE:
        t = clamp01(((o[0] - ax) * wx + (o[1] - ay) * wy + (o[2] - az) * wz) / ww) if ww > 0.0 else 0.0
    elif p.shape == CAPSULE:
        t, e = segment_closest(ax, ay, az, bx, by, bz, o[0], o[1], o[2], a[0], a[1], a[2])
    elif p.shape == BOX:
        t = _box_deepest(p, ax, ay, az, bx, by, bz, reach)
        if t < 0.0:
            return 0.0, FAR, 0.0, 0.0, 1.0
    elif MESHED and p.shape == MESH:
        t, qx, qy, qz, d2, tri = mesh_segment(p, ax, ay, az, bx, by, bz)
        if tri < 0:
            return 0.0, FAR, 0.0, 0.0, 1.0
        n = p.tri_normal[tri]
        dx, dy, dz = ax + t * wx - qx, ay + t * wy - qy, az + t * wz - qz
        side = 1.0 if dx * n[0] + dy * n[1] + dz * n[2] >= 0.0 else -1.0
        d = math.sqrt(d2)
        if d > 0.0:
            return t, side * d, side * dx / d, side * dy / d, side * dz / d
        return t, 0.0, n[0], n[1], n[2]
    else:
        return 0.0, FAR, 0.0, 0.0, 1.0
    d, nx, ny, nz = obstacle_distance(p, ax + t * wx, ay + t * wy, az + t * wz)
    return t, d, nx, ny, nz


@njit(**CACHED_INNER)
def element_overlap(p, x, e):
    """Return (eps_int, t, nx, ny, nz, gax, gay, gaz, gbx, gby, gbz, depth): element e's
    excess overlap (<= 0: no contact), its deepest point's parameter and outward normal,
    G_a, G_b = -grad eps_int on its two vertices (the directions of the normal force, module
    docstring) and the deepest point's overlap as a fraction of its radius."""
    ja, jb = p.elems[e, 0], p.elems[e, 1]
    m = p.verts.shape[0]
    nothing = (-1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    if not (0 <= ja < m and 0 <= jb < m):
        return nothing
    ia, ib = p.verts[ja], p.verts[jb]
    ra, rb = p.radius[ja], p.radius[jb]
    ax, ay, az, bx, by, bz = x[ia, 0], x[ia, 1], x[ia, 2], x[ib, 0], x[ib, 1], x[ib, 2]
    t, d, nx, ny, nz = deepest_point(p, ax, ay, az, bx, by, bz, max(ra, rb))
    r = (1.0 - t) * ra + t * rb
    deep = r - d
    if not (deep > 0.0 and 0.0 < t < 1.0):
        return nothing
    da, nax, nay, naz = obstacle_distance(p, ax, ay, az)
    db, nbx, nby, nbz = obstacle_distance(p, bx, by, bz)
    ea, eb = ra - da, rb - db
    gax, gay, gaz = (1.0 - t) * nx, (1.0 - t) * ny, (1.0 - t) * nz
    gbx, gby, gbz = t * nx, t * ny, t * nz
    if ea >= eb and ea > 0.0:
        eps = deep - ea
        gax, gay, gaz = gax - nax, gay - nay, gaz - naz
    elif eb > 0.0:
        eps = deep - eb
        gbx, gby, gbz = gbx - nbx, gby - nby, gbz - nbz
    else:
        eps = deep
    return eps, t, nx, ny, nz, gax, gay, gaz, gbx, gby, gbz, deep / r


@njit(**CACHED_INNER)
def add_element_contacts(p, x, v, f):
    """Update f (nv, 3), p.edata, p.emode, p.edamp, p.dissipated, p.deepest, p.active given
    the vertex positions x and velocities v: the excess contact of every element whose
    interior reaches deeper into the obstacle than its ends (module docstring). Return the
    energy friction dissipated."""
    data, mode, damp, k, k_t, gamma = p.edata, p.emode, p.edamp, p.k, p.k_t, p.gamma
    lost, active, deepest = 0.0, 0, p.deepest[0]   # in a register, as add_obstacle's
    for e in range(p.elems.shape[0]):
        damp[e, 0, 0] = damp[e, 0, 1] = damp[e, 0, 2] = 0.0
        damp[e, 1, 0] = damp[e, 1, 1] = damp[e, 1, 2] = 0.0
        eps, t, nx, ny, nz, gax, gay, gaz, gbx, gby, gbz, depth = element_overlap(p, x, e)
        if not eps > 0.0:
            if mode[e] != FREE:  # the spring's energy goes as the contact opens
                lost += 0.5 * k_t * (data[e, 0] ** 2 + data[e, 1] ** 2 + data[e, 2] ** 2)
                mode[e] = FREE
            continue
        ia, ib = p.verts[p.elems[e, 0]], p.verts[p.elems[e, 1]]
        active += 1
        deepest = max(deepest, depth)
        rate = (gax * v[ia, 0] + gay * v[ia, 1] + gaz * v[ia, 2]) + (gbx * v[ib, 0] + gby * v[ib, 1] + gbz * v[ib, 2])
        fn = max(k * eps - gamma * rate, 0.0)
        dn = fn - k * eps   # the dashpot's share (the clamp's included)
        f[ia, 0] += fn * gax
        f[ia, 1] += fn * gay
        f[ia, 2] += fn * gaz
        f[ib, 0] += fn * gbx
        f[ib, 1] += fn * gby
        f[ib, 2] += fn * gbz
        damp[e, 0, 0], damp[e, 0, 1], damp[e, 0, 2] = dn * gax, dn * gay, dn * gaz
        damp[e, 1, 0], damp[e, 1, 1], damp[e, 1, 2] = dn * gbx, dn * gby, dn * gbz
        if not k_t > 0.0:
            continue
        cx = (1.0 - t) * x[ia, 0] + t * x[ib, 0]
        cy = (1.0 - t) * x[ia, 1] + t * x[ib, 1]
        cz = (1.0 - t) * x[ia, 2] + t * x[ib, 2]
        ax = ay = az = 0.0
        sliding = mode[e] == SLIDE
        if mode[e] != FREE:
            # the spring turned into the new tangent plane, its length kept, plus the
            # tangential displacement of the material point that touched at the last call
            ax, ay, az = data[e, 0], data[e, 1], data[e, 2]
            ax, ay, az = turn_into_plane(ax, ay, az, nx, ny, nz)
            s0 = clamp01(data[e, 3])
            ux = (1.0 - s0) * x[ia, 0] + s0 * x[ib, 0] - data[e, 4]
            uy = (1.0 - s0) * x[ia, 1] + s0 * x[ib, 1] - data[e, 5]
            uz = (1.0 - s0) * x[ia, 2] + s0 * x[ib, 2] - data[e, 6]
            un = ux * nx + uy * ny + uz * nz
            ax, ay, az = ax + ux - un * nx, ay + uy - un * ny, az + uz - un * nz
        grip = fn * max(0.0, (gax + gbx) * nx + (gay + gby) * ny + (gaz + gbz) * nz)
        vx = (1.0 - t) * v[ia, 0] + t * v[ib, 0]
        vy = (1.0 - t) * v[ia, 1] + t * v[ib, 1]
        vz = (1.0 - t) * v[ia, 2] + t * v[ib, 2]
        vn = vx * nx + vy * ny + vz * nz
        c_t = gamma / k_t
        ex, ey, ez = ax + c_t * (vx - vn * nx), ay + c_t * (vy - vn * ny), az + c_t * (vz - vn * nz)
        tx, ty, tz = plane_tangent(x[ib, 0] - x[ia, 0], x[ib, 1] - x[ia, 1], x[ib, 2] - x[ia, 2], nx, ny, nz)
        bx, by, bz, slides, slip = stick_slip(ax, ay, az, ex, ey, ez, tx, ty, tz, sliding, p.mu_s, p.mu_k, k_t, grip)
        if slides:
            lost += slip
            ax, ay, az = bx, by, bz
        mode[e] = SLIDE if slides else STICK
        for c in range(3):
            g = -k_t * (bx if c == 0 else (by if c == 1 else bz))
            share = -k_t * ((bx - ax) if c == 0 else ((by - ay) if c == 1 else (bz - az)))  # the dashpot's
            f[ia, c] += (1.0 - t) * g
            f[ib, c] += t * g
            damp[e, 0, c] += (1.0 - t) * share
            damp[e, 1, c] += t * share
        data[e, 0], data[e, 1], data[e, 2], data[e, 3] = ax, ay, az, t
        data[e, 4], data[e, 5], data[e, 6] = cx, cy, cz
    p.active[0] += active
    p.deepest[0] = deepest
    return lost


@load_kernel(ObstacleParams)
@njit(**CACHED)
def add_line_obstacle(p, model, state, loads):
    """Update loads.f (nv, 3) and the contact records of p given the vertex positions and
    velocities: the vertex contacts (add_obstacle), then the elements' (module docstring)."""
    add_obstacle(p, model, state, loads)
    if ROUND and p.shape != PLANE and p.elems.shape[0] > 0:
        p.dissipated[0] += add_element_contacts(p, state.x, state.v, loads.f)


@account_kernel(ObstacleParams)
@njit(**CACHED)
def account_obstacle_dashpots(p, model, state, hh):
    """Update p.dissipated by -hh times the power of the dashpot forces of the last force
    evaluation (p.damp, p.edamp) at the current velocities (on both sides of a kick of 2 hh:
    the kinetic energy the kick's dashpot share takes)."""
    if not p.gamma > 0.0:
        return
    v = state.v
    power = 0.0
    for j in range(p.verts.shape[0]):
        i = p.verts[j]
        power += p.damp[j, 0] * v[i, 0] + p.damp[j, 1] * v[i, 1] + p.damp[j, 2] * v[i, 2]
    m = p.verts.shape[0]
    for e in range(p.elems.shape[0] if ROUND else 0):
        for side in range(2):
            j = p.elems[e, side]
            if 0 <= j < m:
                i = p.verts[j]
                power += p.edamp[e, side, 0] * v[i, 0] + p.edamp[e, side, 1] * v[i, 1] + p.edamp[e, side, 2] * v[i, 2]
    p.dissipated[0] -= hh * power


@njit(**ENTRY)
def element_energy(p, state):
    """Return the elements' stored energy: k eps_int^2 / 2 over the excess contacts plus the
    energy k_t |delta|^2 / 2 of their springs."""
    e = 0.0
    if not ROUND:   # a plane's elements add nothing to its vertices' contacts
        return e
    for c in range(p.elems.shape[0]):
        eps = element_overlap(p, state.x, c)[0]
        if eps > 0.0:
            e += 0.5 * p.k * eps * eps
            if p.emode[c] != FREE:
                e += 0.5 * p.k_t * (p.edata[c, 0] ** 2 + p.edata[c, 1] ** 2 + p.edata[c, 2] ** 2)
    return e


def _register(cls, kernels):
    load_kernel(cls)(kernels["add_line_obstacle"])
    account_kernel(cls)(kernels["account_obstacle_dashpots"])


# the variants of the obstacle's kernels by shape and law (kernels.obstacles.OPTIONS): a plane's
# step compiles none of the element contacts or the other shapes, a sphere's, capsule's or
# box's none of the mesh, and only a soft soil's scales its contacts by their areas
VARIANTS = Variants(ObstacleParams, lambda: (obstacles, sys.modules[__name__]), OPTIONS, _register, __name__)


def obstacle_record(p):
    """``p`` (an ObstacleParams) as the record of the variant its shape and law need, sharing
    its arrays: a soil's where some vertex's area is not 1 (scaling by 1 would change
    nothing)."""
    return VARIANTS.record(p, (p.shape != PLANE, p.shape == MESH, bool(np.any(p.scale != 1.0))))


__getattr__ = VARIANTS.module_getattr   # a variant's record class by its name, as pickle looks for it
