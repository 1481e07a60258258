"""Kernels of the fluid medium: drag, added mass, buoyancy and the medium's inertia force on
lines in water or air (Morison's equation), or the resistive forces of Stokes flow.

The medium's velocity U(x, t) is a current (a vector scaled by a profile over height and a
factor over time) plus linear (Airy) waves. What the medium does to a line splits three ways:
- forces of position and time alone (buoyancy; the inertia force of an accelerating medium):
  half their impulse on each side of the kick, which is the same as putting them in it
  (positions do not move during a kick);
- drag, a function of the relative velocity u = v - U: a velocity flow, solved exactly at a
  line's interior vertices (the tangential part and the normal part of u each keep their
  direction, their size decaying as u / (1 + k u h / m) for Morison's quadratic law, as
  u exp(-c h / m) for the linear one), so it is stable at any step and exact for a line
  falling or dragged along a fixed direction; at a node, where line ends of several
  directions meet, by one linearly implicit step (unconditionally stable);
- added mass: a submerged vertex's mass is the matrix m + a_n (1 - t t^T) + a_t t t^T
  (t its tangent), the kick's forces are divided by it, and the flows above use it; where
  a_n and a_t differ, the fluid turning with the line adds forces of its own (both in
  kernels/added_mass.py).
At a line's interior vertices the drag runs once a kick, inside it, between its two halves
(K/2 F K/2: kick_drag_vertices, after the added mass has turned the kick's loads); at the
nodes and for a moving medium's impulses, as half flows on both sides of every kick, mirrored
(kernels/fluid_step.flow_fluid; p.turn remembers which side is next). Either way every step is
a symmetric sequence (second order), stable however stiff the drag against the step, up to
the step's own limit. This module holds the record, the medium and the passes over the lines'
vertices; the free nodes' part and the kick's sequence are kernels/fluid_step.py's.
Lines are listed by row (p.lines); quantities per unit rest length are per row. Vertical is
+z; the free surface, when there is one, is the plane z = p.surface at rest.
"""

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from .backend import PASS
from .compiler import CACHED, INNER
from .effects import interp_table, table_interval
from .elementary import sin_cos
from .layout import columns, uint
from .rotations import quat_rotate
from .waves import add_elevation, add_kinematics, component, sample_depths, stretched, wave_phase

MORISON, LINEAR = 0, 1   # p.law: drag k |u| u per length, or c u per length (Stokes flow)
SAMPLE_ROWS = 17         # rows of p.sample (FluidParams)
SOAKED_ROW = 16          # its row that says, at a line's first vertex, whether the line lay wholly under a still
                         # surface at its last sample (sample_medium)
TANGENT_ROW = 7          # its rows of a vertex's unit tangent (three) and of its inverse masses across and
INVERSE_ROW = 14         # along the line (two), which the rings' impulses read too (kernels/sliding.py)

# Compile-time options (kernels/specialise.py): a fluid's record is of the variant its data needs
# (kernels/fluid_variants.py), whose kernels leave out the parts that cannot act. This module's
# own functions, and its record FluidParams, are the variant with every part. Options for the
# parts that cost most to compile, and for the loops a scene cannot run: of the drag's five
# loops and the turning fluid's three a scene runs one or two, so the drag's law and a medium at
# rest or flowing are pairs (DRAG, RESISTANCE; CALM, CURRENT), the one its data has on in a
# scene's variant, both in the variant with every part, which tests them at run time. Finer ones
# (upthrust, buoys apart, lines whose fluid turns with them apart from the others) each save
# less than the variants they multiply cost: the last, half a second of a cold start's
# compiling, cost the test suite's fluid files a quarter of their time.
MOVING = True        # the medium may move: waves, a profile over height, a factor over time
CARRIES = True       # some line carries an added mass (and its fluid may turn: added_mass.py), or some
                     # node has a buoy (a volume of its own, with or without an added mass)
WAVES = True         # the moving medium has waves (their passes, kernels/waves.py, cost a second of compiling
                     # that a current or a wind varying over height or time has no use for)
NODES = True         # some node is the medium's to move (fixed and driven ones are not): the passes over the
                     # nodes, seconds of compiling that a line between pins or a mooring line from an anchor to
                     # a driven fairlead has no use for
DRAG = True          # the drag may be Morison's law (p.law)
RESISTANCE = True    # it may be the linear law
CALM = True          # the medium may be at rest everywhere and always (calm_medium)
CURRENT = True       # it may flow somewhere, or at some time
ARMS = True          # some node the medium moves has a line end off its centre of mass: the drag's moment turns
                     # it, in a pass over the nodes of its own (fluid_step.drag_nodes) that a net of point
                     # junctions (knots, shackles, a towed weight) has no use for
THREADS = True       # the step runs on threads: the sample and the kick's passes over the lines and the nodes run
                     # in blocks on them (fluid_step.sample_threaded, added_mass.kick_threaded), parallel code a
                     # run on one thread has no use for
LINE_BLOCK = 128     # lines per task of the threaded passes over the lines (added_mass.kick_threaded,
                     # fluid_step.sample_threaded)
OPTIONS = ("MOVING", "CARRIES", "WAVES", "NODES", "DRAG", "RESISTANCE", "CALM", "CURRENT", "ARMS", "THREADS")


