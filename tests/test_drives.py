"""Driven nodes (cosnet.Drive): exact prescription, reactions, energy bookkeeping, bad input.

Every simulation here declares the same effects (Gravity, Damping, Drive; some with g = 0 or
no damping) so the two steppers compile once each.
"""

import numpy as np
import pytest
from scipy.interpolate import CubicSpline
from scipy.spatial.transform import Rotation

import cosnet
from cosnet.core.rotations import matrix_from_quat
from cosnet.scene.loader import build_scene
from nets import ROD_SCENE

RUBBER = cosnet.Material(E=1e6, G=4e5, density=1000.0, name="rubber")
RADIUS = 0.02


def rod(n=8, length=1.0, fixed_start=True, tip_mass=0.0):
    """A straight rod along x from node a (clamped, or free) to node b; (net, a, b, line)."""
    net = cosnet.Net()
    a = net.add_node((0.0, 0.0, 0.0), fixed=fixed_start, name="a")
    b = net.add_node((length, 0.0, 0.0), mass=tip_mass, name="b")
    line = net.add_line(a, b, material=RUBBER, section=cosnet.Circle(RADIUS), elements=n, name="rod")
    return net, a, b, line


def simulate(net, drive, g=0.0, nu=0.0, **kw):
    return cosnet.Simulation(net, [cosnet.Gravity((0.0, 0.0, -g)), cosnet.Damping(nu), drive], **kw)


def path_value(t, rate, amp, omega, phase, times, values):
    """The path's value at t from its definition (scipy's clamped spline, held outside)."""
    f = np.asarray(rate, float) * t + np.asarray(amp, float) * np.sin(omega * t + phase)
    tt = np.clip(t, times[0], times[-1])
    return f + CubicSpline(times, values, bc_type="clamped", axis=0)(tt)


POS = dict(rate=[0.05, 0.0, 0.01], amplitude=[0.0, 0.02, 0.0], omega=9.0, phase=0.3,
           times=[0.0, 0.01, 0.03, 0.05], values=[[0, 0, 0], [0.01, 0, 0], [0.0, 0.02, -0.01], [0.0, 0.0, 0.0]])
ANG = dict(rate=1.0, amplitude=0.2, omega=7.0, phase=0.0, times=[0.0, 0.02, 0.04], values=[0.0, 0.3, -0.1])
AXIS = np.array([1.0, 1.0, 0.5]) / np.linalg.norm([1.0, 1.0, 0.5])


@pytest.mark.parametrize("stepper", ["verlet", "pefrl"])
def test_driven_node_follows_its_prescription_exactly(stepper):
    net, a, b, line = rod(fixed_start=False)
    drive = cosnet.Drive(b, position=POS, rotation=ANG, axis=AXIS)
    sim = simulate(net, drive, stepper=stepper)
    x0, d0 = sim.node_position(b).copy(), sim.node_rotation(b).copy()
    pv = lambda t: path_value(t, **{k: POS[k] for k in ("rate", "omega", "phase", "times", "values")},
                              amp=POS["amplitude"])
    av = lambda t: path_value(t, ANG["rate"], ANG["amplitude"], ANG["omega"], ANG["phase"],
                              ANG["times"], ANG["values"])
    for _ in range(100):   # past the tables' ends, where they hold their last values
        sim.run(steps=1)
        t = sim.time
        np.testing.assert_allclose(sim.node_position(b), x0 + pv(t) - pv(0.0), rtol=0, atol=1e-13)
        turn = Rotation.from_rotvec((av(t) - av(0.0)) * AXIS).as_matrix()
        np.testing.assert_allclose(sim.node_rotation(b), turn @ d0, rtol=0, atol=1e-13)
        # the line end sits on its node: the junction stays exact
        np.testing.assert_allclose(sim.line_positions(line)[-1], sim.node_position(b), rtol=0, atol=1e-15)
    assert sim.time > POS["times"][-1]


