"""Articulated line ends (§8): hinges, universal and ball joints, exact.

A stiff arm on a free hinge swings as the compound pendulum of its masses (small amplitude and
the elliptic-integral period at 90 degrees) and its hinge carries no moment about its axis; the
energy error is Verlet's order 2 and the stable step is the welded arm's; a torsion spring's
period, a friction hinge that holds below its static torque and turns above it with the
energy it takes equal to the kinetic torque times the angle turned, a damper's energy, a
Cardan joint's output angle tan(theta_2) = cos(beta) tan(theta_1), a ball joint that keeps
the angular momentum about the vertical, a loose ball joint settled in closed form where the
iteration settles it, checkpoints and bad input."""

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from scipy.special import ellipk

import cosnet
from cosnet.core.rotations import matrix_from_quat
from cosnet.kernels.joint_lanes import AHEAD, BALL_OK, G_OK, GRIPPED, OK, S_OK, SETTLED, SOCKETED, U_OK, UNIVERSALS, \
    W_MOVES, W_OK, WEIGHED
from nets import resumed

G = 9.81
STIFF = cosnet.Material(E=1e10, G=4e9, density=1000.0)
SOFT = cosnet.Material(E=1e8, G=4e7, density=1000.0)
SECTION = cosnet.Circle(0.02)
Y = (0.0, 1.0, 0.0)


def hanging_arm(alpha, joint, material=STIFF, n=10, g=G, end="start"):
    """A 1 m arm from a fixed pivot at the origin, at angle alpha from the downward vertical in
    the x-z plane, its start on ``joint`` (``end`` = "end": the arm drawn from its tip to the
    pivot, its end on the joint), under gravity g. Returns (sim, line, tip node)."""
    net = cosnet.Net()
    pivot = net.add_node((0.0, 0.0, 0.0), fixed=True, name="pivot")
    tip = net.add_node((math.sin(alpha), 0.0, -math.cos(alpha)), name="tip")
    if end == "end":
        arm = net.add_line(tip, pivot, material=material, section=SECTION, elements=n, end_joint=joint, name="arm")
    else:
        arm = net.add_line(pivot, tip, material=material, section=SECTION, elements=n, start_joint=joint, name="arm")
    return cosnet.Simulation(net, [cosnet.Gravity((0.0, 0.0, -g))]), arm, tip


def pendulum_constants(sim):
    """(I, m d): the moment of inertia about the pivot and the first moment of mass of the
    arm as built (its vertex masses and rotary inertias: the rigid-body limit of the discrete
    arm), pivot at the origin."""
    m = sim.model
    r = np.linalg.norm(sim.state.x, axis=1)
    inertia = (m.vertex_mass * r ** 2).sum() + m.element_inertia[:, 0].sum() + m.node_inertia[1].min()
    return inertia, (m.vertex_mass * r).sum()


def record(sim, line, until, every=100, end="start"):
    """(times, joint angles, reactions) sampled every ``every`` steps up to ``until``."""
    t, phi, reaction = [sim.time], [0.0], [np.zeros(3)]
    while sim.time < until:
        sim.run(steps=every)
        s = cosnet.joint_state(sim, line, end)
        t.append(sim.time)
        phi.append(s["angle"][0])
        reaction.append(s["reaction"])
    return np.array(t), np.array(phi), np.array(reaction)


def crossings(t, y, level):
    """Times where y crosses level, by linear interpolation between samples."""
    d = y - level
    i = np.flatnonzero(np.sign(d[1:]) != np.sign(d[:-1]))
    i = i[d[i] != 0.0]
    return t[i] - d[i] * (t[i + 1] - t[i]) / (d[i + 1] - d[i])


@pytest.mark.parametrize("alpha, end", [(0.05, "start"), (math.pi / 2, "start"), (math.pi / 2, "end")])
def test_free_hinge_swings_as_a_compound_pendulum(alpha, end):
    sim, arm, _ = hanging_arm(alpha, cosnet.Hinge(axis=Y), end=end)
    inertia, md = pendulum_constants(sim)
    small = 2.0 * math.pi * math.sqrt(inertia / (md * G))
    expected = small if alpha < 0.1 else small * 2.0 / math.pi * ellipk(math.sin(alpha / 2.0) ** 2)
    t, phi, reaction = record(sim, arm, 1.35 * expected, end=end)
    # the arm passes the vertical halfway between the turning points, phi = +-alpha
    down = crossings(t, phi, 0.5 * (phi.max() + phi.min()))
    assert down.size >= 3
    assert abs((down[2] - down[0]) / expected - 1.0) < 5e-3
    # a free hinge carries no moment about its axis: to the Newton tolerance of its balance
    assert np.abs(reaction[:, 1]).max() < 1e-8 * md * G


def test_hinge_energy_error_is_second_order():
    errs = []
    for refine in (1, 2):
        sim, arm, _ = hanging_arm(math.pi / 2, cosnet.Hinge(axis=Y), material=SOFT)
        dt = 0.5 * sim.dt / refine
        sim = cosnet.Simulation(sim.net, [cosnet.Gravity((0.0, 0.0, -G))], dt=dt)
        e0, worst = sim.energy(), 0.0
        for _ in range(20):
            sim.run(steps=200 * refine)
            worst = max(worst, abs(sim.energy() - e0))
        errs.append(worst)
    assert 3.2 < errs[0] / errs[1] < 4.8, errs


def test_free_hinge_keeps_the_welded_stable_step():
    hinged, arm, _ = hanging_arm(0.3, cosnet.Hinge(axis=Y), material=SOFT)
    welded = hanging_arm(0.3, None, material=SOFT)[0]
    assert abs(hinged.stable_dt() / welded.stable_dt() - 1.0) < 0.05
    # and the hinged arm is stable at that step (the watch raises on a blow-up)
    free = cosnet.Simulation(hinged.net, [cosnet.Gravity((0.0, 0.0, -G))], safety=1.0)
    e0 = free.energy()
    free.run(steps=20000)
    assert abs(free.energy() - e0) < 1e-3 * abs(e0)