class FluidParams(NamedTuple):
    law: int                 # MORISON or LINEAR
    lines: np.ndarray        # (k,) int64 the lines in the medium, a row each
    line_row: np.ndarray     # (nl,) int64 each line's row, -1 for lines out of the medium
    drag_n: np.ndarray       # (k,) normal drag per length: 1/2 rho C_dn d (Morison) or c_n (linear)
    drag_t: np.ndarray       # (k,) tangential: 1/2 rho C_dt pi d (Morison) or c_t (linear)
    added_n: np.ndarray      # (k,) added mass per length normal to the line, C_an rho A
    added_t: np.ndarray      # (k,) along it, C_at rho A
    inertia_n: np.ndarray    # (k,) fluid-inertia mass per length, rho A (1 + C_an) (0: no such force)
    inertia_t: np.ndarray    # (k,) rho A (1 + C_at)
    buoyancy: np.ndarray     # (k,) upthrust per length when submerged, rho g A (0: none)
    surface: float           # z of the still free surface (inf: the medium fills space)
    depth: float             # water depth below the still surface (inf: deep water)
    stretch: int             # 1: Wheeler stretching of the wave kinematics, 0: held above z = surface
    current: np.ndarray      # (3,) current velocity (before the profile and time factors)
    profile_z: np.ndarray    # (m,) heights of the current's profile table (empty: factor 1)
    profile_f: np.ndarray    # (m,) its factors
    power: np.ndarray        # (3,) power-law profile ((z - z0) / z_ref)^alpha: alpha (0: none), z_ref, z0
    times: np.ndarray        # (m,) times of the current's time factor (empty: factor 1)
    values: np.ndarray       # (m,) its values
    wave_a: np.ndarray       # (nw,) amplitude of each Airy component
    wave_w: np.ndarray       # (nw,) angular frequency
    wave_k: np.ndarray       # (nw,) wave number (dispersion relation over p.depth)
    wave_cos: np.ndarray     # (nw,) direction of travel, cos and sin of the heading
    wave_sin: np.ndarray     # (nw,)
    wave_phase: np.ndarray   # (nw,)
    wave_depth: np.ndarray   # (nw, 2) exp(-2 k depth) and 1 / (1 - that) of each component (waves.depth_factors;
                             # 0 and 1 in deep water)
    wave_now: np.ndarray     # (nw,) scratch: each component's phase at the last sample (waves.wave_phase)
    node_skip: np.ndarray    # (nn,) 1 for nodes the medium leaves alone: held by a drive, or fixed
    sample: np.ndarray       # (SAMPLE_ROWS, nv) scratch: at each vertex of the lines in the medium, as the
                             # kick's first half flow found it: wet (1 or 0), U, A, tangent, then at
                             # interior vertices the medium's inertia force (3), the upthrust, and
                             # the inverse masses across and along the line, added mass included; row
                             # SOAKED_ROW at a line's first vertex 1 where it lay wholly under a still
                             # surface (its rows 0 and 13-15 then as such a sample writes them)
                             # (in a still medium where no line carries added mass the interior
                             # vertices are not sampled: the drag takes their wetness and tangent
                             # itself and the dry inverse masses, kick_drag_line)
    wet_inverse: np.ndarray  # (2, nv) 1 / (m + l a_n), 1 / (m + l a_t) of each interior vertex of a line in the
                             # medium: its inverse masses across and along the line where it is wet
    decay: np.ndarray        # (2, nv) scratch of the linear law: exp(-c h l / m) across and along the line at each
                             # wet interior vertex for a flow of h = decay_h (kick_drag_vertices)
    decay_h: np.ndarray      # (1,) the h of decay (nan: none yet)
    turn: np.ndarray         # (1,) int64: 0 before a kick, 1 after
    dissipated: np.ndarray   # (1,) energy drag has taken so far, in the frame of the medium
    supplied: np.ndarray     # (1,) work a moving medium has done so far (drag and inertia force)
    buoy: np.ndarray         # (nn,) int64 each node's buoy row (a volume of its own in the medium), -1: none
    buoy_node: np.ndarray    # (b,) int64 the node of each buoy row
    buoy_volume: np.ndarray  # (b,) its displaced volume V when submerged (a sphere of radius buoy_radius)
    buoy_radius: np.ndarray  # (b,) (3 V / 4 pi)^(1/3)
    buoy_drag: np.ndarray    # (b,) 1/2 rho C_d A of its drag, -buoy_drag f |u| u
    buoy_added: np.ndarray   # (b,) its added mass when submerged, C_a rho V
    buoy_sample: np.ndarray  # (b, 7) as the kick's first half flow found it: the submerged fraction f, U, A
    medium: np.ndarray       # (2,) rho and g
    turning: np.ndarray      # (12, nv) kernels/added_mass.py: the forces of the entrained fluid as the lines
                             # turn and the velocity's change over the last kick, and scratch;
                             # (12, 0) when they do not act
    node_mass: np.ndarray    # (nn, 6) scratch: each free node's mass matrix with the added mass of its wet
                             # line ends and buoy as the kick's sample holds it (a00 a01 a02 a11 a12 a22;
                             # sample_node_masses), where the medium adds mass
    chord_inverse: np.ndarray  # (nv,) scratch: 1 / |c| of the chord each vertex's sampled tangent is taken
                             # along (the end element at a line end; 1e150 where it vanishes), as the
                             # sample found it (where some line carries added mass): the turning fluid's
                             # terms (kernels/added_mass.vertex_turning)
    node_rate: np.ndarray    # (nn, 3) scratch: each free node's acceleration the turning fluid's predictor
                             # takes (kernels/added_mass.turning_rates)
    block_sums: np.ndarray   # (blocks, 3) scratch: the sums of each block of lines or nodes the threaded kick
                             # runs (added_mass.kick_threaded: a threaded loop's reduction would allocate)


@njit(**CACHED, inline="always")
def time_factor(p, t):
    """Return (f, df/dt) of the current's time table at t (1, 0 without one)."""
    n = p.times.shape[0]
    if n == 0:
        return 1.0, 0.0
    f = interp_table(t, p.times, p.values)
    if n < 2 or t <= p.times[0] or t >= p.times[n - 1]:
        return f, 0.0
    lo = table_interval(t, p.times)
    return f, (p.values[lo + 1] - p.values[lo]) / (p.times[lo + 1] - p.times[lo])


@njit(**CACHED, inline="always")
def current_factor(p, z):
    """Return the current's factor over height at height z (its profile table, its power law)."""
    f = 1.0
    if p.profile_z.shape[0] > 0:
        f = interp_table(z, p.profile_z, p.profile_f)
    if p.power[0] != 0.0:
        above = z - p.power[2]
        f *= (above / p.power[1]) ** p.power[0] if above > 0.0 else 0.0
    return f