def test_motor_shaft_slides_along_its_axis_and_holds_the_rest():
    """slide=True: the angle is prescribed, the position across the axis held, along it free
    (no reaction along it)."""
    net, a, b, line = rod(n=4, fixed_start=False, tip_mass=0.3)
    axis = np.array([0.0, 0.0, 1.0])
    drive = cosnet.Drive(b, rotation=dict(rate=2.0), axis=axis, slide=True)
    sim = simulate(net, drive, g=9.81)
    x0 = sim.node_position(b).copy()
    sim.run(steps=200)
    x = sim.node_position(b)
    np.testing.assert_allclose(x[:2], x0[:2], rtol=0, atol=1e-14)
    # the rod turns in its plane, so nothing but gravity acts along the axis: free fall, exact
    assert x[2] == pytest.approx(x0[2] - 0.5 * 9.81 * sim.time ** 2, rel=0, abs=1e-12)
    force, torque = sim.reaction(b)
    assert abs(force @ axis) < 1e-12 * np.linalg.norm(force)
    np.testing.assert_allclose(sim.node_rotation(b) @ np.array([1.0, 0, 0]),
                               [np.cos(2.0 * sim.time), np.sin(2.0 * sim.time), 0.0], atol=1e-13)


def test_turned_clamp_twists_a_line_with_end_torque_gj_theta_over_l():
    """A straight rod clamped at a, its end b turned slowly by theta about the rod's axis (with
    damping): uniform twist theta / L, so the driver holds the torque G J theta / L (J = pi r^4 / 2)
    about the axis, and no force."""
    net, a, b, line = rod(n=8)
    theta, ramp = 0.6, 1.0
    drive = cosnet.Drive(b, rotation=dict(times=[0.0, ramp], values=[0.0, theta]), axis=(1.0, 0.0, 0.0))
    sim = simulate(net, drive, nu=4.0)
    sim.run(until=3.0 * ramp)
    force, torque = sim.reaction(b)
    gj = RUBBER.G * np.pi * RADIUS ** 4 / 2
    assert torque[0] == pytest.approx(gj * theta / 1.0, rel=0.01)
    assert np.linalg.norm(torque[1:]) < 1e-6 * abs(torque[0])
    assert np.linalg.norm(force) < 1e-6 * abs(torque[0])


def test_driven_pin_carries_a_hanging_line_rigidly():
    """A pin moved at constant velocity v, the line hanging from it free to swing: in steady state
    (damping nu, on absolute velocities) everything moves with v and the line trails straight at
    tan(angle) = nu v / g; the driver holds the whole weight and the drag of all but its own node."""
    net = cosnet.Net()
    pin = net.add_node((0.0, 0.0, 0.0), name="pin")
    end = net.add_node((0.0, 0.0, -1.0), name="end")
    line = net.add_line(pin, end, material=RUBBER, section=cosnet.Circle(RADIUS), elements=6, name="rope")
    v, g, nu = 0.5, 9.81, 2.0
    sim = simulate(net, cosnet.Drive(pin, position=dict(rate=[v, 0.0, 0.0])), g=g, nu=nu)
    sim.run(until=16.0)   # amplitudes decay as exp(-nu t / 2)
    vel = sim.line_velocities(line)
    np.testing.assert_allclose(vel, np.tile([v, 0.0, 0.0], (vel.shape[0], 1)), atol=1e-4 * v)
    x = sim.line_positions(line)
    d = (x[0] - x[-1]) / np.linalg.norm(x[0] - x[-1])
    assert d[0] / d[2] == pytest.approx(nu * v / g, rel=1e-3)
    force, torque = sim.reaction(pin)
    total = net.total_mass()
    pin_mass = sim.model.node_mass[pin.index]
    assert force[2] == pytest.approx(total * g, rel=0.01)
    assert force[0] == pytest.approx(nu * v * (total - pin_mass), rel=0.01)


