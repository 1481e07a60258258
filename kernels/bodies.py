"""Kernel of bodies that collide: a node (rigid body or point mass) carrying a collision shape
(sphere, capsule or box, fixed in the node's frame) that the vertices of lines, static
obstacles and the shapes of other bodies meet.

Every contact is one point P where a force F acts on one side and -F on the other, each side
a line vertex, a node (force F at P: torque (P - x_com) x F about its centre of mass) or a
static obstacle; linear and angular momentum are exchanged exactly.

  line vertex (centre c, radius r) against the body's shape: P = c (the vertex takes no
      torque, so the body's torque arm ends at c too);
  line element reaching deeper into the shape than its ends (cosnet.kernels.segments: the
      excess overlap eps_int beyond the end vertices'): the force F at its deepest point
      c(t*), shared (1 - t*, t*) by its vertices, less the normal force fn n_s on the end
      whose overlap is subtracted; the body takes -F at c(t*) and fn n_s at that end;
  a sample sphere of the body (centre s, radius r) against a target's shape (a static
      obstacle, or another body's shape posed by its node): P the middle of the overlap,
      s - (r - eps/2) n. The samples: a sphere's centre, a capsule's two end centres, a
      box's eight corners (radius 0). A sphere meets everything exactly, a capsule meets a
      plane exactly, a box meets a plane exactly; against curved targets capsules and boxes
      touch only at their samples.

The normal law is the static obstacles' (cosnet.kernels.obstacles): overlap eps, force
max(0, k eps - gamma v_n) along the target's outward normal n. Friction is the same elastic
stick / plastic slip, isotropic (one coefficient): a tangential spring of displacement delta,
trial force -k_t (delta + gamma / k_t u_t) from the relative tangential velocity u_t of the
two sides at P; beyond mu_s fn it slides at mu_k fn. Because a body rolls, delta is carried
incrementally: at each force evaluation delta += (t - t_last) u_t, then projected on the
current tangent plane. In a splitting step the velocities at a kick are those of the drift
just ended, so for a translating pair this is exactly the position-based anchor of a static
obstacle; for a rolling sphere it counts only the slip of the material points in contact.
The work of the friction force on each slip (and the spring energy left when a contact
opens) is added to `dissipated`, and so is the dashpots' work: each evaluation keeps every
contact's dashpot share of its force (normal, clamp included, and a sticking spring's) and
point; the account kernel, just before and just after each kick, adds minus its power on
the relative velocity of the two sides there, times half the kick.
"""

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from .backend import ENTRY
from .compose import account_kernel, load_kernel
from .obstacles import FREE, SLIDE, STICK
from .compiler import CACHED, CACHED_INNER
from .effects import add_wrench
from .rotations import cross, quat_rotate, quat_rotate_inv
from .segments import VARIANTS

# a body's shape and its targets are never meshes: the obstacles' kernels compiled without them
# (kernels/specialise.py; the variant of a sphere, capsule or box obstacle)
_ROUND = VARIANTS.with_options((True, False, False)).family   # ROUND, not MESHED nor SOIL
obstacle_distance, deepest_point = _ROUND["obstacle_distance"], _ROUND["deepest_point"]


class BodyShape(NamedTuple):
    """A shape as obstacle_distance reads it (no mesh: its arrays are empty)."""
    shape: int
    origin: np.ndarray       # (3,) sphere/box centre, capsule start
    axis: np.ndarray         # (3,) plane normal, capsule end
    size: np.ndarray         # (3,) radius in [0]; box half sizes
    rot: np.ndarray          # (3, 3) box axes as rows
    tri: np.ndarray          # (0, 3, 3)
    tri_normal: np.ndarray   # (0, 3)
    grid_origin: np.ndarray  # (3,)
    grid_h: float
    grid_dims: np.ndarray    # (3,) int64
    cell_start: np.ndarray   # (1,) int64
    cell_tri: np.ndarray     # (0,) int64