def test_torsion_spring_period():
    k, disk, length, omega0 = 0.5, 0.01, 0.5, 0.1
    net = cosnet.Net()
    base = net.add_node((0.0, 0.0, 0.0), fixed=True)
    top = net.add_node((0.0, 0.0, length), mass=2.0, inertia=(disk / 2, disk / 2, disk))
    rod = net.add_line(base, top, material=STIFF, section=cosnet.Circle(0.01), elements=10,
                       start_joint=cosnet.Hinge(axis=(0.0, 0.0, 1.0), stiffness=k))
    sim = cosnet.Simulation(net, [cosnet.Gravity((0.0, 0.0, 0.0))])
    sim.line_angular_velocities(rod)[:] = (0.0, 0.0, omega0)   # body d3 is the rod's axis
    sim.node_angular_velocity(top)[:] = matrix_from_quat(sim.state.node_q[top.index]).T @ [0.0, 0.0, omega0]
    m = sim.model
    turning = m.element_inertia[:, 2].sum() + sim.model.node_inertia[top.index].max()
    gj = STIFF.G * cosnet.Circle(0.01).J
    k_eff = 1.0 / (1.0 / k + length / gj)   # the spring in series with the rod's twist
    expected = 2.0 * math.pi * math.sqrt(turning / k_eff)
    t, phi, _ = record(sim, rod, 1.1 * expected)
    zeros = crossings(t[1:], phi[1:], 0.0)
    assert abs(zeros[1] / expected - 1.0) < 5e-3
    assert abs(phi.max() / (omega0 * expected / (2 * math.pi)) - 1.0) < 1e-2


def horizontal_arm(**joint):
    sim, arm, tip = hanging_arm(math.pi / 2, cosnet.Hinge(axis=Y, **joint))
    moment = G * (sim.model.vertex_mass * sim.state.x[:, 0]).sum()
    return sim, arm, moment


def test_friction_hinge_holds_below_its_static_torque():
    sim, arm, moment = horizontal_arm()
    # the arm released at rest bends and rings: its root moment reaches twice the static one
    sim, arm, _ = horizontal_arm(friction=(2.5 * moment, 2.0 * moment))
    t, phi, reaction = record(sim, arm, 0.1)
    assert np.all(phi == 0.0)
    assert not cosnet.joint_state(sim, arm)["sliding"][0]
    assert sim.dissipated() == 0.0
    assert np.abs(reaction[:, 1]).max() > moment   # the hinge carried the load


def test_friction_hinge_turns_above_it_and_takes_kinetic_torque_times_angle():
    _, _, moment = horizontal_arm()
    kinetic = 0.4 * moment
    sim, arm, _ = horizontal_arm(friction=(0.5 * moment, kinetic))
    e0 = sim.energy()
    t, phi, _ = record(sim, arm, 0.15)
    turned = np.abs(np.diff(phi)).sum()
    assert turned > 0.02 and np.all(np.diff(phi) >= 0.0)   # it falls, one way
    assert abs(sim.dissipated() / (kinetic * turned) - 1.0) < 1e-2
    assert abs(sim.energy() + sim.dissipated() - e0) < 1e-2 * sim.dissipated()


def test_damped_hinge_energy_balance():
    sim, arm, moment = horizontal_arm(damping=2.0)
    e0 = sim.energy()
    record(sim, arm, 0.15)
    assert sim.dissipated() > 0.01 * moment   # the arm's weight times a tenth of its half length
    assert abs(sim.energy() + sim.dissipated() - e0) < 1e-2 * sim.dissipated()


def test_cardan_joint_output_angle():
    beta, omega, length = 0.5, 2.0 * math.pi, 0.6
    s = np.array([math.cos(beta), math.sin(beta), 0.0])
    along_x = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])   # body z -> lab x
    along_s = np.column_stack([np.cross([0.0, 0.0, 1.0], s), [0.0, 0.0, 1.0], s])
    net = cosnet.Net()
    # input on a flywheel; output on a bearing at its far end (both turn about their shaft only)
    fly = net.add_node((-length, 0.0, 0.0), frame=along_x, mass=math.inf, inertia=(math.inf, math.inf, 1e4))
    cross = net.add_node((0.0, 0.0, 0.0), frame=along_x, mass=math.inf, inertia=(math.inf, math.inf, 0.0))
    out = net.add_node(length * s, frame=along_s, mass=math.inf, inertia=(math.inf, math.inf, 1e-4))
    steel = cosnet.Material(E=2e11, G=8e10, density=7850.0)
    shaft = cosnet.Circle(0.01)
    net.add_line(fly, cross, material=steel, section=shaft, elements=6)
    # the cross: one pin across both shafts' plane (the input's yoke), one across the output
    yoke_a, yoke_b = np.array([0.0, 0.0, 1.0]), np.array([-math.sin(beta), math.cos(beta), 0.0])
    net.add_line(cross, out, material=steel, section=shaft, elements=6, name="output",
                 start_joint=cosnet.Universal(axes=(along_x.T @ yoke_a, along_x.T @ yoke_b)))   # node's frame
    sim = cosnet.Simulation(net, [cosnet.Gravity((0.0, 0.0, 0.0))])
    # start on the kinematics: input at omega, output at omega cos(beta) (theta_1 = 0)
    for line, rate in ((net.lines[0], omega), (net.lines[1], omega * math.cos(beta))):
        sim.line_angular_velocities(line)[:] = (0.0, 0.0, rate)
    for node, rate in ((fly, omega), (cross, omega), (out, omega * math.cos(beta))):
        sim.node_angular_velocity(node)[:] = (0.0, 0.0, rate)

    def turned(node, axis):
        """Rotation angle of the node about its shaft axis since built."""
        d = sim.node_rotation(node)
        x0 = net.nodes[node.index].frame[:, 0]
        return math.atan2(np.cross(x0, d[:, 0]) @ axis, x0 @ d[:, 0])

    def axial_moments():
        """The reaction's moments about the joint's two axes (lab): a, fixed in the cross's
        frame, and b, turned with the first coordinate about a (the free joint passes none)."""
        state = cosnet.joint_state(sim, net.lines[1], "start")
        d, (a, b) = sim.node_rotation(cross), (along_x.T @ yoke_a, along_x.T @ yoke_b)
        b = Rotation.from_rotvec(state["angle"][0] * a).as_matrix() @ b
        return abs(state["reaction"] @ (d @ a)), abs(state["reaction"] @ (d @ b)), np.linalg.norm(state["reaction"])

    worst_angle, worst_rate, worst_moment, largest = 0.0, 0.0, 0.0, 0.0
    while sim.time < 0.2:
        sim.run(steps=500)
        ma, mb, size = axial_moments()
        worst_moment, largest = max(worst_moment, ma, mb), max(largest, size)
        t1, t2 = turned(fly, np.array([1.0, 0.0, 0.0])), turned(out, s)
        worst_angle = max(worst_angle, abs(t2 - math.atan2(math.cos(beta) * math.sin(t1), math.cos(t1))))
        ratio = sim.node_angular_velocity(out)[2] / sim.node_angular_velocity(fly)[2]
        expected = math.cos(beta) / (1.0 - math.sin(beta) ** 2 * math.sin(t1) ** 2)
        worst_rate = max(worst_rate, abs(ratio / expected - 1.0))
    assert sim.time > 0.2 and turned(fly, np.array([1.0, 0.0, 0.0])) > 1.0
    assert worst_angle < 1e-4       # rad: the shafts' twist under the output's small inertia
    assert worst_rate < 1e-3
    # the joint's balance: no moment about either axis, to its Newton tolerance (1e-13 rad)
    # times the boundary point's stiffness B / L = E I / (0.05 m)
    assert worst_moment < 1e-13 * 2e11 * math.pi * 0.01 ** 4 / 4.0 / 0.05 * 3.0 < 1e-5 * largest


