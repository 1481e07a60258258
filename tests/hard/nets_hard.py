"""Builders of the hard nets (stiff/soft contrasts, extreme mass ratios, pre-stress, fast spin,
buckling). Each returns the Net and a dict of the parts a test or a benchmark needs, plus the
numbers its analytic check uses. SI units throughout."""

from __future__ import annotations

import math

import numpy as np

import cosnet

STEEL = cosnet.Material(E=2.1e11, G=8.1e10, density=7850.0, name="steel")


def stiffness_contrast(ratio=1e6, soft_radius=0.01, soft_length=0.5, soft_elements=10):
    """A thick steel stub (fixed at the origin, along x) carrying, through a massless point
    junction, a slender line 'ratio' times softer (E_soft = E_steel / ratio) and lighter
    (density 100 kg/m^3) that ends free. The soft line is effectively clamped at the junction."""
    soft = cosnet.Material(E=STEEL.E / ratio, G=STEEL.G / ratio, density=100.0, name="soft")
    net = cosnet.Net()
    root = net.add_node((0.0, 0.0, 0.0), fixed=True, name="root")
    joint = net.add_node((0.2, 0.0, 0.0), name="joint")
    tip = net.add_node((0.2 + soft_length, 0.0, 0.0), name="tip")
    stub = net.add_line(root, joint, material=STEEL, section=cosnet.Circle(0.05), elements=2, name="stub")
    line = net.add_line(joint, tip, material=soft, section=cosnet.Circle(soft_radius),
                        elements=soft_elements, name="soft")
    return net, {"root": root, "joint": joint, "tip": tip, "stub": stub, "soft": line,
                 "material": soft, "section": cosnet.Circle(soft_radius), "length": soft_length}


def heavy_body_on_light_line(ratio=1e6, length=1.0, radius=0.05, elements=4):
    """A rigid body of mass M hanging from a fixed node on one line of mass M / ratio; the
    body bounces on the line's axial stiffness k = E A / L."""
    A = math.pi * radius**2
    line_mass = 1.0
    mat = cosnet.Material(E=1e7, poisson=0.3, density=line_mass / (A * length), name="light")
    M = ratio * line_mass
    net = cosnet.Net()
    top = net.add_node((0.0, 0.0, 0.0), fixed=True, name="top")
    body = net.add_node((0.0, 0.0, -length - 0.1), mass=M, inertia=M * 0.01 * np.ones(3), name="body")
    line = net.add_line(top, body, material=mat, section=cosnet.Circle(radius), elements=elements,
                        end_offset=(0.0, 0.0, 0.1), name="line")
    return net, {"top": top, "body": body, "line": line, "M": M, "m": line_mass,
                 "k": mat.E * A / length}


def light_body_on_stiff_lines(ratio=1e6, elements=4):
    """A free net: three steel lines from a light rigid body (own mass = line mass / ratio,
    ends at offsets) to three point masses of a line's mass each."""
    net = cosnet.Net()
    sec = cosnet.Circle(0.01)
    line_mass = STEEL.density * sec.A * 0.5
    m = line_mass / ratio
    body = net.add_node((0.0, 0.0, 0.0), mass=m, inertia=m * 1e-4 * np.array([1.0, 2.0, 3.0]), name="body")
    lines = []
    for k in range(3):
        a = 2 * math.pi * k / 3
        u = np.array([math.cos(a), math.sin(a), 0.1 * (k - 1)])
        u /= np.linalg.norm(u)
        tip = net.add_node(0.51 * u, mass=line_mass, name=f"tip{k}")
        lines.append(net.add_line(body, tip, material=STEEL, section=sec, elements=elements,
                                  start_offset=0.01 * u, name=f"arm{k}"))
    return net, {"body": body, "lines": lines}


def fibonacci_directions(n):
    """n unit vectors spread evenly over the sphere (the Fibonacci lattice)."""
    k = np.arange(n) + 0.5
    z = 1.0 - 2.0 * k / n
    phi = math.pi * (1.0 + 5.0**0.5) * k
    r = np.sqrt(1.0 - z * z)
    return np.column_stack([r * np.cos(phi), r * np.sin(phi), z])