SHAKE = dict(amplitude=[0.0, 0.05, 0.02], omega=20.0)
# tumbled: a table of rotations (quaternions) over the run, a spin and a wobble on top
TUMBLE = dict(rate=[1.0, 0.0, 2.0], amplitude=[0.2, -0.1, 0.0], omega=15.0, times=[0.0, 0.07, 0.14, 0.2],
              quaternions=Rotation.from_rotvec([[0, 0, 0], [0.5, 0.8, 0.0], [1.2, 0.3, -0.9], [0.4, -0.6, 1.8]])
              .as_quat(scalar_first=True).tolist())


def drift_of_energy(dt, stepper="verlet", tumbled=False):
    """max |E - W - E(0)| over a driven run: a free rod shaken and turned (about an axis, or
    tumbled along a path on SO(3)) at one end."""
    net, a, b, line = rod(n=6, fixed_start=False)
    if tumbled:
        drive = cosnet.Drive(b, position=SHAKE, orientation=TUMBLE)
    else:
        drive = cosnet.Drive(b, position=SHAKE, rotation=dict(amplitude=0.3, omega=15.0), axis=(0.0, 0.0, 1.0))
    sim = simulate(net, drive, g=9.81, stepper=stepper, dt=dt)
    e0 = sim.energy()
    worst, work = 0.0, []
    for _ in range(int(round(0.2 / dt / 20))):
        sim.run(steps=20)
        worst = max(worst, abs(sim.energy() - sim.driver_work() - e0))
        work.append(sim.driver_work())
    return worst, max(abs(w) for w in work)


@pytest.mark.parametrize("tumbled", [False, True])
def test_energy_plus_driver_work_is_conserved_to_second_order(tumbled):
    dt = 2e-4
    e1, w = drift_of_energy(dt, tumbled=tumbled)
    e2, _ = drift_of_energy(dt / 2, tumbled=tumbled)
    assert w > 100 * e1                   # the driver does work well above the error
    assert 3.4 < e1 / e2 < 4.6            # halving dt quarters the error: order 2


@pytest.mark.parametrize("tumbled", [False, True])
def test_energy_plus_driver_work_is_conserved_to_fourth_order_with_pefrl(tumbled):
    """The drive's pose is exact at every stage time and its work a quadrature on the kicks'
    own times and weights (of order 4 with PEFRL's), so without damping the balance keeps
    PEFRL's order."""
    e1, w = drift_of_energy(2e-4, "pefrl", tumbled=tumbled)
    e2, _ = drift_of_energy(1e-4, "pefrl", tumbled=tumbled)
    assert w > 1e4 * e1
    assert 13.0 < e1 / e2 < 19.0


def damped_shaft_balance(dt, orient):
    """max |E - W + D - E(0)|, W and D: a motor shaft (free along its axis, where damping's
    loss is the net's own) turning a rod under gravity and damping, about the axis or along
    an orientation path, starting at rest."""
    net, a, b, line = rod(n=4, fixed_start=False, tip_mass=0.3)
    turn = (dict(orientation=dict(amplitude=[0.3, 0.2, 0.1], omega=12.0, phase=np.pi / 2)) if orient
            else dict(rotation=dict(amplitude=0.5, omega=12.0, phase=np.pi / 2)))
    sim = simulate(net, cosnet.Drive(b, axis=(0.0, 0.0, 1.0), slide=True, **turn), g=9.81, nu=3.0, dt=dt)
    e0, worst = sim.energy(), 0.0
    for _ in range(50):      # the same sample times at every dt
        sim.run(steps=round(0.004 / dt))
        worst = max(worst, abs(sim.energy() - sim.driver_work() + sim.dissipated() - e0))
    return worst, sim.driver_work(), sim.dissipated()