def test_ball_joint_keeps_angular_momentum_about_the_vertical():
    sim, arm, tip = hanging_arm(0.6, cosnet.Ball())
    # set it turning about the vertical: a conical swing
    spin = np.array([0.0, 0.0, 2.0])
    sim.line_velocities(arm)[:] = np.cross(spin, sim.state.x[sim.vertex_range(arm)])
    sim.node_velocity(tip)[:] = np.cross(spin, sim.state.node_x[tip.index])
    for i, d in enumerate(sim.line_directors(arm)):
        sim.line_angular_velocities(arm)[i] = d.T @ spin
    lz0 = sim.angular_momentum()[2]
    _, _, reaction = record(sim, arm, 0.3)
    assert abs(sim.angular_momentum()[2] / lz0 - 1.0) < 1e-9
    scale = pendulum_constants(sim)[1] * G
    assert np.abs(reaction).max() < 1e-8 * scale    # a free ball joint passes no moment


def test_loose_ball_joint_settles_in_closed_form_where_the_iteration_does():
    """A ball joint with nothing on it (no spring, friction or damper) balances where its
    boundary point is unstrained, found in closed form: an arm swinging in a cone and spinning
    about its own axis, its joint twisting on past pi, moves as the same arm whose joint
    carries a spring table of zero torque (which the iteration settles), to the iteration's
    tolerance, and exactly as one whose cone it never reaches; the loose joint passes no
    moment at all, and its angle goes on past pi without a jump. (test_ball_joint_holds_its_cone:
    a cone reached.)"""
    def spinning(joint):
        sim, arm, tip = hanging_arm(0.3, joint)
        spin = np.array([0.0, 0.0, 40.0])
        sim.line_velocities(arm)[:] = np.cross(spin, sim.state.x[sim.vertex_range(arm)])
        sim.node_velocity(tip)[:] = np.cross(spin, sim.state.node_x[tip.index])
        for i, d in enumerate(sim.line_directors(arm)):
            sim.line_angular_velocities(arm)[i] = d.T @ spin
        angles, reactions = [], []
        for _ in range(60):
            sim.run(steps=500)
            s = cosnet.joint_state(sim, arm, "start")
            angles.append(s["angle"])
            reactions.append(s["reaction"])
        return sim, np.array(angles), np.array(reactions)
    loose, angles, reactions = spinning(cosnet.Ball())
    iterated, angles_it, _ = spinning(cosnet.Ball(spring_table=([-1.0, 1.0], [0.0, 0.0])))
    coned, angles_coned, _ = spinning(cosnet.Ball(cone=3.0))   # a cone the swing never reaches: it never acts
    assert np.array_equal(angles_coned, angles) and np.array_equal(coned.state.q, loose.state.q)
    assert np.linalg.norm(angles[-1]) > math.pi + 0.5                  # turned on past pi
    assert np.abs(np.diff(angles, axis=0)).max() < 0.5                 # no jump of 2 pi on the way
    assert np.abs(angles - angles_it).max() < 1e-8
    assert np.abs(loose.state.x - iterated.state.x).max() < 1e-9       # m, on a 1 m arm
    assert np.abs(loose.state.q - iterated.state.q).max() < 1e-8
    assert not reactions.any()


@pytest.mark.parametrize("end", ["start", "end"])
def test_loose_ball_joint_on_a_curved_line_turns_as_the_iteration_finds(end):
    """A line built straight with a rest curvature, hung from a loose ball joint, swings to its
    curved shape: the closed form's joint angle (where the boundary point is unstrained,
    theta = L u0, at either end of the line) is the iteration's."""
    def swinging(joint):
        net = cosnet.Net()
        pivot = net.add_node((0.0, 0.0, 0.0), fixed=True)
        tip = net.add_node((0.3, 0.0, -0.9))
        ends = (pivot, tip) if end == "start" else (tip, pivot)
        arm = net.add_line(*ends, material=SOFT, section=SECTION, elements=10, rest_curvature=(0.8, -0.5, 0.3),
                           **{f"{end}_joint": joint})
        sim = cosnet.Simulation(net, [cosnet.Gravity((0.0, 0.0, -G))])
        angles = []
        for _ in range(20):
            sim.run(steps=200)
            angles.append(cosnet.joint_state(sim, arm, end)["angle"])
        return np.array(angles)
    loose = swinging(cosnet.Ball())
    iterated = swinging(cosnet.Ball(spring_table=([-1.0, 1.0], [0.0, 0.0])))
    assert np.abs(loose).max() > 0.05     # it turned
    assert np.abs(loose - iterated).max() < 1e-8


def test_checkpoint_carries_the_joint_state(tmp_path):
    def sliding():
        _, _, moment = horizontal_arm()
        return horizontal_arm(friction=(0.5 * moment, 0.4 * moment), damping=0.5)
    (a, arm_a, _), (b, arm_b, _) = resumed(sliding, tmp_path / "c.npz", 3000, 2000)
    assert np.array_equal(a.state.x, b.state.x)
    assert cosnet.joint_state(a, arm_a)["angle"] == cosnet.joint_state(b, arm_b)["angle"]
    assert a.dissipated() == b.dissipated()