def star(lines=20, length=0.3, elements=3):
    """A free star: 'lines' rubber lines from one point junction (no mass or inertia of its
    own: its rotary inertia is only the quarter end elements) to free ends."""
    mat = cosnet.Material(E=5e6, G=2e6, density=1000.0, name="rubber")
    net = cosnet.Net()
    hub = net.add_node((0.0, 0.0, 0.0), name="hub")
    out = []
    for k, u in enumerate(fibonacci_directions(lines)):
        tip = net.add_node(length * u, name=f"tip{k}")
        out.append(net.add_line(hub, tip, material=mat, section=cosnet.Circle(0.01), elements=elements,
                                name=f"ray{k}"))
    return net, {"hub": hub, "lines": out}


def slender_cantilever(slenderness=200.0, length=1.0, elements=20):
    """A steel cantilever with L / r = slenderness: E A / (E I / L^2) = 4 (L / r)^2."""
    radius = length / slenderness
    net = cosnet.Net()
    root = net.add_node((0.0, 0.0, 0.0), fixed=True, name="root")
    tip = net.add_node((length, 0.0, 0.0), name="tip")
    line = net.add_line(root, tip, material=STEEL, section=cosnet.Circle(radius), elements=elements, name="rod")
    return net, {"root": root, "tip": tip, "line": line, "section": cosnet.Circle(radius), "length": length}


def spinning_hub(arms=3, length=0.4, hub_radius=0.05, tip_mass=0.05, elements=6):
    """A free steel rotor: a hub body with 'arms' radial lines in the xy plane, each ending in
    a point mass; made to spin about z by the test."""
    net = cosnet.Net()
    hub = net.add_node((0.0, 0.0, 0.0), mass=1.0, inertia=np.diag([2e-3, 2e-3, 4e-3]), name="hub")
    out, tips = [], []
    for k in range(arms):
        a = 2 * math.pi * k / arms
        u = np.array([math.cos(a), math.sin(a), 0.0])
        tip = net.add_node((hub_radius + length) * u, mass=tip_mass, name=f"tip{k}")
        tips.append(tip)
        out.append(net.add_line(hub, tip, material=STEEL, section=cosnet.Circle(0.005), elements=elements,
                                start_offset=hub_radius * u, name=f"arm{k}"))
    return net, {"hub": hub, "tips": tips, "lines": out, "hub_radius": hub_radius, "length": length,
                 "tip_mass": tip_mass, "section": cosnet.Circle(0.005)}


def lone_body(inertia=(1.0, 100.0, 1e4), mass=1.0):
    """A single free rigid body (a node with no lines)."""
    net = cosnet.Net()
    body = net.add_node((0.0, 0.0, 0.0), mass=mass, inertia=np.diag(inertia), name="body")
    return net, {"body": body, "inertia": np.array(inertia, dtype=float)}


def _junction_frames(turn_deg, polygon):
    """Line end frames X for a closed planar polygon (xy plane) of straight lines whose
    consecutive lines must meet with tangent turning 'turn_deg' degrees at each corner (180
    minus the corner angle). Node frames are the identity; line k runs from corner k to k+1."""
    n = len(polygon)
    starts = []
    for k in range(n):
        t = polygon[(k + 1) % n] - polygon[k]
        heading = math.atan2(t[1], t[0])
        starts.append(heading)
    # distribute the mismatch: at corner k, the incoming line's end tangent and the outgoing
    # line's start tangent differ by turn_deg, symmetric about the built bisector
    frames = []
    for k in range(n):
        out_h = starts[k]
        in_h = starts[k - 1]
        mid = in_h + 0.5 * math.atan2(math.sin(out_h - in_h), math.cos(out_h - in_h))
        half = 0.5 * math.radians(turn_deg)
        frames.append((mid - half, mid + half))   # (incoming end heading, outgoing start heading)
    return frames