@njit(**INNER, inline="always")
def medium_at(p, x, y, z, t):
    """Return (wet, U, A): whether point (x, y, z) is in the medium at time t (below the
    free surface, waves included), and the medium's velocity U and acceleration A there
    (3-tuples; zero where it is dry). (The values sample_moving takes at a line's vertices.)"""
    if not MOVING:   # the variant of a still medium: the current, under the still surface
        if z - p.surface > 0.0:
            return False, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
        c0, c1, c2 = p.current[0], p.current[1], p.current[2]
        return True, (c0, c1, c2), (c0 * 0.0, c1 * 0.0, c2 * 0.0)   # as below: the time factor's rate 0
    nw = p.wave_a.shape[0] if WAVES else 0
    zeta = z - p.surface
    eta = 0.0
    for c in range(nw):
        th = p.wave_k[c] * (x * p.wave_cos[c] + y * p.wave_sin[c]) + wave_phase(p.wave_w[c], p.wave_phase[c], t)
        eta += p.wave_a[c] * sin_cos(th)[1]
    if zeta > eta:
        return False, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
    f = current_factor(p, z)
    ft, dft = time_factor(p, t)
    c0, c1, c2 = p.current[0] * f, p.current[1] * f, p.current[2] * f
    ux, uy, uz = c0 * ft, c1 * ft, c2 * ft
    ax, ay, az = c0 * dft, c1 * dft, c2 * dft
    if WAVES and nw > 0:
        zs = stretched(zeta, eta, p.depth, p.stretch)
        for c in range(nw):
            k = p.wave_k[c]
            th = k * (x * p.wave_cos[c] + y * p.wave_sin[c]) + wave_phase(p.wave_w[c], p.wave_phase[c], t)
            du = component(p.wave_a[c], p.wave_w[c], k, p.wave_cos[c], p.wave_sin[c], th, zs, p.wave_depth[c, 0],
                           p.wave_depth[c, 1])
            ux, uy, uz = ux + du[0], uy + du[1], uz + du[2]
            ax, ay, az = ax + du[3], ay + du[4], az + du[5]
    return True, (ux, uy, uz), (ax, ay, az)


@njit(**INNER, inline="always")
def sample_moving(p, c, S, lo, hi, t):
    """Update rows 0-6 of the sample (S) at the vertices lo..hi-1 of a line in a moving medium
    given their positions (c: the columns) and the time t: medium_at's values, taken in passes
    over the vertices that run in vector lanes (kernels/waves.py), a component at a time, with
    rows 10 and 11 as their scratch (left 0: sample_inertia writes them after), the
    components' phases at t in p.wave_now (sample_medium takes them once for every line)."""
    n, first = hi - lo, uint(lo)
    eta, zs = S[10], S[11]
    if WAVES:
        for i in range(lo, hi):
            eta[i] = 0.0
        for w in range(p.wave_a.shape[0]):
            k = p.wave_k[w]
            add_elevation(c[0], c[1], eta, first, n, p.wave_a[w], k * p.wave_cos[w], k * p.wave_sin[w], p.wave_now[w])
        sample_depths(c[2], eta, S[0], zs, first, n, p.surface, p.depth, p.stretch)
    else:
        sample_still(c[2], S, first, n, p.surface, 0.0, 0.0, 0.0)   # (the wetness; the rest is written below)
    shaped = p.profile_z.shape[0] > 0 or p.power[0] != 0.0
    if shaped:   # the elevation is taken: its row holds the current's factor over height
        for i in range(lo, hi):
            eta[i] = current_factor(p, c[2][i])
    ft, dft = time_factor(p, t)
    c0, c1, c2 = p.current[0], p.current[1], p.current[2]
    sample_current(S[0], eta, (S[1], S[2], S[3]), (S[4], S[5], S[6]), first, n, shaped,
                   c0 * ft, c1 * ft, c2 * ft, c0 * dft, c1 * dft, c2 * dft)
    if WAVES:
        for w in range(p.wave_a.shape[0]):
            add_kinematics(c[0], c[1], zs, S[0], (S[1], S[2], S[3]), (S[4], S[5], S[6]), first, n, p.wave_a[w],
                           p.wave_w[w], p.wave_k[w], p.wave_cos[w], p.wave_sin[w], p.wave_now[w], p.wave_depth[w, 0],
                           p.wave_depth[w, 1])
    for i in range(lo, hi):
        eta[i], zs[i] = 0.0, 0.0


@njit(**PASS)
def sample_current(wet, f, U, A, lo, n, shaped, u0, u1, u2, a0, a1, a2):
    """Update U and A (three columns each) at the n vertices lo.. by the current's velocity
    (u0, u1, u2) and acceleration (a0, a1, a2) where they are wet, times its factor over
    height f there if ``shaped``."""
    for k in range(n):
        i = lo + uint(k)
        w = wet[i] * f[i] if shaped else wet[i]
        U[0][i], U[1][i], U[2][i] = u0 * w, u1 * w, u2 * w
        A[0][i], A[1][i], A[2][i] = a0 * w, a1 * w, a2 * w


@njit(**CACHED, inline="always")
def line_tangent(x, i, lo, hi):
    """Return (the unit tangent, 1 / the chord's length) at vertex i of the line whose vertices
    are lo..hi-1: the chord between its neighbours (the end element's at the ends)."""
    a, b = max(i - 1, lo), min(i + 1, hi - 1)
    tx, ty, tz = x[b, 0] - x[a, 0], x[b, 1] - x[a, 1], x[b, 2] - x[a, 2]
    n = math.sqrt(tx * tx + ty * ty + tz * tz)
    if n == 0.0:
        return (0.0, 0.0, 1.0), 1e150
    return (tx / n, ty / n, tz / n), 1.0 / n


@njit(**CACHED, inline="always")
def split(gn, gt, x, y, z, tx, ty, tz):
    """Return gn (1 - t t^T) w + gt t t^T w for w = (x, y, z) and the unit tangent t: a vector
    scaled by gn across the line and by gt along it (a drag, a mass, a force split by the
    line's direction)."""
    wt = x * tx + y * ty + z * tz
    return gn * (x - wt * tx) + gt * wt * tx, gn * (y - wt * ty) + gt * wt * ty, gn * (z - wt * tz) + gt * wt * tz


@njit(**CACHED, inline="always")
def add_split(a, cn, dc, t):
    """Return the symmetric matrix a (a00, a01, a02, a11, a12, a22) plus cn 1 + dc t t^T."""
    return (a[0] + cn + dc * t[0] * t[0], a[1] + dc * t[0] * t[1], a[2] + dc * t[0] * t[2],
            a[3] + cn + dc * t[1] * t[1], a[4] + dc * t[1] * t[2], a[5] + cn + dc * t[2] * t[2])


@njit(**CACHED, inline="always")
def has_added_mass(p):
    """Whether any line or buoy in the medium carries an added mass."""
    for j in range(p.added_n.shape[0]):
        if p.added_n[j] != 0.0 or p.added_t[j] != 0.0:
            return True
    for b in range(p.buoy_added.shape[0]):
        if p.buoy_added[b] != 0.0:
            return True
    return False