@pytest.mark.parametrize("make, message", [
    (lambda: cosnet.Hinge(axis=(0.0, 0.0, 0.0)), "Hinge: axis must be a nonzero 3-vector"),
    (lambda: cosnet.Hinge(limits=(0.5, -0.5)), "Hinge: limits must have lower < upper"),
    (lambda: cosnet.Hinge(limits=(0.2, 0.5)), "must hold the angle as built, 0"),
    (lambda: cosnet.Hinge(friction=(-1.0, 0.0)), "Hinge: friction (static) must be a finite number >= 0"),
    (lambda: cosnet.Hinge(friction=(1.0, 2.0)), "must not exceed the static one"),
    (lambda: cosnet.Universal(axes=((1, 0, 0), (2, 0, 0))), "the two axes must not be parallel"),
    (lambda: cosnet.Universal(stiffness=[1.0, 2.0, 3.0]), "stiffness must be a number or 2 numbers"),
    (lambda: cosnet.Ball(limits=(-1, 1)), "a ball joint takes a cone"),
    (lambda: cosnet.Ball(cone=0.0), "cone must be an angle in (0, pi] rad"),
])
def test_bad_joints_are_refused_in_one_line(make, message):
    with pytest.raises(ValueError, match=None) as err:
        make()
    assert message in str(err.value) and "\n" not in str(err.value)


def test_a_line_end_takes_only_a_joint():
    net = cosnet.Net()
    a, b = net.add_node((0, 0, 0)), net.add_node((1, 0, 0))
    with pytest.raises(ValueError, match="start_joint: must be a cosnet joint"):
        net.add_line(a, b, material=STIFF, section=SECTION, elements=2, start_joint="hinge")


def test_welded_end_has_no_joint_state():
    sim, arm, _ = hanging_arm(0.2, None)
    with pytest.raises(ValueError, match="is welded"):
        cosnet.joint_state(sim, arm)


def lane_chain(make, hang=False, row=None, **extra):
    """A chain of twelve links from a fixed pivot, along x (or hanging along -z), its joints
    make(**extra) at line starts and at line ends (``make`` a list: its makers in turn),
    stepped 10 x 300 steps under gravity out of its plane; returns (sim, the joints' angles,
    padded with zeros to the most coordinates a joint has, the lanes' row ``row`` of the
    joints) at each sample."""
    makers = make if isinstance(make, list) else [make]
    net = cosnet.Net()
    nodes = [net.add_node((0.0, 0.0, 0.0), fixed=True)]
    lines = []
    for i in range(12):
        nodes.append(net.add_node((0.0, 0.0, -0.15 * (i + 1)) if hang else (0.15 * (i + 1), 0.0, 0.0)))
        joint = makers[i % len(makers)](**extra)
        if i % 2:   # drawn from its far node: the joint at its end
            lines.append(net.add_line(nodes[i + 1], nodes[i], material=SOFT, section=SECTION, elements=4,
                                      end_joint=joint))
        else:
            lines.append(net.add_line(nodes[i], nodes[i + 1], material=SOFT, section=SECTION, elements=4,
                                      start_joint=joint))
    sim = cosnet.Simulation(net, [cosnet.Gravity((0.0, 3.0, -G))])   # (out of the chain's plane too)
    angles, taken = [], []
    for _ in range(10):
        sim.run(steps=300)
        angles.append([np.atleast_1d(cosnet.joint_state(sim, line, "end" if i % 2 else "start")["angle"])
                       for i, line in enumerate(lines)])
        if row is not None:
            taken.append(sim.effect_params(sim.effects[-1]).lanes[row][:12].copy())
    width = max(a.size for sample in angles for a in sample)
    return sim, np.array([[np.pad(a, (0, width - a.size)) for a in sample] for sample in angles]), np.array(taken)


@pytest.mark.parametrize("make, row, within", [
    (lambda **kw: cosnet.Hinge(axis=Y, **kw), OK, 1e-9),
    (lambda **kw: cosnet.Hinge(axis=Y, stiffness=0.5, rest=0.2, limits=(-0.25, 0.3), **kw), OK, 1e-9),
    (lambda **kw: cosnet.Hinge(axis=Y, stiffness=0.5, damping=2e-3, friction=(0.05, 0.04), **kw), OK, 1e-9),
    (lambda **kw: cosnet.Ball(**kw), BALL_OK, 1e-8),
    (lambda **kw: cosnet.Universal(axes=(Y, (0.0, 0.0, 1.0)), **kw), UNIVERSALS + U_OK, 1e-9),
    (lambda **kw: cosnet.Universal(axes=(Y, (0.0, 0.0, 1.0)), stiffness=(0.5, 0.3), rest=(0.2, -0.1),
                                   limits=((-0.3, 0.12), (-0.03, 0.3)), **kw), UNIVERSALS + U_OK, 1e-9),
    (lambda **kw: cosnet.Universal(axes=(Y, (0.0, 0.0, 1.0)), stiffness=0.5, damping=2e-3,
                                   friction=(0.05, 0.04), **kw), UNIVERSALS + U_OK, 1e-9),
    (lambda **kw: cosnet.Ball(stiffness=(0.5, 0.3, 0.2), rest=(0.1, -0.05, 0.3), damping=2e-3,
                              friction=(0.05, 0.04), **kw), GRIPPED + G_OK, 1e-9),
    (lambda **kw: cosnet.Ball(stiffness=(0.5, 0.3, 0.2), rest=(0.1, -0.05, 0.3), damping=(2e-3, 1e-3, 5e-4), **kw),
     SOCKETED + S_OK, 1e-9)],
    ids=["pins", "springs and limits", "dampers and friction", "loose balls", "cardans",
         "cardans with springs and limits", "cardans with dampers and friction", "balls with dampers and friction",
         "balls with springs and dampers"])