@pytest.mark.parametrize("orient", [False, True])
def test_a_drive_pays_back_what_damping_takes_from_what_it_holds_only(orient):
    """Damping's loss at the driven node counts as driver work for the components the drive
    holds (across the axis, the rotation) and as the net's own loss along the free axis: the
    balance E - W + D keeps Verlet's order."""
    e1, work, lost = damped_shaft_balance(2e-4, orient)
    e2, _, _ = damped_shaft_balance(1e-4, orient)
    assert min(abs(work), lost) > 1e4 * e1
    assert 3.6 < e1 / e2 < 4.4


def test_bad_drives_are_refused_in_one_line():
    net, a, b, line = rod()
    bad = [
        (lambda: cosnet.Drive(a, position=dict(rate=[1, 0, 0])), None, "fixed"),
        (lambda: cosnet.Drive(b, rotation=dict(times=[0, 2, 1], values=[0, 1, 2]), axis=(1, 0, 0)), None,
         "increase strictly"),
        (lambda: cosnet.Drive(b, position=dict(times=[0, 1, 2], values=[[0, 0, 0], [1, 0, 0]])), None,
         "values must be 3 x 3"),
        (lambda: cosnet.Drive(b, rotation=dict(rate=1.0), axis=(0, 0, 0)), None, "nonzero 3-vector"),
        (lambda: cosnet.Drive(b, rotation=dict(rate=1.0)), None, "axis is needed"),
        (lambda: cosnet.Drive(b), None, "give a position path"),
    ]
    for make, _, words in bad:
        with pytest.raises(ValueError, match=words) as e:
            simulate(net, make())
        assert "\n" not in str(e.value)
    # a velocity given to a driven node that its drive does not have
    sim = simulate(net, cosnet.Drive(b, position=dict(rate=[0.1, 0, 0])))
    sim.node_velocity(b)[:] = [0.0, 0.2, 0.0]
    with pytest.raises(ValueError, match=r"node's velocity .* contradicts its drive"):
        sim.run(steps=1)


# the shared clamped rod with one drive table: node "root" is fixed, "tip" free
SCENE = ROD_SCENE.format(title="driven rod", E="1e6", G="4e5", elements=4, rest="""[[effects]]
kind = "drive"
node = "{node}"
{keys}
""")


@pytest.mark.parametrize("node, keys, words", [
    ("tip", 'rotation = { times = [0.0, 0.0], values = [0.0, 1.0] }\naxis = [1, 0, 0]',
     r"\[\[effects\]\] #1 \(drive\) rotation: .*times must increase strictly"),
    ("tip", 'position = { rate = [1, 0] }', r"\(drive\) position: .*rate must be 3 finite numbers"),
    ("tip", 'rotation = { rate = 1.0 }\naxis = [0, 0, 0]', r"\(drive\) axis: must be a non-zero vector"),
    ("tip", 'position = { speed = [1, 0, 0] }', r"\(drive\) position: unknown key 'speed'"),
    ("root", 'position = { rate = [1, 0, 0] }', r"\(drive\) .*the node is fixed"),
    ("tip", 'orientation = { times = [0, 1], quaternions = [[1, 0, 0, 0], [0, 0.9, 0, 0]] }',
     r"\(drive\) orientation: .*quaternions must be unit, quaternions\[1\] has norm 0.9"),
    ("tip", 'orientation = { times = [0, 1], quaternions = [[1, 0, 0], [1, 0, 0]] }',
     r"\(drive\) orientation: .*quaternions must be rows of 4 finite numbers"),
    ("tip", 'orientation = { times = [0, 1], values = [[0, 0, 0]] }', r"\(drive\) orientation: .*values must be 2 x 3"),
    ("tip", 'position = { times = [0, 1], quaternions = [[1, 0, 0, 0], [1, 0, 0, 0]] }',
     r"\(drive\) position: .*quaternions tabulate an orientation path only"),
    ("tip", 'orientation = { rate = [0, 0, 1] }\nrotation = { rate = 1 }\naxis = [1, 0, 0]',
     r"\(drive\) .*a rotation \(about axis\) or an orientation path, not both"),
])
def test_scene_drive_errors_name_the_table_and_key(node, keys, words):
    with pytest.raises(ValueError, match=words) as e:
        build_scene(__import__("tomllib").loads(SCENE.format(node=node, keys=keys))).simulation()
    assert "\n" not in str(e.value)