@njit(**CACHED, inline="always")
def submerged_fraction(depth, radius):
    """Return the fraction of a sphere of the given radius below the still surface, its centre
    ``depth`` below it: the cap (R + d)^2 (2R - d) / (4 R^3), d clamped to [-R, R]."""
    d = min(max(depth, -radius), radius)
    return (radius + d) ** 2 * (2.0 * radius - d) / (4.0 * radius ** 3)


@njit(**CACHED, inline="always")
def buoy_of(p, nd):
    """Return node nd's buoy row, -1 when it has none."""
    return p.buoy[nd] if nd < p.buoy.shape[0] else -1


@njit(**INNER)
def sample_buoys(p, state, t):
    """Update p.buoy_sample given the buoys' centres and the clock: the submerged fraction (by
    the still surface, as the lines' upthrust) and the medium's velocity and acceleration."""
    for b in range(p.buoy_node.shape[0]):
        x = state.node_x[p.buoy_node[b]]
        p.buoy_sample[b, 0] = submerged_fraction(p.surface - x[2], p.buoy_radius[b])
        _, um, acc = medium_at(p, x[0], x[1], x[2], t)
        for k in range(3):
            p.buoy_sample[b, 1 + k] = um[k]
            p.buoy_sample[b, 4 + k] = acc[k]


@njit(**CACHED, inline="always")
def still_medium(p):
    """Whether the medium is the same everywhere and always (a steady uniform current, no
    waves): then only the free surface decides where it acts."""
    return (p.wave_a.shape[0] == 0 and p.profile_z.shape[0] == 0 and p.power[0] == 0.0
            and p.times.shape[0] == 0)


@njit(**PASS)
def sample_upthrust(z, S, elen, lo, e0, n, up, surface, under):
    """Update row 13 of the sample (S) at the n interior vertices lo+1.. of a line whose
    elements start at e0 by their shares of the upthrust (up per length; vertex_force),
    given the heights z. A line wholly under the surface (``under``: line_under), the common
    case, takes a branch-free loop; one that crosses it, wet_shares element by element."""
    if under:
        for k in range(n):
            S[13][lo + uint(k + 1)] = 0.5 * up * (elen[e0 + uint(k)] + elen[e0 + uint(k + 1)])
        return
    for k in range(n):
        i = lo + uint(k + 1)
        S[13][i] = up * (elen[e0 + uint(k)] * wet_shares(z[lo + uint(k)], z[i], surface)[1]
                         + elen[e0 + uint(k + 1)] * wet_shares(z[i], z[lo + uint(k + 2)], surface)[0])


@njit(**PASS)
def line_under(z, lo, n, surface):
    """Return whether the n vertices lo.. of a line lie under the surface (z: the heights)."""
    under = 0.0
    for k in range(n):
        under += 1.0 if z[lo + uint(k)] <= surface else 0.0
    return under == n


@njit(**PASS)
def sample_inertia(S, vlen, first, n, cn, ct):
    """Update rows 10-12 of the sample (S) at the n vertices first.. by the medium's inertia
    force (masses per length cn across, ct along the line) of the sampled acceleration where
    they are wet (vertex_force)."""
    for k in range(n):
        i = first + uint(k)
        wl = S[0][i] * vlen[i]
        S[10][i], S[11][i], S[12][i] = split(wl * cn, wl * ct, S[4][i], S[5][i], S[6][i], S[7][i], S[8][i], S[9][i])


@njit(**PASS)
def sample_masses(S, dry, wet0, wet1, first, n):
    """Update rows 14-15 of the sample (S) at the n vertices first.. by the inverse of the
    vertex mass with the added mass across and along the line where it is wet (dry: the dry
    inverse masses, wet0 and wet1 the wet ones, p.wet_inverse): the divisions the flows and
    the kick would otherwise each repeat, made once when the simulation is built."""
    for k in range(n):
        i = first + uint(k)
        S[14][i], S[15][i] = wet_inverses(dry, wet0, wet1, i, S[0][i])


@njit(**CACHED, inline="always")
def unit_chord(c, a, b):
    """Return the unit chord from vertex a to vertex b (c: the position columns) and 1 / its
    length; 0 and 1e150 where they coincide (no tangent)."""
    tx, ty, tz = c[0][b] - c[0][a], c[1][b] - c[1][a], c[2][b] - c[2][a]
    inv = 1.0 / math.sqrt(max(tx * tx + ty * ty + tz * tz, 1e-300))
    return tx * inv, ty * inv, tz * inv, inv


@njit(**CACHED, inline="always")
def wet_inverses(dry, wet0, wet1, i, w):
    """Return vertex i's inverse masses across and along its line at wetness w (1 or 0):
    the wet ones (wet0, wet1: p.wet_inverse) or the dry one."""
    return dry[i] + w * (wet0[i] - dry[i]), dry[i] + w * (wet1[i] - dry[i])


@njit(**PASS)
def sample_chords(c, S, ci, lo, n):
    """Update rows 7-9 of the sample (S) at the n interior vertices lo+1.. of a line by the
    unit chord between their neighbours (c: the position columns), ci by 1 / its length where
    some line carries added mass (its turning fluid reads it; nothing else does)."""
    for k in range(n):
        i = lo + uint(k + 1)
        if CARRIES:
            S[7][i], S[8][i], S[9][i], ci[i] = unit_chord(c, i - uint(1), i + uint(1))
        else:
            S[7][i], S[8][i], S[9][i], _ = unit_chord(c, i - uint(1), i + uint(1))


@njit(**PASS)
def sample_still(z, S, lo, n, surface, c0, c1, c2):
    """Update rows 0-6 of the sample (S) at the n vertices lo.. of a line in a still medium:
    wet below the surface, the current (c0, c1, c2), no acceleration."""
    for k in range(n):
        i = lo + uint(k)
        S[0][i] = 1.0 if z[i] <= surface else 0.0
        S[1][i], S[2][i], S[3][i] = c0, c1, c2
        S[4][i], S[5][i], S[6][i] = 0.0, 0.0, 0.0