def test_joints_settled_in_vector_lanes_move_as_the_iteration_settles_them(make, row, within):
    """A hanging chain of twelve links on hinges without a spring table, or on loose ball joints
    (its joints at line starts and at line ends), settles them in vector lanes; the same chain
    whose joints carry a spring table of zero torque settles them by the scalar iteration. They
    move alike, to round-off (hinges) or to the iteration's tolerance (balls, which the lanes
    settle in closed form), as the joints swing, with springs and limits as these act, and
    with dampers and friction, some joints held and others turning. At the last evaluation the
    lanes took every joint: a hinge's friction check and first Newton step (and settled it
    there, or, the step too long to carry, the iteration went on from it; with friction and few
    turning, the held ones settled as weighed, the others by the iteration), a ball joint's
    balance; a ball joint's friction weighed, the joint settled there where it holds it (the
    others turned by the scalar iteration); a ball joint with springs and dampers by its first
    evaluation (and its exact Newton step, or the iteration going on from its leading one)."""
    lanes, angles, _ = lane_chain(make)
    iterated, angles_it, _ = lane_chain(make, spring_table=([-1.0, 1.0], [0.0, 0.0]))
    rows = lanes.effect_params(lanes.effects[-1]).lanes
    taken = rows[row][:12]   # (the joints, not the vector's padding)
    turned = lanes.effect_params(lanes.effects[-1]).sliding[:, 0] != 0.0
    if row == GRIPPED + G_OK:   # held joints settled there, turning ones left to the iteration
        assert np.array_equal(taken == SETTLED, ~turned) and np.all(taken[turned] == AHEAD)
    elif row == OK and np.any(make().kinetic):   # all by settle_hinges, or (few turning) the held ones as weighed
        weighed = (rows[WEIGHED + W_MOVES][:12] == 0.0) & (rows[WEIGHED + W_OK][:12] != 0.0)
        assert np.all(np.isin(taken, (SETTLED, AHEAD))) or (not taken.any() and np.array_equal(weighed, ~turned))
    else:
        assert np.all(np.isin(taken, (SETTLED,) if row == BALL_OK else (SETTLED, AHEAD)))
    assert np.ptp(angles, axis=0).max() > 0.2            # the joints swung (rad)
    joint = make()
    if np.isfinite(joint.upper).any():   # limits: a joint held at one
        a = angles.reshape(angles.shape[0], angles.shape[1], -1)
        lo, hi = joint.lower[:a.shape[2]], joint.upper[:a.shape[2]]
        assert np.any(np.isclose(a, lo, rtol=0.0, atol=1e-12) | np.isclose(a, hi, rtol=0.0, atol=1e-12))
    if np.any(joint.kinetic):   # friction: joints held and joints turning
        sliding = lanes.effect_params(lanes.effects[-1]).sliding[:, 0]
        assert 0 < sliding.sum() < sliding.size
    assert np.abs(angles - angles_it).max() < within
    assert np.abs(lanes.state.x - iterated.state.x).max() < within / 10.0    # m, on a 1.8 m chain


def test_ball_joints_turned_in_lanes_carry_their_exact_step():
    """A chain of twelve links on ball joints with springs and dampers, hanging and swinging
    gently, turns its joints in vector lanes by one evaluation and the exact Newton step, its
    loads carried along it (settle_sockets: the step below ONE_STEP, as in most joints at most
    evaluations here); it moves as the same chain settled by the scalar iteration (a spring
    table of zero torque) to 1e-9 rad. (The joints of the lanes' test of the same kind: one
    variant compiled for both.)"""
    make = lambda **kw: cosnet.Ball(stiffness=(0.5, 0.3, 0.2), rest=(0.02, -0.01, 0.03),   # noqa: E731
                                   damping=(2e-2, 1e-2, 5e-3), **kw)
    lanes, angles, taken = lane_chain(make, hang=True, row=SOCKETED + S_OK)
    iterated, angles_it, _ = lane_chain(make, hang=True, spring_table=([-1.0, 1.0], [0.0, 0.0]))
    assert np.all(np.isin(taken, (SETTLED, AHEAD))) and np.mean(taken == SETTLED) > 0.8
    assert np.ptp(angles, axis=0).max() > 0.05            # the joints turned (rad)
    assert np.abs(angles - angles_it).max() < 1e-9
    assert np.abs(lanes.state.x - iterated.state.x).max() < 1e-10


def test_a_net_of_every_kind_of_joint_in_lanes_moves_as_the_iteration_moves_it():
    """A chain of twelve links whose joints are in turn a hinge with spring, damper and
    friction, a ball joint with springs, a universal joint with springs, a ball joint with
    friction and a cone, a ball joint with dampers and friction, and a loose ball joint takes
    each kind through its own lanes' rows (every one of the variant's options), and moves as
    the same chain settled by the scalar iteration (spring tables of zero torque) to 1e-9 rad:
    no kind's rows spoil another's."""
    makers = [lambda **kw: cosnet.Hinge(axis=Y, stiffness=0.5, damping=2e-3, friction=(0.05, 0.04), **kw),
              lambda **kw: cosnet.Ball(stiffness=(0.5, 0.3, 0.2), **kw),
              lambda **kw: cosnet.Universal(axes=(Y, (0.0, 0.0, 1.0)), stiffness=0.5, **kw),
              lambda **kw: cosnet.Ball(stiffness=0.5, damping=1e-3, friction=(0.05, 0.04), cone=1.0, **kw),
              lambda **kw: cosnet.Ball(damping=(2e-3, 1e-3, 5e-4), friction=(0.02, 0.01), **kw),
              lambda **kw: cosnet.Ball(**kw)]
    lanes, angles, _ = lane_chain(makers)
    iterated, angles_it, _ = lane_chain(makers, spring_table=([-1.0, 1.0], [0.0, 0.0]))
    from cosnet.kernels.articulation import OPTIONS
    assert type(lanes.effect_params(lanes.effects[-1])).__name__.endswith("1" * len(OPTIONS))
    assert np.ptp(angles, axis=0).max() > 0.2            # the joints swung (rad)
    assert np.abs(angles - angles_it).max() < 1e-9
    assert np.abs(lanes.state.x - iterated.state.x).max() < 1e-10