class BodyParams(NamedTuple):
    node: int                # the node carrying the shape
    own: BodyShape           # its shape, principal body frame, about the centre of mass
    bound: float             # radius about the centre of mass enclosing the shape
    k: float                 # normal penalty stiffness (N/m)
    gamma: float             # normal damping (N s/m)
    k_t: float               # tangential (stick) stiffness (N/m)
    mu_s: float              # static coefficient
    mu_k: float              # kinetic coefficient
    verts: np.ndarray        # (nl,) int64 line vertices touching the shape
    vrad: np.ndarray         # (nl,) their sphere radii
    samples: np.ndarray      # (ns, 3) sample sphere centres, principal body frame about the centre of mass
    srad: np.ndarray         # (ns,) their radii
    tnode: np.ndarray        # (nt,) int64 target's node, -1 for a static obstacle
    tshape: np.ndarray       # (nt,) int64 target shape codes
    torigin: np.ndarray      # (nt, 3) target geometry: lab, or its node's principal frame about its centre of mass
    taxis: np.ndarray        # (nt, 3)
    tsize: np.ndarray        # (nt, 3)
    trot: np.ndarray         # (nt, 3, 3)
    tbound: np.ndarray       # (nt,) radius enclosing a target body's shape about its centre of mass
    delta: np.ndarray        # (nc, 3) tangential spring displacements (lab): nc = nl + ns nt + ne
    mode: np.ndarray         # (nc,) int64 FREE, STICK or SLIDE
    last: np.ndarray         # (1,) time of the last force evaluation
    dissipated: np.ndarray   # (1,) energy dissipated by friction (J)
    deepest: np.ndarray      # (1,) largest eps / r met so far (r: the vertex or sample radius, or 1 m at 0)
    active: np.ndarray       # (1,) int64 contacts at the last call
    damp: np.ndarray         # (nc, 6) each contact's dashpot force on its touching side and its point
    elems: np.ndarray        # (ne, 2) int64 the lines' elements: their two vertices' rows in verts
    eparam: np.ndarray       # (ne, 8) element contacts at the last call: t*, subtracted end (-1, 0, 1),
                             # deepest point's normal (3), the subtracted end's normal (3)

    # flattened into its callees' arguments though large (kernels/by_reference.py): passed as a
    # pointer, the contact loop's reads of it after each contact's writes cost a ball caught in
    # a net (cases/net_catch.toml) 5 % of its step
    by_value = True


@njit(**CACHED, inline="always")
def _target(p, o, own):
    """The shape of target o (its geometry as the record holds it)."""
    return BodyShape(p.tshape[o], p.torigin[o], p.taxis[o], p.tsize[o], p.trot[o], own.tri, own.tri_normal,
                     own.grid_origin, own.grid_h, own.grid_dims, own.cell_start, own.cell_tri)


@njit(**CACHED_INNER)
def posed_distance(shape, nd, state, cx, cy, cz):
    """Return (d, nx, ny, nz): obstacle_distance of lab point c from a shape fixed in node nd's
    principal frame about its centre of mass (nd < 0: a shape in the lab), lab normal."""
    if nd < 0:
        return obstacle_distance(shape, cx, cy, cz)
    q, x = state.node_q[nd], state.node_x[nd]
    bx, by, bz = quat_rotate_inv(q[0], q[1], q[2], q[3], cx - x[0], cy - x[1], cz - x[2])
    d, nx, ny, nz = obstacle_distance(shape, bx, by, bz)
    nx, ny, nz = quat_rotate(q[0], q[1], q[2], q[3], nx, ny, nz)
    return d, nx, ny, nz


@njit(**CACHED, inline="always")
def point_velocity(nd, state, px, py, pz):
    """Return the lab velocity of node nd's material point at p (zeros for nd < 0)."""
    if nd < 0:
        return 0.0, 0.0, 0.0
    q, x, v, w = state.node_q[nd], state.node_x[nd], state.node_v[nd], state.node_w[nd]
    wx, wy, wz = quat_rotate(q[0], q[1], q[2], q[3], w[0], w[1], w[2])
    cx, cy, cz = cross(wx, wy, wz, px - x[0], py - x[1], pz - x[2])
    return v[0] + cx, v[1] + cy, v[2] + cz


@njit(**CACHED, inline="always")
def push_node(nd, state, loads, px, py, pz, fx, fy, fz):
    """Update loads.node_f, loads.node_tau of node nd (if nd >= 0) with force f acting at lab
    point p (its torque about the centre of mass)."""
    if nd < 0:
        return
    x = state.node_x[nd]
    add_wrench(loads, nd, px - x[0], py - x[1], pz - x[2], fx, fy, fz)