def _heading_frame(h):
    """Frame with d3 = (cos h, sin h, 0), d1 = z (the bending plane is the xy plane)."""
    d3 = np.array([math.cos(h), math.sin(h), 0.0])
    d1 = np.array([0.0, 0.0, 1.0])
    return np.column_stack([d1, np.cross(d3, d1), d3])


def prestressed_polygon(sides, turn_deg, side=1.0, radius=0.02, elements=12, material=None):
    """A free closed polygon of straight lines whose junction frames X force the tangents to
    turn 'turn_deg' at every corner (point junctions without mass). No stress-free state
    exists unless sides * turn_deg = 360. Returns the net and its parts."""
    mat = material or cosnet.Material(E=1e7, G=4e6, density=1000.0, name="plastic")
    R = side / (2 * math.sin(math.pi / sides))
    poly = [np.array([R * math.cos(2 * math.pi * k / sides), R * math.sin(2 * math.pi * k / sides), 0.0])
            for k in range(sides)]
    frames = _junction_frames(turn_deg, poly)
    net = cosnet.Net()
    nodes = [net.add_node(p, name=f"c{k}") for k, p in enumerate(poly)]
    lines = []
    for k in range(sides):
        a, b = nodes[k], nodes[(k + 1) % sides]
        lines.append(net.add_line(a, b, material=mat, section=cosnet.Circle(radius), elements=elements,
                                  start_frame=_heading_frame(frames[k][1]),
                                  end_frame=_heading_frame(frames[(k + 1) % sides][0]),
                                  d1=(0.0, 0.0, 1.0), name=f"side{k}"))
    return net, {"nodes": nodes, "lines": lines, "material": mat, "section": cosnet.Circle(radius),
                 "side": side}


def bent_triangle(**kw):
    """§2.3: three straight lines joined at right angles (tangents turning 90 degrees, not 120)."""
    return prestressed_polygon(3, 90.0, **kw)


def closed_ring(sides=4, **kw):
    """A loop of straight lines joined tangentially (tangents turning 0 degrees at the corners,
    i.e. consecutive lines meet at 180 degrees): it must bend into a circle."""
    return prestressed_polygon(sides, 0.0, **kw)


def column(length=1.0, radius=0.02, elements=16, material=None):
    """A vertical steel column clamped at the origin, free at the top (clamped-free):
    Euler's critical load pi^2 E I / (4 L^2)."""
    mat = material or STEEL
    net = cosnet.Net()
    base = net.add_node((0.0, 0.0, 0.0), fixed=True, name="base")
    top = net.add_node((0.0, 0.0, length), name="top")
    line = net.add_line(base, top, material=mat, section=cosnet.Circle(radius), elements=elements, name="column")
    sec = cosnet.Circle(radius)
    return net, {"base": base, "top": top, "line": line, "EI": mat.E * sec.I11,
                 "P_cr": math.pi**2 * mat.E * sec.I11 / (4 * length**2), "length": length}


def shallow_arch(span=1.0, rise=0.05, radius=0.01, elements=10, material=None):
    """A shallow circular arch clamped at both ends (fixed nodes), built as two polylines
    (stress free as built) meeting at a crown point junction."""
    mat = material or STEEL
    half = 0.5 * span
    Rc = (half**2 + rise**2) / (2 * rise)
    net = cosnet.Net()
    left = net.add_node((-half, 0.0, 0.0), fixed=True, name="left")
    right = net.add_node((half, 0.0, 0.0), fixed=True, name="right")
    crown = net.add_node((0.0, 0.0, rise), name="crown")

    def arc(x0, x1):
        x = np.linspace(x0, x1, elements + 1)
        z = np.sqrt(Rc**2 - x**2) - (Rc - rise)
        return np.column_stack([x, np.zeros_like(x), z])

    a = net.add_line(left, crown, material=mat, section=cosnet.Circle(radius), elements=elements,
                     points=arc(-half, 0.0), d1=(0.0, 1.0, 0.0), name="left_half")
    b = net.add_line(crown, right, material=mat, section=cosnet.Circle(radius), elements=elements,
                     points=arc(0.0, half), d1=(0.0, 1.0, 0.0), name="right_half")
    return net, {"left": left, "right": right, "crown": crown, "lines": [a, b], "rise": rise,
                 "span": span, "EI": mat.E * cosnet.Circle(radius).I11}