def test_the_lanes_take_the_joints_the_scalar_path_would_settle_so():
    """The lanes' rows (joint_lanes.lane_tables, numpy over all joints) mark as loose exactly the
    ball joints the scalar path settles in closed form (articulation.loose_ball), hold each
    cone's cosine as the scalar path takes it (cone_cosine), mark as hinges those without a
    spring table, and universal joints likewise, as held those with friction or a damper
    (free_joint), ball joints held so without a spring table as those whose friction the
    lanes weigh, and ball joints neither loose nor with a spring table or a cone as those the
    lanes turn; the padding to whole vectors marks none."""
    from cosnet.kernels.articulation import BALL, cone_cosine, free_joint, loose_ball
    from cosnet.kernels.joint_lanes import C_CONE, C_GRIP, C_HELD, C_HINGE, C_LOOSE, C_SOCKET, C_UNIVERSAL
    joints = [cosnet.Ball(), cosnet.Ball(cone=0.4), cosnet.Ball(stiffness=1.0), cosnet.Ball(damping=0.1),
              cosnet.Ball(friction=(0.2, 0.1)), cosnet.Ball(spring_table=([-1.0, 1.0], [0.0, 0.0])),
              cosnet.Hinge(axis=Y), cosnet.Hinge(axis=Y, friction=(0.2, 0.1)),
              cosnet.Hinge(axis=Y, spring_table=([-1.0, 1.0], [0.0, 0.0])), cosnet.Universal(),
              cosnet.Universal(damping=0.1), cosnet.Universal(spring_table=([-1.0, 1.0], [0.0, 0.0]))]
    net = cosnet.Net()
    nodes = [net.add_node((0.0, 0.0, 0.0), fixed=True)]
    for i, joint in enumerate(joints):
        nodes.append(net.add_node((0.1 * (i + 1), 0.0, 0.0)))
        net.add_line(nodes[i], nodes[i + 1], material=STIFF, section=SECTION, elements=2, start_joint=joint)
    sim = cosnet.Simulation(net, [])
    p = sim.effect_params(sim.effects[-1])
    k = len(joints)
    loose = [bool(p.dofs[j] == BALL and loose_ball.py_func(p, j)) for j in range(k)]   # (settled's test)
    assert loose == [True, True] + [False] * (k - 2)
    assert np.array_equal(p.lane_constants[C_LOOSE, :k] != 0.0, loose)
    assert np.array_equal(p.lane_constants[C_CONE, :k], [cone_cosine.py_func(c) for c in p.cone])
    assert np.array_equal(p.lane_constants[C_HINGE, :k] != 0.0, [False] * 6 + [True, True] + [False] * 4)
    assert np.array_equal(p.lane_constants[C_UNIVERSAL, :k] != 0.0, [False] * 9 + [True, True, False])
    held = [not free_joint.py_func(p, j) for j in range(k)]   # (start_joint's test)
    assert held == [False, False, False, True, True, False, False, True, False, False, True, False]
    assert np.array_equal(p.lane_constants[C_HELD, :k] != 0.0, held)
    grips = [held[j] and p.dofs[j] == BALL and p.table_offsets[3 * j + 3] == p.table_offsets[3 * j] for j in range(k)]
    assert grips == [False, False, False, True, True] + [False] * (k - 5)
    assert np.array_equal(p.lane_constants[C_GRIP, :k] != 0.0, grips)
    sockets = [p.dofs[j] == BALL and not loose[j] and p.cone[j] >= np.pi and
               p.table_offsets[3 * j + 3] == p.table_offsets[3 * j] for j in range(k)]
    assert sockets == [False, False, True, True, True] + [False] * (k - 5)
    assert np.array_equal(p.lane_constants[C_SOCKET, :k] != 0.0, sockets)
    assert p.lane_constants.shape[1] == 16
    assert not p.lane_constants[[C_LOOSE, C_HINGE, C_UNIVERSAL, C_GRIP, C_SOCKET], k:].any()


def test_spoilt_joint_table_is_refused_in_one_line():
    sim, arm, _ = hanging_arm(0.2, cosnet.Hinge(axis=Y))
    sim.effect_params(sim.effects[-1]).attach[0] = 7
    with pytest.raises(ValueError, match=r"joints.attach holds 7, outside \[0, 2\)"):
        sim.run(steps=1)


SCENE = """
[materials.steel]
E = 1e10
G = 4e9
density = 1000.0
[sections.rod]
kind = "circle"
radius = 0.02
[nodes.pivot]
position = [0.0, 0.0, 0.0]
fixed = true
[nodes.tip]
position = [1.0, 0.0, 0.0]
[lines.arm]
start = "pivot"
end = "tip"
material = "steel"
section = "rod"
elements = 10
start_joint = { kind = "hinge", axis = [0.0, 1.0, 0.0], friction = [%s, 1.0] }
[[effects]]
kind = "gravity"
[run]
until = 0.01
"""


def test_scene_declares_a_joint_as_the_python_call(tmp_path):
    path = tmp_path / "hinged.toml"
    path.write_text(SCENE % "2.0")
    scene = cosnet.load_scene(path)
    arm = scene.net.lines[0]
    assert isinstance(arm.start_joint, cosnet.Hinge) and arm.end_joint is None
    assert arm.start_joint.axis.tolist() == [0.0, 1.0, 0.0] and arm.start_joint.static[0] == 2.0
    sim = scene.simulation()
    sim.run(steps=2000)
    # the moment of the arm's weight (about 6 N m) is above the static torque: it turns
    assert cosnet.joint_state(sim, arm)["angle"][0] > 0.0


@pytest.mark.parametrize("friction, message", [
    ("0.5", "[lines.arm.start_joint] friction: Hinge: the kinetic friction torque must not exceed the static one"),
    ('"a"', "[lines.arm.start_joint] friction: Hinge: friction (static) must be a number"),
])
def test_scene_joint_errors_name_the_table_and_key(tmp_path, friction, message):
    path = tmp_path / "bad.toml"
    path.write_text(SCENE % friction)
    with pytest.raises(ValueError) as err:
        cosnet.load_scene(path)
    assert message in str(err.value) and "\n" not in str(err.value)


def hinged_cantilever(stiffness, n=20, joint=True):
    net = cosnet.Net()
    pivot, tip = net.add_node((0.0, 0.0, 0.0), fixed=True), net.add_node((1.0, 0.0, 0.0))
    net.add_line(pivot, tip, material=STIFF, section=SECTION, elements=n,
                 start_joint=cosnet.Hinge(axis=Y, stiffness=stiffness) if joint else None)
    return net


def test_modes_see_the_hinge():
    k = 1e-3 * STIFF.E * SECTION.I11  # soft against the arm's bending, EI / L
    welded = cosnet.modes(hinged_cantilever(0.0, joint=False), count=2).omega
    free = cosnet.modes(hinged_cantilever(0.0), count=3).omega
    sprung = cosnet.modes(hinged_cantilever(k), count=3).omega
    sim = cosnet.Simulation(hinged_cantilever(k), [])
    inertia, _ = pendulum_constants(sim)
    # a free hinge: its mechanism at zero frequency; the other plane keeps the welded mode
    assert free[0] < 1e-6 * free[1]
    assert abs(free[1] / welded[0] - 1.0) < 1e-9
    # a torsion spring: the rigid arm on it, sqrt(k / I), less the arm's bending in series
    assert abs(sprung[0] / math.sqrt(k / inertia) - 1.0) < 5e-3
    # the hinged plane's first elastic mode: pinned-free over clamped-free, (3.9266 / 1.8751)^2
    assert abs(free[2] / free[1] / (3.9266 / 1.8751) ** 2 - 1.0) < 1e-2


def test_cosnet_modes_on_a_hinged_scene(tmp_path, capsys):
    from cosnet import cli
    path = tmp_path / "hinged.toml"
    path.write_text(SCENE.replace(", friction = [%s, 1.0]", ""))
    assert cli.main(["modes", str(path), "--count", "3", "--no-output"]) == 0
    table = capsys.readouterr().out
    omega = cosnet.modes(cosnet.load_scene(path).net, count=3).omega
    # the hinge's mechanism first, at zero frequency, then the arm's two lowest bending modes
    assert omega[0] < 1e-6 * omega[1] and f"{omega[1] / (2 * math.pi):.4g}" in table