@njit(**CACHED_INNER)
def touch(p, j, eps, scale, nx, ny, nz, ux, uy, uz, dt):
    """Update p.delta[j], p.mode[j], p.deepest given contact j's overlap eps (scale: the radius
    its depth is reported against), the target's outward normal n, the relative velocity u of
    the touching side at the contact point and the time dt since the last evaluation; return
    (fx, fy, fz, lost): the force on the touching side and the energy friction dissipated."""
    d, mode, k_t = p.delta, p.mode, p.k_t
    p.damp[j, 0] = p.damp[j, 1] = p.damp[j, 2] = 0.0
    if not eps > 0.0:
        lost = 0.0
        if mode[j] != FREE:  # the cone shrank to nothing as the contact opened
            lost = 0.5 * k_t * (d[j, 0] ** 2 + d[j, 1] ** 2 + d[j, 2] ** 2)
            mode[j] = FREE
            d[j, 0] = d[j, 1] = d[j, 2] = 0.0
        return 0.0, 0.0, 0.0, lost
    p.deepest[0] = max(p.deepest[0], eps / scale)
    un = ux * nx + uy * ny + uz * nz
    tx, ty, tz = ux - un * nx, uy - un * ny, uz - un * nz
    if mode[j] == FREE:
        mode[j] = STICK
        ax = ay = az = 0.0
    else:
        ax, ay, az = d[j, 0] + dt * tx, d[j, 1] + dt * ty, d[j, 2] + dt * tz
        an = ax * nx + ay * ny + az * nz
        ax, ay, az = ax - an * nx, ay - an * ny, az - an * nz
    fn = max(p.k * eps - p.gamma * un, 0.0)
    fx, fy, fz, lost = fn * nx, fn * ny, fn * nz, 0.0
    dn = fn - p.k * eps   # the dashpot's share (the clamp's included), for the account
    p.damp[j, 0], p.damp[j, 1], p.damp[j, 2] = dn * nx, dn * ny, dn * nz
    if k_t > 0.0:
        c_t = p.gamma / k_t
        ex, ey, ez = ax + c_t * tx, ay + c_t * ty, az + c_t * tz
        trial = k_t * math.sqrt(ex * ex + ey * ey + ez * ez)
        mu = p.mu_s if mode[j] == STICK else p.mu_k
        if trial > mu * fn:
            mode[j] = SLIDE
            # back onto the kinetic cone, the dashpot idle; the work on the slip is lost
            s = p.mu_k * fn / trial if trial > 0.0 else 0.0
            bx, by, bz = s * ex, s * ey, s * ez
            lost = k_t * (bx * (ax - bx) + by * (ay - by) + bz * (az - bz))
            ax, ay, az = bx, by, bz
            ex, ey, ez = bx, by, bz
        elif mode[j] == SLIDE:
            mode[j] = STICK
        if mode[j] == STICK:   # the dashpot beside the sticking spring
            p.damp[j, 0] -= k_t * (ex - ax)
            p.damp[j, 1] -= k_t * (ey - ay)
            p.damp[j, 2] -= k_t * (ez - az)
        fx -= k_t * ex
        fy -= k_t * ey
        fz -= k_t * ez
    d[j, 0], d[j, 1], d[j, 2] = ax, ay, az
    return fx, fy, fz, lost