@njit(**CACHED, inline="always")
def still_vertex(v, c, S, ci, vlen, dry, wet0, wet1, i, surface, an, at, entrained, soaked):
    """Update the wetness, tangent (and ci, 1 / its chord's length) and inverse masses of
    interior vertex i in a still medium (sample_still_line), the tangent alone where
    ``soaked``; return the change of 1/2 v^T M_a v they make (0 unless ``entrained``)."""
    before = entrained_at(v, S, vlen, i, an, at) if entrained else 0.0
    if not soaked:
        w = 1.0 if c[2][i] <= surface else 0.0
        S[0][i] = w
        S[14][i], S[15][i] = wet_inverses(dry, wet0, wet1, i, w)
    S[7][i], S[8][i], S[9][i], ci[i] = unit_chord(c, i - uint(1), i + uint(1))
    return entrained_at(v, S, vlen, i, an, at) - before if entrained else 0.0


@njit(**PASS)
def sample_still_line(v, c, S, ci, vlen, dry, wet0, wet1, first, n, surface, an, at, entrained, soaked):
    """Update rows 0 (wetness), 7-9 (tangent) and 14-15 (inverse masses, as sample_masses) of
    the sample (S) at the n interior vertices first.. of a line in a still medium, in one pass
    (c: the position columns, v: the velocity columns), rows 7-9 alone where ``soaked`` (the
    line under the surface now and at its last sample: rows 0 and 14-15 already hold what
    this would write); return the change of the entrained fluid's kinetic energy at the
    present velocities (0 unless ``entrained``: a loop each way)."""
    de = 0.0
    if CARRIES and entrained and soaked:
        for k in range(n):
            de += still_vertex(v, c, S, ci, vlen, dry, wet0, wet1, first + uint(k), surface, an, at, True, True)
    elif CARRIES and entrained:
        for k in range(n):
            de += still_vertex(v, c, S, ci, vlen, dry, wet0, wet1, first + uint(k), surface, an, at, True, False)
    elif soaked:
        for k in range(n):
            still_vertex(v, c, S, ci, vlen, dry, wet0, wet1, first + uint(k), surface, an, at, False, True)
    else:
        for k in range(n):
            still_vertex(v, c, S, ci, vlen, dry, wet0, wet1, first + uint(k), surface, an, at, False, False)
    return de


@njit(**INNER)
def sample_medium(p, model, state):
    """Update p.sample at every vertex of the lines in the medium given the positions and the
    clock: they hold still through a kick and the flows around it, so the medium is sampled
    once per kick. A still medium's velocity and acceleration rows never change: they are
    written where a line's first vertex does not hold them (a new sample; a new current).
    Return the change of the entrained fluid's kinetic energy at the lines' vertices (line
    ends at the nodes the medium moves included) at the present velocities, in a still medium
    (0 otherwise: flow_fluid measures it around the sample). A line under a still surface at
    this sample and at the last (row SOAKED_ROW at its first vertex) has its wetness, inverse
    masses and upthrust as that sample wrote them, the same numbers: its tangents alone are
    written (a wire or a net wholly submerged, the common case, writes four rows a vertex
    fewer a kick). (Loops over vertices without calls or branches, which LLVM vectorises.)"""
    set_wave_phases(p, state.clock[0])
    return sample_lines(p, model, state, np.int64(0), p.lines.shape[0])


@njit(**CACHED, inline="always")
def set_wave_phases(p, t):
    """Update p.wave_now by each wave component's phase at time t (sample_lines reads them)."""
    if MOVING and WAVES:
        for w in range(p.wave_a.shape[0]):
            p.wave_now[w] = wave_phase(p.wave_w[w], p.wave_phase[w], t)


@njit(**INNER)
def sample_lines(p, model, state, j0, j1):
    """Update p.sample at the vertices of rows j0..j1-1's lines as sample_medium does (the wave
    components' phases set: set_wave_phases); return their share of its value."""
    x = state.x
    c, S, v = columns(x), sample_rows(p), columns(state.v)
    t = state.clock[0]
    nl = model.line_vertex_offsets.shape[0] - 1
    still = still_medium(p)
    c0, c1, c2, surface = p.current[0], p.current[1], p.current[2], p.surface
    vlen, dry, wet0, wet1 = model.voronoi_rest_length, model.vertex_inv_mass, p.wet_inverse[0], p.wet_inverse[1]
    de = 0.0
    for j in range(j0, j1):
        l = p.lines[j]
        if l < 0 or l >= nl:
            continue
        lo, hi = model.line_vertex_offsets[l], model.line_vertex_offsets[l + 1]
        an, at = p.added_n[j], p.added_t[j]
        ends = still and (an != 0.0 or at != 0.0)
        if CARRIES and ends:
            de -= ends_entrained(p, model, state, S, vlen, l, lo, hi, an, at)
        for i in (lo, hi - 1):
            tan, p.chord_inverse[i] = line_tangent(x, i, lo, hi)
            S[7][i], S[8][i], S[9][i] = tan[0], tan[1], tan[2]
        under = False
        if CARRIES or MOVING or p.buoyancy[j] != 0.0:
            under = line_under(c[2], uint(lo), hi - lo, surface)
        held = under and (not MOVING or still)   # under a still surface now
        soaked = held and p.sample[SOAKED_ROW, lo] == 1.0   # and at the last sample
        if not MOVING or still:
            if not (S[1][lo] == c0 and S[2][lo] == c1 and S[3][lo] == c2 and S[4][lo] == 0.0 and S[5][lo] == 0.0
                    and S[6][lo] == 0.0):
                sample_still(c[2], S, uint(lo), hi - lo, surface, c0, c1, c2)
            else:
                for i in (lo, hi - 1):
                    S[0][i] = 1.0 if c[2][i] <= surface else 0.0
            if CARRIES or MOVING:   # (else the drag alone reads the interior, and takes it itself: kick_drag_line)
                de += sample_still_line(v, c, S, p.chord_inverse, vlen, dry, wet0, wet1, uint(lo + 1), hi - lo - 2,
                                        surface, an, at, an != 0.0 or at != 0.0, soaked)
            if CARRIES and ends:
                de += ends_entrained(p, model, state, S, vlen, l, lo, hi, an, at)
        else:
            sample_chords(c, S, p.chord_inverse, uint(lo), hi - lo - 2)
            sample_moving(p, c, S, lo, hi, t)
            sample_masses(S, dry, wet0, wet1, uint(lo + 1), hi - lo - 2)
        if p.buoyancy[j] != 0.0 and not soaked:
            sample_upthrust(c[2], S, model.element_rest_length, uint(lo), uint(model.line_element_offsets[l]),
                            hi - lo - 2, p.buoyancy[j], surface, under)
        p.sample[SOAKED_ROW, lo] = 1.0 if held else 0.0
        if MOVING and not still and (p.inertia_n[j] != 0.0 or p.inertia_t[j] != 0.0):   # (still: rows 10-12 stay 0)
            sample_inertia(S, vlen, uint(lo + 1), hi - lo - 2, p.inertia_n[j], p.inertia_t[j])
    return de