def long_run_net(elements=4):
    """A free net for long runs: an extended body, a point mass and a point junction joined by
    four lines (one loop), offsets on the body."""
    mat = cosnet.Material(E=5e6, G=2e6, density=1000.0, name="rubber")
    net = cosnet.Net()
    body = net.add_node((0.0, 0.0, 0.0), mass=0.3, inertia=np.diag([1e-3, 2e-3, 2.5e-3]), name="body")
    a = net.add_node((0.6, 0.0, 0.0), name="a")
    b = net.add_node((0.3, 0.5, 0.1), mass=0.05, inertia=np.diag([1e-5, 1e-5, 1e-5]), name="b")
    c = net.add_node((-0.2, 0.4, -0.3), name="c")
    net.add_line(body, a, material=mat, section=cosnet.Circle(0.02), elements=elements,
                 start_offset=(0.08, 0.0, 0.0), name="l1")
    net.add_line(a, b, material=mat, section=cosnet.Rectangle(0.03, 0.02), elements=elements, name="l2")
    net.add_line(b, body, material=mat, section=cosnet.Circle(0.015), elements=elements,
                 end_offset=(0.0, 0.08, 0.03), name="l3")
    net.add_line(b, c, material=mat, section=cosnet.Circle(0.012), elements=elements, name="l4")
    return net, {"body": body, "a": a, "b": b, "c": c}


def rigid_motion(sim, velocity, omega):
    """Set every vertex, element and node of sim to the rigid motion v + omega x (r - c),
    c = the centre of mass (lab vectors)."""
    from cosnet.core.rotations import matrix_from_quat
    m, s = sim.model, sim.state
    omega = np.asarray(omega, dtype=float)
    fin = np.isfinite(m.node_mass)
    mass = m.vertex_mass[m.vertex_inv_mass > 0].sum() + m.node_mass[fin].sum()
    c = (m.vertex_mass[m.vertex_inv_mass > 0] @ s.x[m.vertex_inv_mass > 0]
         + m.node_mass[fin] @ s.node_x[fin]) / mass
    s.v[:] = velocity + np.cross(omega, s.x - c)
    s.w[:] = np.einsum("eji,j->ei", matrix_from_quat(s.q), omega)
    s.node_v[:] = velocity + np.cross(omega, s.node_x - c)
    s.node_w[:] = np.einsum("nji,j->ni", matrix_from_quat(s.node_q), omega)
    return c


# ---------------------------------------------------------------------- analysis helpers
BETA_L = (1.8751040687, 4.6940911330, 7.8547574382)   # clamped-free Euler-Bernoulli roots


def eb_shape(beta_l, s):
    """Clamped-free Euler-Bernoulli mode shape at s in [0, 1] (fraction of L) and its slope
    d/ds (per unit s)."""
    b = beta_l
    sig = (math.cosh(b) + math.cos(b)) / (math.sinh(b) + math.sin(b))
    x = b * np.asarray(s, dtype=float)
    phi = np.cosh(x) - np.cos(x) - sig * (np.sinh(x) - np.sin(x))
    dphi = b * (np.sinh(x) + np.sin(x) - sig * (np.cosh(x) - np.cos(x)))
    return phi, dphi