@njit(**CACHED_INNER)
def body_element_overlap(p, state, e):
    """Return (eps_int, t, nx, ny, nz, side, sx, sy, sz): element e's excess overlap with the
    body's shape beyond its end vertices' (<= 0: none; cosnet.kernels.segments), the deepest
    point's parameter and lab normal, the end whose overlap is subtracted (-1: none) and that
    end's normal."""
    nothing = (-1.0, 0.0, 0.0, 0.0, 1.0, -1, 0.0, 0.0, 1.0)
    ja, jb = p.elems[e, 0], p.elems[e, 1]
    m = p.verts.shape[0]
    if not (0 <= ja < m and 0 <= jb < m):
        return nothing
    nd, x = p.node, state.x
    ia, ib = p.verts[ja], p.verts[jb]
    ra, rb = p.vrad[ja], p.vrad[jb]
    q, xc = state.node_q[nd], state.node_x[nd]
    ax, ay, az = quat_rotate_inv(q[0], q[1], q[2], q[3], x[ia, 0] - xc[0], x[ia, 1] - xc[1], x[ia, 2] - xc[2])
    bx, by, bz = quat_rotate_inv(q[0], q[1], q[2], q[3], x[ib, 0] - xc[0], x[ib, 1] - xc[1], x[ib, 2] - xc[2])
    reach = max(ra, rb)
    wx, wy, wz = bx - ax, by - ay, bz - az
    ww = wx * wx + wy * wy + wz * wz
    s = min(max(-(ax * wx + ay * wy + az * wz) / ww, 0.0), 1.0) if ww > 0.0 else 0.0
    if (ax + s * wx) ** 2 + (ay + s * wy) ** 2 + (az + s * wz) ** 2 > (p.bound + reach) ** 2:
        return nothing
    t, d, nx, ny, nz = deepest_point(p.own, ax, ay, az, bx, by, bz, reach)
    deep = (1.0 - t) * ra + t * rb - d
    if not (deep > 0.0 and 0.0 < t < 1.0):
        return nothing
    nx, ny, nz = quat_rotate(q[0], q[1], q[2], q[3], nx, ny, nz)
    da, nax, nay, naz = posed_distance(p.own, nd, state, x[ia, 0], x[ia, 1], x[ia, 2])
    db, nbx, nby, nbz = posed_distance(p.own, nd, state, x[ib, 0], x[ib, 1], x[ib, 2])
    ea, eb = ra - da, rb - db
    if ea >= eb and ea > 0.0:
        return deep - ea, t, nx, ny, nz, 0, nax, nay, naz
    if eb > 0.0:
        return deep - eb, t, nx, ny, nz, 1, nbx, nby, nbz
    return deep, t, nx, ny, nz, -1, 0.0, 0.0, 1.0


@njit(**CACHED_INNER)
def add_element_contacts(p, state, loads, base, dt):
    """Update loads.f, loads.node_f, loads.node_tau and contacts base.. of p given the
    positions and velocities: the excess contact of every element reaching deeper into the
    body's shape than its ends, the gradient of k eps_int^2 / 2 (the line's point c(t*) along
    n*, less the subtracted end's normal on that end; the opposite on the body at both
    points), damped on the rate of eps_int, with the shape's friction at c(t*). Return
    (energy friction dissipated, contacts)."""
    nd, x, v, f = p.node, state.x, state.v, loads.f
    lost, active = 0.0, 0
    for e in range(p.elems.shape[0]):
        eps, t, nx, ny, nz, side, sx, sy, sz = body_element_overlap(p, state, e)
        j = base + e
        ia, ib = p.verts[p.elems[e, 0]], p.verts[p.elems[e, 1]]
        cx, cy, cz = (1.0 - t) * x[ia, 0] + t * x[ib, 0], (1.0 - t) * x[ia, 1] + t * x[ib, 1], \
            (1.0 - t) * x[ia, 2] + t * x[ib, 2]
        wx, wy, wz = point_velocity(nd, state, cx, cy, cz)
        ux = (1.0 - t) * v[ia, 0] + t * v[ib, 0] - wx
        uy = (1.0 - t) * v[ia, 1] + t * v[ib, 1] - wy
        uz = (1.0 - t) * v[ia, 2] + t * v[ib, 2] - wz
        i_s = ia if side == 0 else ib
        if side >= 0:   # the rate of eps_int: the subtracted end's approach taken off
            px, py, pz = x[i_s, 0], x[i_s, 1], x[i_s, 2]
            wx, wy, wz = point_velocity(nd, state, px, py, pz)
            us = sx * (v[i_s, 0] - wx) + sy * (v[i_s, 1] - wy) + sz * (v[i_s, 2] - wz)
            ux, uy, uz = ux - us * nx, uy - us * ny, uz - us * nz
        # deepest stays the vertices' and samples' overlap (an infinite scale leaves it)
        fx, fy, fz, dl = touch(p, j, eps, math.inf, nx, ny, nz, ux, uy, uz, dt)
        lost += dl
        p.damp[j, 3], p.damp[j, 4], p.damp[j, 5] = cx, cy, cz
        p.eparam[e, 0], p.eparam[e, 1] = t, side
        p.eparam[e, 2], p.eparam[e, 3], p.eparam[e, 4] = nx, ny, nz
        p.eparam[e, 5], p.eparam[e, 6], p.eparam[e, 7] = sx, sy, sz
        if not eps > 0.0:
            continue
        active += 1
        f[ia, 0] += (1.0 - t) * fx
        f[ia, 1] += (1.0 - t) * fy
        f[ia, 2] += (1.0 - t) * fz
        f[ib, 0] += t * fx
        f[ib, 1] += t * fy
        f[ib, 2] += t * fz
        push_node(nd, state, loads, cx, cy, cz, -fx, -fy, -fz)
        if side >= 0:
            fn = fx * nx + fy * ny + fz * nz
            f[i_s, 0] -= fn * sx
            f[i_s, 1] -= fn * sy
            f[i_s, 2] -= fn * sz
            push_node(nd, state, loads, x[i_s, 0], x[i_s, 1], x[i_s, 2], fn * sx, fn * sy, fn * sz)
    return lost, active