# a tumbling table: rotation vectors continuous across |r| = pi, given as quaternions of either sign
TURNS = np.array([[0.0, 0.0, 0.0], [0.6, -0.3, 0.8], [1.5, 0.4, 2.6], [0.2, 1.0, 3.9]])
TURN_TIMES = [0.0, 0.015, 0.03, 0.05]
ORIENT = dict(rate=[2.0, -1.0, 0.5], amplitude=[0.1, 0.0, -0.2], omega=30.0, phase=0.4, times=TURN_TIMES,
              quaternions=(Rotation.from_rotvec(TURNS).as_quat(scalar_first=True) * [[1], [-1], [1], [-1]]).tolist())


def orientation_value(t):
    """The orientation path's rotation vector at t from its definition."""
    return path_value(t, ORIENT["rate"], ORIENT["amplitude"], ORIENT["omega"], ORIENT["phase"], TURN_TIMES, TURNS)


def test_nearly_unit_quaternions_are_normalised_and_a_spin_turns_at_its_rate():
    """Quaternions within 1e-3 of unit norm are normalised; a rate alone is a constant angular
    velocity about a fixed lab axis (any number of turns)."""
    net, a, b, line = rod(fixed_start=False)
    spin = np.array([0.0, 3.0, 4.0])
    sim = simulate(net, cosnet.Drive(b, orientation=dict(rate=spin)))
    d0 = sim.node_rotation(b).copy()
    sim.run(until=1.5)
    np.testing.assert_allclose(sim.node_rotation(b), Rotation.from_rotvec(spin * sim.time).as_matrix() @ d0,
                               rtol=0, atol=1e-12)
    assert np.linalg.norm(spin) * sim.time > 2 * np.pi
    lab = matrix_from_quat(sim.state.node_q[b.index]) @ sim.node_angular_velocity(b)   # principal frame -> lab
    np.testing.assert_allclose(lab, spin, rtol=0, atol=1e-13)
    q = Rotation.from_rotvec([[0, 0, 0], [0, 0, 1]]).as_quat(scalar_first=True) * 1.0005
    sim = simulate(net, cosnet.Drive(b, orientation=dict(times=[0, 0.1], quaternions=q)))
    sim.run(until=0.2)
    np.testing.assert_allclose(sim.node_rotation(b), Rotation.from_rotvec([0, 0, 1]).as_matrix() @ d0,
                               rtol=0, atol=1e-14)


@pytest.mark.parametrize("stepper", ["verlet", "pefrl"])
def test_node_follows_a_general_rotation_path_exactly(stepper):
    """exp(r(t)) exp(r(0))^-1 times the frame as built, r the rotation vector's path (quaternions
    unwrapped to the rotation vectors they came from), at every step, with the junction exact."""
    net, a, b, line = rod(fixed_start=False)
    sim = simulate(net, cosnet.Drive(b, position=POS, orientation=ORIENT), stepper=stepper)
    d0 = sim.node_rotation(b).copy()
    start = Rotation.from_rotvec(orientation_value(0.0)).inv()
    for _ in range(100):   # past the table's end, where it holds its last value and the rate goes on
        sim.run(steps=1)
        want = (Rotation.from_rotvec(orientation_value(sim.time)) * start).as_matrix() @ d0
        np.testing.assert_allclose(sim.node_rotation(b), want, rtol=0, atol=1e-13)
        np.testing.assert_allclose(sim.line_positions(line)[-1], sim.node_position(b), rtol=0, atol=1e-15)
    assert sim.time > TURN_TIMES[-1]