@njit(**CACHED, inline="always")
def sampled(p, i):
    """Return (wet, U, A, tangent) of vertex i as p.sample holds them."""
    S = p.sample
    return (S[0, i] != 0.0, (S[1, i], S[2, i], S[3, i]), (S[4, i], S[5, i], S[6, i]),
            (S[7, i], S[8, i], S[9, i]))


@njit(**CACHED, inline="always")
def wet_shares(za, zb, s):
    """Return (w_a, w_b): the integrals of (1 - tau) and tau over the part of an element
    from height za (tau = 0) to zb (tau = 1) that lies below s: the shares of its upthrust
    its two vertices carry (the gradient of its buoyancy potential). (Branches: an element
    wholly under or over the surface, the common case, costs no division.)"""
    if za <= s and zb <= s:
        return 0.5, 0.5
    if za > s and zb > s:
        return 0.0, 0.0
    tc = (s - za) / (zb - za)
    if za <= s:
        return tc - 0.5 * tc * tc, 0.5 * tc * tc
    return 0.5 * (1.0 - tc) * (1.0 - tc), 0.5 * (1.0 - tc * tc)


@njit(**CACHED, inline="always")
def vertex_upthrust(p, model, x, j, l, i, lo, hi):
    """Return the upthrust on vertex i of line l (row j; its vertices lo..hi-1; x the
    positions): its shares of the elements beside it (wet_shares)."""
    up = 0.0
    if p.buoyancy[j] != 0.0:
        e0 = model.line_element_offsets[l] + (i - lo)
        if i > lo:
            up += model.element_rest_length[e0 - 1] * wet_shares(x[i - 1, 2], x[i, 2], p.surface)[1]
        if i < hi - 1:
            up += model.element_rest_length[e0] * wet_shares(x[i, 2], x[i + 1, 2], p.surface)[0]
        up *= p.buoyancy[j]
    return up


@njit(**INNER)
def vertex_force(p, model, state, j, l, i, lo, hi, tan, wet, acc):
    """Return the force of position and time on vertex i (line l, row j): its share of the
    upthrust of the elements beside it, and the medium's inertia force l_i (rho A (1 + C_a))
    A split along the tangent (the latter where the vertex is wet), each a 3-tuple."""
    up = vertex_upthrust(p, model, state.x, j, l, i, lo, hi)
    wl = model.voronoi_rest_length[i] if wet else 0.0
    return (0.0, 0.0, up), split(wl * p.inertia_n[j], wl * p.inertia_t[j], acc[0], acc[1], acc[2], tan[0], tan[1],
                                 tan[2])


@njit(**INNER)
def push_vertices(p, model, state, h):
    """Update state.v of the interior vertices by the impulse h of the medium's inertia force
    (as sample_inertia found it), through the added mass; p.supplied by its work. (The
    upthrust is a load of the kick: added_mass.kick_fluid. Contiguous columns, unsigned indices:
    vectorised as drag_vertices.)"""
    v, S = columns(state.v), sample_rows(p)
    nl = model.line_vertex_offsets.shape[0] - 1
    supplied = 0.0
    for j in range(p.lines.shape[0]):
        l = p.lines[j]
        if l < 0 or l >= nl or (p.inertia_n[j] == 0.0 and p.inertia_t[j] == 0.0):
            continue
        supplied += push_line(v, S, uint(model.line_vertex_offsets[l] + 1),
                              model.line_vertex_offsets[l + 1] - model.line_vertex_offsets[l] - 2, h)
    p.supplied[0] += supplied


@njit(**PASS)
def push_line(v, S, first, n, h):
    """Update the velocity columns v at the n vertices first.. by the impulse h of the sampled
    inertia force through the sampled inverse masses; return its work."""
    supplied = 0.0
    for k in range(n):
        i = first + uint(k)
        ix, iy, iz = h * S[10][i], h * S[11][i], h * S[12][i]
        dx, dy, dz = split(S[14][i], S[15][i], ix, iy, iz, S[7][i], S[8][i], S[9][i])
        supplied += ix * (v[0][i] + 0.5 * dx) + iy * (v[1][i] + 0.5 * dy) + iz * (v[2][i] + 0.5 * dz)
        v[0][i] += dx
        v[1][i] += dy
        v[2][i] += dz
    return supplied


@njit(**CACHED, inline="always")
def drag_flow(vx, vy, vz, w, tx, ty, tz, S, vlen, vmass, im, i, kn, kt, an, at, linear, calm, decay):
    """Return (the velocity, the energy dissipated, the work the medium supplied) of vertex i
    after the exact flow of drag (see kick_drag_vertices) from the velocity (vx, vy, vz), given
    its wetness w (1 or 0) and unit tangent t, the sample rows S, the Voronoi lengths, vertex
    masses and dry inverse masses (im) and, for the linear law, the decay factors of a wet
    vertex over the flow (p.decay: across, along) (``calm``: the medium at rest everywhere, its
    velocity rows not read). The inverse masses with the added mass are the sample's rows
    14-15; where no line carries added mass they are the dry ones, the same numbers, read from
    im, which the kick reads anyway."""
    wl = w * vlen[i]                                   # 0 where the vertex is dry
    Ux, Uy, Uz = (0.0, 0.0, 0.0) if calm else (S[1][i], S[2][i], S[3][i])
    ux, uy, uz = vx - Ux, vy - Uy, vz - Uz
    ut = ux * tx + uy * ty + uz * tz
    nx, ny, nz = ux - ut * tx, uy - ut * ty, uz - ut * tz
    sn = math.sqrt(nx * nx + ny * ny + nz * nz)
    if linear:
        rt, rn = 1.0 + w * (decay[1][i] - 1.0), 1.0 + w * (decay[0][i] - 1.0)
        m = vmass[i]
        jt, jn = (m + vlen[i] * at) * (rt - 1.0), (m + vlen[i] * an) * (rn - 1.0)   # impulse per relative velocity
    else:   # m (r - 1) = -w k s r; both r from one division
        ct, cn = wl * kt * abs(ut), wl * kn * sn
        wn, wt = (S[14][i], S[15][i]) if CARRIES else (im[i], im[i])
        at_, an_ = 1.0 + ct * wt, 1.0 + cn * wn
        d = 1.0 / (at_ * an_)
        rt, rn = an_ * d, at_ * d
        jt, jn = -ct * rt, -cn * rn
    return ((Ux + rt * ut * tx + rn * nx, Uy + rt * ut * ty + rn * ny, Uz + rt * ut * tz + rn * nz),
            -0.5 * (1.0 + rt) * jt * ut * ut - 0.5 * (1.0 + rn) * jn * sn * sn,
            jt * ut * (tx * Ux + ty * Uy + tz * Uz) + jn * (nx * Ux + ny * Uy + nz * Uz))