@load_kernel(BodyParams)
@njit(**CACHED)
def add_body_contacts(p, model, state, loads):
    """Update loads.f (nv, 3), loads.node_f, loads.node_tau, p.delta, p.mode, p.last,
    p.dissipated, p.deepest, p.active given the positions and velocities of the body's node,
    the listed line vertices and the target bodies: the contact forces of the body's shape
    on the vertices, of its samples on the targets, and their reactions (module docstring)."""
    nd, own = p.node, p.own
    x, v, f = state.x, state.v, loads.f
    xc = state.node_x[nd]
    t = state.clock[0]
    dt = t - p.last[0]
    p.last[0] = t
    lost, active = 0.0, 0
    for j in range(p.verts.shape[0]):
        i = p.verts[j]
        cx, cy, cz = x[i, 0], x[i, 1], x[i, 2]
        r = p.vrad[j]
        far = (cx - xc[0]) ** 2 + (cy - xc[1]) ** 2 + (cz - xc[2]) ** 2 > (p.bound + r) ** 2
        eps, nx, ny, nz = -1.0, 0.0, 0.0, 1.0
        if not far:
            d, nx, ny, nz = posed_distance(own, nd, state, cx, cy, cz)
            eps = r - d
        bx, by, bz = point_velocity(nd, state, cx, cy, cz)
        fx, fy, fz, dl = touch(p, j, eps, r, nx, ny, nz, v[i, 0] - bx, v[i, 1] - by, v[i, 2] - bz, dt)
        p.damp[j, 3], p.damp[j, 4], p.damp[j, 5] = cx, cy, cz
        lost += dl
        if eps > 0.0:
            active += 1
            f[i, 0] += fx
            f[i, 1] += fy
            f[i, 2] += fz
            push_node(nd, state, loads, cx, cy, cz, -fx, -fy, -fz)
    q = state.node_q[nd]
    nt, base = p.tnode.shape[0], p.verts.shape[0]
    for s in range(p.samples.shape[0]):
        ox, oy, oz = quat_rotate(q[0], q[1], q[2], q[3], p.samples[s, 0], p.samples[s, 1], p.samples[s, 2])
        cx, cy, cz = xc[0] + ox, xc[1] + oy, xc[2] + oz
        r = p.srad[s]
        for o in range(nt):
            other = p.tnode[o]
            d, nx, ny, nz = posed_distance(_target(p, o, own), other, state, cx, cy, cz)
            eps = r - d
            arm = r - 0.5 * eps
            px, py, pz = cx - arm * nx, cy - arm * ny, cz - arm * nz
            ax, ay, az = point_velocity(nd, state, px, py, pz)
            bx, by, bz = point_velocity(other, state, px, py, pz)
            c = base + s * nt + o
            fx, fy, fz, dl = touch(p, c, eps, r if r > 0.0 else 1.0, nx, ny, nz, ax - bx, ay - by, az - bz, dt)
            p.damp[c, 3], p.damp[c, 4], p.damp[c, 5] = px, py, pz
            lost += dl
            if eps > 0.0:
                active += 1
                push_node(nd, state, loads, px, py, pz, fx, fy, fz)
                push_node(other, state, loads, px, py, pz, -fx, -fy, -fz)
    dl, de = add_element_contacts(p, state, loads, base + p.samples.shape[0] * nt, dt)
    p.dissipated[0] += lost + dl
    p.active[0] = active + de


