"""Coulomb friction by elastic stick and plastic slip, shared by the line-obstacle contact
(cosnet.kernels.obstacles) and the line-line contact (cosnet.kernels.contact).

A contact carries a tangential spring of stiffness k_t; a its displacement (in the tangent
plane) and e = a + (gamma / k_t) v_t the trial displacement, the spring and a dashpot beside
it. The Coulomb limit is an ellipse in the tangent plane, with coefficients along the line's
tangent t (forward or backward, by the sign of e . t) and across it (lateral):

    (k_t e_long / mu_long)^2 + (k_t e_lat / mu_lat)^2 <= fn^2.

A sticking contact whose trial leaves the static ellipse (mu_s) starts sliding, the dashpot
idle, and the spring's anchor is dragged so that its displacement is the point b of the
kinetic ellipse (mu_k) that resists each component of the trial's direction u with its own
coefficient:

    k_t b = fn (mu_long u_long t + mu_lat u_lat l),    u = e / |e|,  l the lateral direction,

the anisotropic Coulomb law of slithering locomotion (Hu, Nirody, Scott and Shelley, PNAS
2009; PyElastica's anisotropic plane): a sliding force -fn M u for a slip along u. (Scaling
the trial radially back onto the ellipse instead would resist the along-line share of a
mostly sideways slip with the lateral coefficient, and a snake would barely advance.) Sliding
along the line or straight across it, both give mu fn against the slip. A sliding contact
whose trial falls inside the kinetic ellipse sticks again. A direction with mu = 0 carries
no friction, and the slip's direction is then taken in the other alone.
"""

import math

from numba import njit

from .compiler import CACHED, CACHED_INNER


@njit(**CACHED, inline="always")
def ellipse(a, b, mu_long, mu_lat, k_t, fn):
    """Return the trial friction of displacement (a along, b across the line) measured against
    the ellipse of coefficients (mu_long, mu_lat) at normal force fn: <= 1 inside, inf where a
    direction without friction (mu fn <= 0) is displaced. Branch-free (selects, each quotient
    computed whether used or not), so that a loop over contacts can run in vector lanes."""
    qa = (k_t * a / (mu_long * fn)) ** 2
    qb = (k_t * b / (mu_lat * fn)) ** 2
    q = 0.0 + qa if a != 0.0 else 0.0
    q = q + qb if b != 0.0 else q
    held = ((a != 0.0) & (mu_long * fn <= 0.0)) | ((b != 0.0) & (mu_lat * fn <= 0.0))   # no short cuts: no branches
    return math.inf if held else math.sqrt(q)


@njit(**CACHED, inline="always")
def plane_tangent(ux, uy, uz, nx, ny, nz):
    """Unit vector along u projected on the plane normal to n (zeros when u is along n);
    branch-free, as ellipse."""
    tn = ux * nx + uy * ny + uz * nz
    tx, ty, tz = ux - tn * nx, uy - tn * ny, uz - tn * nz
    t = math.sqrt(tx * tx + ty * ty + tz * tz)
    some = t > 0.0
    return (tx / t if some else 0.0), (ty / t if some else 0.0), (tz / t if some else 0.0)


@njit(**CACHED, inline="always")
def turn_into_plane(ax, ay, az, nx, ny, nz):
    """Return the spring displacement a turned into the plane normal to unit n, its length
    kept: a contact's normal turns as the bodies move, and a projection alone would shed the
    spring's energy at every turn."""
    length = math.sqrt(ax * ax + ay * ay + az * az)
    an = ax * nx + ay * ny + az * nz
    ax, ay, az = ax - an * nx, ay - an * ny, az - an * nz
    turned = math.sqrt(ax * ax + ay * ay + az * az)
    if turned > 0.0:
        ax, ay, az = ax * (length / turned), ay * (length / turned), az * (length / turned)
    return ax, ay, az


@njit(**CACHED_INNER)
def stick_slip(ax, ay, az, ex, ey, ez, tx, ty, tz, sliding, mu_s, mu_k, k_t, fn):
    """Return (bx, by, bz, slides, lost): the spring displacement the friction force -k_t b
    acts with, whether the contact slides, and the plastic work of the slip, given the
    spring's displacement a, the trial e, the line's unit tangent t in the tangent plane,
    whether the contact slid before, the coefficients mu_s, mu_k ((3,): forward, backward,
    lateral), k_t and the normal force fn (see the module docstring). Sticking: b = e."""
    return slip_law(ax, ay, az, ex, ey, ez, tx, ty, tz, sliding, mu_s[0], mu_s[1], mu_s[2],
                    mu_k[0], mu_k[1], mu_k[2], k_t, fn)


@njit(**CACHED, inline="always")
def slip_law(ax, ay, az, ex, ey, ez, tx, ty, tz, sliding, s_fwd, s_back, s_lat, k_fwd, k_back, k_lat, k_t, fn):
    """stick_slip with the coefficients as numbers (static then kinetic: forward, backward,
    lateral), branch-free as ellipse: a loop over contacts calling it can run in vector
    lanes, each lane computing what the branching form computed, bit for bit."""
    along = ex * tx + ey * ty + ez * tz
    lx, ly, lz = ex - along * tx, ey - along * ty, ez - along * tz
    lat = math.sqrt(lx * lx + ly * ly + lz * lz)
    forward = along >= 0.0   # moved forward: the forward coefficient resists
    k_long = k_fwd if forward else k_back
    trial = ellipse(along, lat, k_long if sliding else (s_fwd if forward else s_back),
                    k_lat if sliding else s_lat, k_t, fn)
    sticks = not trial > 1.0
    # a direction without friction lets its share go; each remaining component of the
    # trial's direction is resisted with its own kinetic coefficient (module docstring)
    free_long, free_lat = k_long * fn <= 0.0, k_lat * fn <= 0.0
    along = 0.0 if free_long else along
    lx, ly, lz, lat = (0.0 if free_lat else lx), (0.0 if free_lat else ly), (0.0 if free_lat else lz), \
        (0.0 if free_lat else lat)
    size = math.sqrt(along * along + lat * lat)
    # measured against mu_k again unless the trial was measured against it as it is
    again = ellipse(along, lat, k_long, k_lat, k_t, fn)
    trial = again if (free_long | free_lat | (not sliding)) else trial
    grip = fn / (k_t * size)
    # inside after all (what a frictionless direction left): it sticks as it is
    ca = 1.0 if not trial > 1.0 else (grip * k_long if size > 0.0 else 0.0)
    cl = 1.0 if not trial > 1.0 else (grip * k_lat if size > 0.0 else 0.0)
    bx, by, bz = ca * along * tx + cl * lx, ca * along * ty + cl * ly, ca * along * tz + cl * lz
    # the plastic work: the friction force on the anchor's slip (the spring's own energy drop
    # would also count the drift's O(h^2) excess over a constant force)
    lost = k_t * (bx * (ax - bx) + by * (ay - by) + bz * (az - bz))
    return ((ex if sticks else bx), (ey if sticks else by), (ez if sticks else bz), not sticks,
            (0.0 if sticks else lost))