@njit(**CACHED, inline="always")
def kick_drag_vertex(v, f, im, hh, D, S, c, surface, vlen, vmass, i, kn, kt, an, at, linear, calm, decay, keep,
                     fresh):
    """Update the velocity columns v (3-tuple) at vertex i by half the kick's impulse (hh times
    the inverse mass im times the load columns f, as the kick takes them), the exact flow of
    drag (drag_flow), and that half impulse taken back, which the kick then gives with the
    other half: K/2 F K/2. D at i by the kick's whole change of the velocity where ``keep``.
    The vertex's wetness and tangent as the sample holds them, or where ``fresh`` as
    sample_still_line finds them, from the position columns c and the surface's height.
    Return the energy dissipated and the work supplied."""
    s = hh * im[i]
    ax, ay, az = s * f[0][i], s * f[1][i], s * f[2][i]
    wx, wy, wz = v[0][i] + ax, v[1][i] + ay, v[2][i] + az
    if fresh:
        w = 1.0 if c[2][i] <= surface else 0.0
        tx, ty, tz, _ = unit_chord(c, i - uint(1), i + uint(1))
    else:
        w, tx, ty, tz = S[0][i], S[7][i], S[8][i], S[9][i]
    u, d, g = drag_flow(wx, wy, wz, w, tx, ty, tz, S, vlen, vmass, im, i, kn, kt, an, at, linear, calm, decay)
    if keep:
        D[0][i], D[1][i], D[2][i] = u[0] - v[0][i] + ax, u[1] - v[1][i] + ay, u[2] - v[2][i] + az
    v[0][i], v[1][i], v[2][i] = u[0] - ax, u[1] - ay, u[2] - az
    return d, g


@njit(**PASS)
def kick_drag_line(v, f, im, hh, D, S, c, surface, vlen, vmass, first, n, kn, kt, an, at, linear, calm, decay, keep):
    """Update the velocity columns v at the n vertices first.. by the kick's drag
    (kick_drag_vertex; a loop per law, and for Morison's a calm medium's of its own: three rows
    fewer to read, no work supplied); return the energy dissipated and the work supplied.
    Where no line carries added mass and the medium is still (a variant's constants), nothing
    but the drag reads the sample at the interior vertices: each takes its wetness and tangent
    here from the positions (c; the surface's height), which hold still through the kick, as
    the sample would have found them (the sample skips them: sample_medium)."""
    dissipated = supplied = 0.0
    fresh = not CARRIES and not MOVING   # (a variant's constants: LLVM folds the test in each loop)
    # (each loop's guard names the options under which it can run: a variant compiles those alone)
    if CALM and DRAG and keep and calm and not linear:   # (the default: Lagrange's, Morison's, still water)
        for k in range(n):
            dissipated += kick_drag_vertex(v, f, im, hh, D, S, c, surface, vlen, vmass, first + uint(k), kn, kt, an,
                                           at, False, True, decay, True, False)[0]
    elif (CURRENT or RESISTANCE) and keep:   # (the test inside the loops cost a fifth of them: LLVM left it there)
        for k in range(n):
            d, g = kick_drag_vertex(v, f, im, hh, D, S, c, surface, vlen, vmass, first + uint(k), kn, kt, an, at,
                                    linear, calm, decay, True, False)
            dissipated += d
            supplied += g
    elif RESISTANCE and linear:
        for k in range(n):
            d, g = kick_drag_vertex(v, f, im, hh, D, S, c, surface, vlen, vmass, first + uint(k), kn, kt, an, at,
                                    True, False, decay, False, fresh)
            dissipated += d
            supplied += g
    elif CALM and DRAG and calm:
        for k in range(n):
            dissipated += kick_drag_vertex(v, f, im, hh, D, S, c, surface, vlen, vmass, first + uint(k), kn, kt, an,
                                           at, False, True, decay, False, fresh)[0]
    elif CURRENT and DRAG:
        for k in range(n):
            d, g = kick_drag_vertex(v, f, im, hh, D, S, c, surface, vlen, vmass, first + uint(k), kn, kt, an, at,
                                    False, False, decay, False, fresh)
            dissipated += d
            supplied += g
    return dissipated, supplied


@njit(**INNER)
def calm_medium(p):
    """Whether the medium is at rest everywhere and always (a still medium without a current)."""
    return still_medium(p) and p.current[0] == 0.0 and p.current[1] == 0.0 and p.current[2] == 0.0


@njit(**CACHED, inline="always")
def calm_now(p):
    """Whether the drag's and the turning fluid's passes take the medium at rest (calm_medium),
    by the variant's options where they tell it: their loops for the other case are then never
    compiled (kick_drag_line, added_mass.add_inner_turning)."""
    return not CURRENT or (CALM and calm_medium(p))


@njit(**CACHED, inline="always")
def linear_law(p):
    """Whether the drag is the linear law (p.law), by the variant's options where they tell it."""
    return not DRAG or (RESISTANCE and p.law == LINEAR)


@njit(**CACHED, inline="always")
def sample_rows(p):
    """The rows of p.sample as contiguous 1-D views."""
    S = p.sample
    return S[0], S[1], S[2], S[3], S[4], S[5], S[6], S[7], S[8], S[9], S[10], S[11], S[12], S[13], S[14], S[15]


@njit(**CACHED, inline="always")
def kick_changes(p):
    """The rows of p.turning that hold the last kick's whole change of the velocity at the
    interior vertices (kernels/added_mass.py: the next kick's prediction of its midpoint)."""
    T = p.turning
    return T[3], T[4], T[5]


@njit(**CACHED, inline="always")
def turns(p, j):
    """Whether row j's added mass differs across and along its line (its fluid turns with it:
    kernels/added_mass.py)."""
    return p.added_n[j] != p.added_t[j] and p.turning.shape[1] > 0