@account_kernel(BodyParams)
@njit(**CACHED)
def account_body_dashpots(p, model, state, hh):
    """Update p.dissipated by -hh times the power of the last force evaluation's dashpot
    forces (p.damp: on the touching side at the contact point, the opposite on the other) at
    the current velocities: on both sides of a kick of 2 hh, the kinetic energy the kick's
    dashpot share takes."""
    if not p.gamma > 0.0:
        return
    v, x, damp, nd = state.v, state.x, p.damp, p.node
    nl, nt = p.verts.shape[0], p.tnode.shape[0]
    base = nl + p.samples.shape[0] * nt
    power = 0.0
    for j in range(damp.shape[0]):
        if damp[j, 0] == 0.0 and damp[j, 1] == 0.0 and damp[j, 2] == 0.0:
            continue
        px, py, pz = damp[j, 3], damp[j, 4], damp[j, 5]
        if j >= base:   # an element's: its point c(t*), and the subtracted end's normal share
            e = j - base
            ia, ib = p.verts[p.elems[e, 0]], p.verts[p.elems[e, 1]]
            t, side, pe = p.eparam[e, 0], int(p.eparam[e, 1]), p.eparam[e]
            ax, ay, az = (1.0 - t) * v[ia, 0] + t * v[ib, 0], (1.0 - t) * v[ia, 1] + t * v[ib, 1], \
                (1.0 - t) * v[ia, 2] + t * v[ib, 2]
            bx, by, bz = point_velocity(nd, state, px, py, pz)
            if side >= 0:
                i_s = ia if side == 0 else ib
                dn = damp[j, 0] * pe[2] + damp[j, 1] * pe[3] + damp[j, 2] * pe[4]
                wx, wy, wz = point_velocity(nd, state, x[i_s, 0], x[i_s, 1], x[i_s, 2])
                power -= dn * (pe[5] * (v[i_s, 0] - wx) + pe[6] * (v[i_s, 1] - wy) + pe[7] * (v[i_s, 2] - wz))
        elif j < nl:
            i = p.verts[j]
            ax, ay, az = v[i, 0], v[i, 1], v[i, 2]
            bx, by, bz = point_velocity(nd, state, px, py, pz)
        else:
            ax, ay, az = point_velocity(nd, state, px, py, pz)
            bx, by, bz = point_velocity(p.tnode[(j - nl) % nt], state, px, py, pz)
        power += damp[j, 0] * (ax - bx) + damp[j, 1] * (ay - by) + damp[j, 2] * (az - bz)
    p.dissipated[0] -= hh * power


@njit(**ENTRY)
def body_energy(p, state):
    """Return the stored energy: k eps^2 / 2 over every overlapping contact plus the spring
    energy k_t |delta|^2 / 2 of the touching ones."""
    x, e = state.x, 0.0
    nd, own = p.node, p.own
    for j in range(p.verts.shape[0]):
        i = p.verts[j]
        d, nx, ny, nz = posed_distance(own, nd, state, x[i, 0], x[i, 1], x[i, 2])
        eps = p.vrad[j] - d
        if eps > 0.0:
            e += 0.5 * p.k * eps * eps
    q, xc = state.node_q[nd], state.node_x[nd]
    nt = p.tnode.shape[0]
    for s in range(p.samples.shape[0]):
        ox, oy, oz = quat_rotate(q[0], q[1], q[2], q[3], p.samples[s, 0], p.samples[s, 1], p.samples[s, 2])
        for o in range(nt):
            d, nx, ny, nz = posed_distance(_target(p, o, own), p.tnode[o], state, xc[0] + ox, xc[1] + oy,
                                           xc[2] + oz)
            eps = p.srad[s] - d
            if eps > 0.0:
                e += 0.5 * p.k * eps * eps
    for c in range(p.elems.shape[0]):
        eps = body_element_overlap(p, state, c)[0]
        if eps > 0.0:
            e += 0.5 * p.k * eps * eps
    for j in range(p.mode.shape[0]):
        if p.mode[j] != FREE:
            e += 0.5 * p.k_t * (p.delta[j, 0] ** 2 + p.delta[j, 1] ** 2 + p.delta[j, 2] ** 2)
    return e