def test_run_writes_joint_probes(tmp_path):
    sim, arm, _ = hanging_arm(0.3, cosnet.Hinge(axis=Y))
    sim.run(until=0.05, out=tmp_path / "run", every=0.01,
            probes=["arm@start:joint_angle", "arm@start:joint_rate", "arm@start:joint_reaction"])
    rows = np.genfromtxt(tmp_path / "run" / "probes.csv", delimiter=",", names=True)
    now = cosnet.joint_state(sim, arm)
    assert rows["armstartjoint_angle_x"][-1] == now["angle"][0] > 0.0
    assert rows["armstartjoint_rate_x"][-1] == now["rate"][0] > 0.0
    assert np.all(rows["armstartjoint_angle_y"] == 0.0)      # a hinge has one coordinate
    with pytest.raises(ValueError, match="unknown field 'joint_angle'"):
        sim.run(until=0.06, probes=["arm@end:joint_angle"], out=tmp_path / "other")


def test_line_fields_at_a_joint_show_the_moment_it_passes():
    k = 50.0
    sim, arm, _ = hanging_arm(0.4, cosnet.Hinge(axis=Y, stiffness=k))
    sim.run(steps=3000)
    state = cosnet.joint_state(sim, arm)
    torque = sim.line_fields(arm)["torque"][0]
    # at a sprung hinge the moment about its axis is the spring's, k phi (the joint state is that
    # of the last evaluation, half a step before the fields: 1e-3)
    assert abs(torque[1] / (k * state["angle"][0]) - 1.0) < 1e-3
    # and the internal torque at the start is what the line passes to the node through the joint
    assert np.allclose(torque, state["reaction"], rtol=1e-3, atol=1e-6 * abs(torque[1]))


def test_scaled_scene_converts_joint_torques(tmp_path):
    path = tmp_path / "scaled.toml"
    text = (SCENE % "2.0").replace('friction = [2.0, 1.0] }', 'friction = [2.0, 1.0], stiffness = 3.0, damping = 0.5 }')
    path.write_text("[scale]\ntime = 0.01\nlength = 0.1\narea = 1e-4\ndensity = 1000.0\n" + text)
    scene = cosnet.load_scene(path)
    joint, scale = scene.net.lines[0].start_joint, scene.scale
    torque = scale.force * scale.length
    assert math.isclose(joint.stiffness[0], 3.0 * torque) and math.isclose(joint.static[0], 2.0 * torque)
    assert math.isclose(joint.kinetic[0], 1.0 * torque) and math.isclose(joint.damping[0], 0.5 * torque * scale.time)
    assert joint.axis.tolist() == [0.0, 1.0, 0.0]


def test_ball_joint_holds_its_cone():
    cone = 0.4
    sim, arm, tip = hanging_arm(math.pi / 2, cosnet.Ball(cone=cone))   # built horizontal: it falls
    worst = 0.0
    while sim.time < 0.4:
        sim.run(steps=200)
        d3 = Rotation.from_rotvec(cosnet.joint_state(sim, arm)["angle"]).apply([0.0, 0.0, 1.0])
        worst = max(worst, math.acos(min(1.0, d3[2])))
    assert cone - 1e-9 < worst < cone + 1e-12     # it reached the cone and never left it
    end = sim.node_position(tip)
    assert math.acos(end[0] / np.linalg.norm(end)) < cone + 0.02   # the stiff arm stays near it


def table_torsion(omega0, k=0.5, disk=0.01):
    """The torsion test's disk on a hinge whose spring is a table: linear (slope k) to 0.05 rad,
    stiffer (slope 1.9 k) beyond; started turning at omega0."""
    net = cosnet.Net()
    base = net.add_node((0.0, 0.0, 0.0), fixed=True)
    top = net.add_node((0.0, 0.0, 0.5), mass=2.0, inertia=(disk / 2, disk / 2, disk))
    knee = 0.05 * k
    table = ([-1.0, -0.05, 0.0, 0.05, 1.0], [-knee - 1.9 * k * 0.95, -knee, 0.0, knee, knee + 1.9 * k * 0.95])
    rod = net.add_line(base, top, material=STIFF, section=cosnet.Circle(0.01), elements=10,
                       start_joint=cosnet.Hinge(axis=(0.0, 0.0, 1.0), spring_table=table))
    sim = cosnet.Simulation(net, [cosnet.Gravity((0.0, 0.0, 0.0))])
    sim.line_angular_velocities(rod)[:] = (0.0, 0.0, omega0)
    sim.node_angular_velocity(top)[:] = matrix_from_quat(sim.state.node_q[top.index]).T @ [0.0, 0.0, omega0]
    turning = sim.model.element_inertia[:, 2].sum() + sim.model.node_inertia[top.index].max()
    return sim, rod, turning


def test_spring_table_gives_its_torque_and_stores_its_energy():
    k = 0.5
    # within the linear part the table is the spring k: the torsion test's period
    sim, rod, turning = table_torsion(0.02)
    k_eff = 1.0 / (1.0 / k + 0.5 / (STIFF.G * cosnet.Circle(0.01).J))
    expected = 2.0 * math.pi * math.sqrt(turning / k_eff)
    t, phi, _ = record(sim, rod, 1.1 * expected)
    assert abs(crossings(t[1:], phi[1:], 0.0)[1] / expected - 1.0) < 5e-3
    # past the knee: the swing stops where the table's energy, the integral of its torque, has
    # taken the kinetic energy (less the rod's share of the twist), and the energy is kept
    omega0 = 0.8
    sim, rod, turning = table_torsion(omega0)
    e0 = sim.energy()
    t, phi, _ = record(sim, rod, 0.3)
    kinetic = 0.5 * turning * omega0 ** 2
    knee_energy = 0.5 * k * 0.05 ** 2
    # V(phi) = knee_energy + 0.05 k (phi - 0.05) + 1.9 k (phi - 0.05)^2 / 2 = kinetic
    a, b, c = 0.95 * k, 0.05 * k, knee_energy - kinetic
    reach = 0.05 + (-b + math.sqrt(b * b - 4 * a * c)) / (2 * a)
    assert abs(phi.max() / reach - 1.0) < 1e-2
    assert abs(sim.energy() / e0 - 1.0) < 1e-3
    with pytest.raises(ValueError, match="spring_table's angles must increase"):
        cosnet.Hinge(spring_table=([0.0, 0.0], [0.0, 1.0]))