@njit(**INNER)
def set_decay(p, model, h):
    """Update p.decay for the linear law at the kick's length h where it changed: the decay of
    a wet vertex's relative velocity over the drag's flow, exp(-c h l / m) (m with the added
    mass of that direction), depends on h alone: a run of equal kicks takes its exponentials
    once instead of two a vertex a kick."""
    if not (RESISTANCE and linear_law(p) and p.decay_h[0] != h):
        return
    vlen = model.voronoi_rest_length
    nl = model.line_vertex_offsets.shape[0] - 1
    for j in range(p.lines.shape[0]):
        l = p.lines[j]
        if 0 <= l < nl:
            for i in range(model.line_vertex_offsets[l] + 1, model.line_vertex_offsets[l + 1] - 1):
                p.decay[0, i] = math.exp(-h * p.drag_n[j] * vlen[i] * p.wet_inverse[0, i])
                p.decay[1, i] = math.exp(-h * p.drag_t[j] * vlen[i] * p.wet_inverse[1, i])
    p.decay_h[0] = h


@njit(**INNER)
def kick_drag_vertices(p, model, state, loads, h, j0, j1):
    """Update state.v of the interior vertices of rows j0..j1-1's lines by the exact flow of
    drag for the kick's length h, between the kick's two halves (K/2 F K/2: kick_drag_vertex;
    the kick that follows gives the whole impulse of loads.f, as the added mass left it): the
    tangential and normal parts of the relative velocity u each keep their direction, their
    size s becoming s r with r = 1 / (1 + k s h / m) for Morison's law, exp(-k h / m) for the
    linear one (p.decay: set_decay), m with the added mass of that direction. Rows 3-5 of
    p.turning, where the line's fluid turns, by the kick's whole change of the velocity (the
    next kick's prediction of its midpoint: added_mass.predicted). Return (the energy
    dissipated, the work supplied). One flow a kick at its middle where two halves on its
    sides took two passes; the step stays a symmetric sequence (second order) and stable
    however stiff the drag. (A loop per law over contiguous columns with unsigned indices,
    branch-free, which LLVM vectorises; see layout.columns.)"""
    v, f, S, c = columns(state.v), columns(loads.f), sample_rows(p), columns(state.x)
    vlen, vmass, im = model.voronoi_rest_length, model.vertex_mass, model.vertex_inv_mass
    nl = model.line_vertex_offsets.shape[0] - 1
    decay = (p.decay[0], p.decay[1])
    D = kick_changes(p)
    calm = calm_now(p)
    dissipated = supplied = 0.0
    for j in range(j0, j1):
        l = p.lines[j]
        if l < 0 or l >= nl or (p.drag_n[j] == 0.0 and p.drag_t[j] == 0.0):
            continue
        lo, hi = model.line_vertex_offsets[l], model.line_vertex_offsets[l + 1]
        first, n = uint(lo + 1), hi - lo - 2
        kn, kt, an, at, linear = h * p.drag_n[j], h * p.drag_t[j], p.added_n[j], p.added_t[j], linear_law(p)
        d, g = kick_drag_line(v, f, im, 0.5 * h, D, S, c, p.surface, vlen, vmass, first, n, kn, kt, an, at, linear,
                              calm, decay, turns(p, j))
        dissipated += d
        supplied += g
    return dissipated, supplied


@njit(**CACHED, inline="always")
def end_arm(model, state, a):
    """Return line end a's offset from its node's centre of mass, in the lab frame."""
    q, o = state.node_q[model.attach_node[a]], model.attach_offset[a]
    if o[0] == 0.0 and o[1] == 0.0 and o[2] == 0.0:   # (a point junction's ends: no arm)
        return 0.0, 0.0, 0.0
    return quat_rotate(q[0], q[1], q[2], q[3], o[0], o[1], o[2])


@njit(**CACHED, inline="always")
def node_free(p, model, nd):
    """Whether the medium moves node nd itself (finite mass, no drive holding it)."""
    return model.node_inv_mass[nd] > 0.0 and not (nd < p.node_skip.shape[0] and p.node_skip[nd] != 0.0)


@njit(**CACHED, inline="always")
def entrained_at(v, S, vlen, i, an, at):
    """Return 1/2 v^T M_a v at vertex i (M_a as p.sample holds it; see entrained_energy)."""
    return entrained_of(v[0][i], v[1][i], v[2][i], S, vlen, i, an, at)


@njit(**CACHED, inline="always")
def entrained_of(vx, vy, vz, S, vlen, i, an, at):
    """Return 1/2 u^T M_a u for the velocity u = (vx, vy, vz) and the added mass of vertex i."""
    vt = vx * S[7][i] + vy * S[8][i] + vz * S[9][i]
    vv = vx * vx + vy * vy + vz * vz
    return 0.5 * S[0][i] * vlen[i] * (an * (vv - vt * vt) + at * vt * vt)


@njit(**PASS)
def entrained_line(v, S, vlen, first, n, an, at):
    """Return 1/2 v^T M_a v summed over the n vertices first.. (entrained_at)."""
    e = 0.0
    for k in range(n):
        e += entrained_at(v, S, vlen, first + uint(k), an, at)
    return e


@njit(**CACHED, inline="always")
def carrying_span(p, model, j):
    """Return (l, lo, hi): row j's line and its vertices lo..hi-1 when it carries added mass,
    else hi = 0."""
    l = p.lines[j]
    if l < 0 or l >= model.line_vertex_offsets.shape[0] - 1 or (p.added_n[j] == 0.0 and p.added_t[j] == 0.0):
        return l, 0, 0
    return l, model.line_vertex_offsets[l], model.line_vertex_offsets[l + 1]


@njit(**INNER)
def ends_entrained(p, model, state, S, vlen, l, lo, hi, an, at):
    """Return the share of entrained_energy at the ends (vertices lo, hi - 1) of line l whose
    nodes the medium moves (an, at: its added masses per length): their added mass moves with
    the node's centre of mass, as the kick and the drag move it (node_mass_matrix: it adds to
    the node's mass, not to its rotary inertia), so at the node's velocity."""
    e = 0.0
    for i, end in ((lo, 0), (hi - 1, 1)):
        nd = model.attach_node[2 * l + end]
        if node_free(p, model, nd):
            vn = state.node_v[nd]
            e += entrained_of(vn[0], vn[1], vn[2], S, vlen, uint(i), an, at)
    return e