def excite_bending_mode(sim, line, mode=0, amplitude=1e-3, lateral=(0.0, 0.0, 1.0)):
    """Give a straight clamped-free line the velocity field of its Euler-Bernoulli mode
    (vertices move along 'lateral', elements turn with the slope, the free end node follows).
    Returns the mass-weighted projection signal(sim) of the displacement on the mode."""
    from cosnet.core.rotations import matrix_from_quat
    n = line.elements
    L = line.length
    x0 = sim.line_positions(line).copy()
    t = (x0[-1] - x0[0]) / np.linalg.norm(x0[-1] - x0[0])
    lat = np.asarray(lateral, dtype=float)
    s = np.linspace(0.0, 1.0, n + 1)
    phi, _ = eb_shape(BETA_L[mode], s)
    sim.line_velocities(line)[:] = amplitude * phi[:, None] * lat
    sim.node_velocity(line.end)[:] = amplitude * phi[-1] * lat
    smid = 0.5 * (s[1:] + s[:-1])
    slope = amplitude * eb_shape(BETA_L[mode], smid)[1] / L
    axis = np.cross(t, lat)                              # the rotation axis of a lateral slope
    eo = sim.model.line_element_offsets
    D = matrix_from_quat(sim.state.q[eo[line.index]:eo[line.index + 1]])
    sim.line_angular_velocities(line)[:] = np.einsum("eji,j->ei", D, axis) * slope[:, None]
    o = sim.model.line_vertex_offsets
    weights = sim.model.vertex_mass[o[line.index]:o[line.index + 1]] * phi
    return lambda sim: float(weights @ ((sim.line_positions(line) - x0) @ lat))


def zero_crossing_omega(sim, signal, periods, omega_guess, samples_per_period=40, record=None):
    """Run sim for 'periods' periods of omega_guess, sampling signal(sim) (zero at the start),
    and return the angular frequency fitted to its zero crossings. record(sim), if given, is
    called at every sample."""
    period = 2 * math.pi / omega_guess
    n_sub = max(1, int(period / samples_per_period / sim.dt))
    t, y = [sim.time], [signal(sim)]
    t_end = sim.time + periods * period
    while sim.time < t_end:
        sim.run(steps=n_sub)
        t.append(sim.time)
        y.append(signal(sim))
        if record is not None:
            record(sim)
    t, y = np.array(t), np.array(y)
    k = np.flatnonzero((np.sign(y[1:]) != np.sign(y[:-1])) & (y[:-1] != 0))
    crossings = t[k] - y[k] * (t[k + 1] - t[k]) / (y[k + 1] - y[k])
    crossings = crossings[crossings > t[0] + 0.25 * period]
    if len(crossings) < 2:
        raise AssertionError(f"signal crossed zero {len(crossings)} times in {periods} periods")
    half = np.polyfit(np.arange(len(crossings)), crossings, 1)[0]
    return math.pi / half


def rigid_body_flip_period(inertia, omega):
    """Period of the torque-free motion of a rigid body (principal inertia I1 < I2 < I3,
    body angular velocity omega): the intermediate component changes sign twice per period.
    Jacobi's solution (Landau & Lifshitz §37): T = 4 K(m) / rate."""
    from scipy.special import ellipk
    I1, I2, I3 = inertia
    w = np.asarray(omega, dtype=float)
    E2 = float(np.dot(inertia, w * w))             # 2 E
    M2 = float(np.dot(np.square(inertia), w * w))  # |L|^2
    if M2 > E2 * I2:
        rate = math.sqrt((I3 - I2) * (M2 - E2 * I1) / (I1 * I2 * I3))
        m = (I2 - I1) * (E2 * I3 - M2) / ((I3 - I2) * (M2 - E2 * I1))
    else:
        rate = math.sqrt((I2 - I1) * (E2 * I3 - M2) / (I1 * I2 * I3))
        m = (I3 - I2) * (M2 - E2 * I1) / ((I2 - I1) * (E2 * I3 - M2))
    return 4.0 * float(ellipk(m)) / rate


def elastica_tip_deflection(load_ratio, length):
    """Lateral tip deflection of a clamped-free elastica under an axial tip load
    P = load_ratio * P_cr (> 1): with k = sin(theta0 / 2), K(k^2) = (pi / 2) sqrt(P / P_cr)
    and delta = 2 k / sqrt(P / EI) = 2 k L / K."""
    from scipy.optimize import brentq
    from scipy.special import ellipk
    target = 0.5 * math.pi * math.sqrt(load_ratio)
    m = brentq(lambda m: ellipk(m) - target, 0.0, 1.0 - 1e-15)
    return 2.0 * math.sqrt(m) * length / target