def ball_arm(d1, friction):
    """horizontal_arm's arm (1 m along x, gravity -z) on a ball joint with ``friction``, its
    first director d1 (the joint's coordinates are the rotation vector in the end's frame as
    built: d1 = y puts the weight's moment on one coordinate, d1 at 45 deg about x splits it
    equally between two). Returns (sim, line, moment of the weight about the pivot)."""
    net = cosnet.Net()
    pivot = net.add_node((0.0, 0.0, 0.0), fixed=True, name="pivot")
    tip = net.add_node((1.0, 0.0, 0.0), name="tip")
    arm = net.add_line(pivot, tip, material=STIFF, section=SECTION, elements=10, d1=d1, name="arm",
                       start_joint=cosnet.Ball(friction=friction))
    sim = cosnet.Simulation(net, [cosnet.Gravity((0.0, 0.0, -G))])
    return sim, arm, G * (sim.model.vertex_mass * sim.state.x[:, 0]).sum()


SPLIT = (0.0, math.sqrt(0.5), math.sqrt(0.5))


def test_ball_joint_friction_is_one_torque_whatever_the_coordinates():
    """A ball joint's friction resists its rotation as a whole: the arm falls the same with
    its weight's moment on one coordinate or split between two (a friction per coordinate
    would meet it with sqrt(2) times the torque in the split case), and what friction takes is
    the kinetic torque times the angle turned."""
    _, _, moment = ball_arm((0.0, 1.0, 0.0), (0.0, 0.0))
    kinetic = 0.4 * moment
    runs = []
    for d1 in ((0.0, 1.0, 0.0), SPLIT):
        sim, arm, _ = ball_arm(d1, (0.5 * moment, kinetic))
        e0 = sim.energy()
        sim.run(until=0.15)
        angle = np.linalg.norm(cosnet.joint_state(sim, arm)["angle"])
        assert angle > 0.02                                   # it slid
        assert abs(sim.dissipated() / (kinetic * angle) - 1.0) < 1e-2
        assert abs(sim.energy() + sim.dissipated() - e0) < 1e-2 * sim.dissipated()
        runs.append((sim.state.x.copy(), sim.dissipated()))
    (x1, w1), (x2, w2) = runs
    np.testing.assert_allclose(x2, x1, rtol=0, atol=1e-9)     # round-off of two frames, 1 m arm
    assert w2 == pytest.approx(w1, rel=1e-7)


def test_ball_joint_friction_holds_below_its_static_torque_in_any_direction():
    _, _, moment = ball_arm(SPLIT, (0.0, 0.0))
    # released at rest the arm rings: its root moment reaches about twice the static one
    sim, arm, _ = ball_arm(SPLIT, (2.5 * moment, 2.0 * moment))
    sim.run(until=0.1)
    assert np.all(cosnet.joint_state(sim, arm)["angle"] == 0.0) and sim.dissipated() == 0.0


def test_ball_joint_friction_is_one_pair_of_torques():
    with pytest.raises(ValueError, match="one static and one kinetic torque") as e:
        cosnet.Ball(friction=((1.0, 2.0, 1.0), 0.5))
    assert "\n" not in str(e.value)


def test_ball_joint_newton_matrix_is_the_derivative_of_its_torques():
    """A ball joint's exact Newton matrix (the leading term w_i^T B w_k / L plus
    joint_math.ball_exact: the inverse Jacobian's rate and the axes turning with phi) is minus
    the derivative of its generalised torques -e (J k_i) . m over its coordinates, by central
    differences, at a line's start and end, a turned and a nearly straight joint (ball_axes'
    series), and a boundary point bent by up to 0.15 rad; the axes' turning is a part of it
    that matters there."""
    from numba import njit
    from cosnet.kernels.articulation import boundary_turn
    from cosnet.kernels.joint_math import ball_axes, ball_exact, bend_rate, dot3, inverse_jacobian
    from cosnet.kernels.rotations import quat_exp, quat_mul

    @njit
    def terms(f, q, start, il, u0, bend, x):
        r = quat_exp(x[0], x[1], x[2])
        k = ball_axes(x[0], x[1], x[2])
        t, cc, c2, m, _, e = boundary_turn(f, q, start, il, u0, bend, r)
        w = (inverse_jacobian(t, cc, e, k[0]), inverse_jacobian(t, cc, e, k[1]), inverse_jacobian(t, cc, e, k[2]))
        bw = (bend_rate(il, bend, w[0]), bend_rate(il, bend, w[1]), bend_rate(il, bend, w[2]))
        g = (-e * dot3(w[0], m), -e * dot3(w[1], m), -e * dot3(w[2], m))
        lead = (dot3(w[0], bw[0]), dot3(w[1], bw[1]), dot3(w[2], bw[2]), dot3(w[0], bw[1]), dot3(w[0], bw[2]),
                dot3(w[1], bw[2]))
        return g, lead, ball_exact(t, cc, c2, e, m, x, k, w)

    @njit
    def turned(a, v):   # a exp(v) (quaternions; v a rotation vector)
        b = quat_exp(v[0], v[1], v[2])
        return quat_mul(a[0], a[1], a[2], a[3], b[0], b[1], b[2], b[3])

    rng = np.random.default_rng(7)
    pairs = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))
    for start in (True, False):
        for size in (4.5, 0.7, 0.03):
            f = turned((1.0, 0.0, 0.0, 0.0), tuple(rng.normal(size=3)))
            x = tuple(rng.normal(size=3) * size / np.sqrt(3.0))
            q = turned(turned(f, x), tuple(rng.normal(size=3) * 0.15 / np.sqrt(3.0)))   # G bent to E
            il, u0, bend = 40.0, tuple(rng.normal(size=3) * 0.5), (2.0, 3.0, 1.5)
            _, lead, exact = terms(f, q, start, il, u0, bend, x)
            step = 1e-6
            numeric = np.zeros((3, 3))
            for k in range(3):
                up, down = np.array(x), np.array(x)
                up[k] += step
                down[k] -= step
                numeric[:, k] = -(np.array(terms(f, q, start, il, u0, bend, tuple(up))[0]) -
                                  np.array(terms(f, q, start, il, u0, bend, tuple(down))[0])) / (2.0 * step)
            within = 1e-6 * np.abs(numeric).max()
            for n, (i, k) in enumerate(pairs):
                assert abs(lead[n] + exact[n] - numeric[i, k]) < within, (start, size, i, k)
            assert np.abs(exact).max() > 100.0 * within   # (the leading term alone is not it)
