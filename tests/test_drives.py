"""Driven nodes (cosnet.Drive): exact prescription, reactions, energy bookkeeping, bad input.

Every simulation here declares the same effects (Gravity, Damping, Drive; some with g = 0 or
no damping) so the two steppers compile once each.
"""

import numpy as np
import pytest
from scipy.interpolate import CubicSpline
from scipy.spatial.transform import Rotation

import cosnet
from cosnet.scene import build_scene

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


def drift_of_energy(dt, stepper="verlet"):
    """max |E - W - E(0)| over a driven run: a free rod shaken and turned at one end."""
    net, a, b, line = rod(n=6, fixed_start=False)
    drive = cosnet.Drive(b, position=dict(amplitude=[0.0, 0.05, 0.02], omega=20.0),
                         rotation=dict(amplitude=0.3, omega=15.0), axis=(0.0, 0.0, 1.0))
    sim = simulate(net, drive, g=9.81, stepper=stepper, dt=dt)
    e0 = sim.energy()
    worst, work = 0.0, []
    for _ in range(int(round(0.2 / dt / 20))):
        sim.run(steps=20)
        worst = max(worst, abs(sim.energy() - sim.driver_work() - e0))
        work.append(sim.driver_work())
    return worst, max(abs(w) for w in work)


def test_energy_plus_driver_work_is_conserved_to_second_order():
    dt = 2e-4
    e1, w = drift_of_energy(dt)
    e2, _ = drift_of_energy(dt / 2)
    assert w > 100 * e1                   # the driver does work well above the error
    assert 3.4 < e1 / e2 < 4.6            # halving dt quarters the error: order 2


def test_energy_plus_driver_work_is_conserved_to_fourth_order_with_pefrl():
    """The drive's pose at PEFRL's drift stage times and its work by the kicks' own weights keep
    the scheme's order: halving dt divides the error by 16."""
    dt = 2e-4
    e1, w = drift_of_energy(dt, "pefrl")
    e2, _ = drift_of_energy(dt / 2, "pefrl")
    assert w > 1e5 * e1
    assert 13.0 < e1 / e2 < 19.5


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


SCENE = """
[materials.m]
E = 1e6
G = 4e5
density = 1000.0
[nodes.a]
position = [0, 0, 0]
fixed = true
[nodes.b]
position = [1, 0, 0]
[lines.rod]
start = "a"
end = "b"
material = "m"
section = {{ kind = "circle", radius = 0.02 }}
elements = 4
[run]
until = 0.01
[[effects]]
kind = "drive"
node = "{node}"
{keys}
"""


@pytest.mark.parametrize("node, keys, words", [
    ("b", 'rotation = { times = [0.0, 0.0], values = [0.0, 1.0] }\naxis = [1, 0, 0]',
     r"\[\[effects\]\] #1 \(drive\) rotation: .*times must increase strictly"),
    ("b", 'position = { rate = [1, 0] }', r"\(drive\) position: .*rate must be 3 finite numbers"),
    ("b", 'rotation = { rate = 1.0 }\naxis = [0, 0, 0]', r"\(drive\) axis: must be a non-zero vector"),
    ("b", 'position = { speed = [1, 0, 0] }', r"\(drive\) position: unknown key 'speed'"),
    ("a", 'position = { rate = [1, 0, 0] }', r"\(drive\) .*the node is fixed"),
])
def test_scene_drive_errors_name_the_table_and_key(node, keys, words):
    with pytest.raises(ValueError, match=words) as e:
        build_scene(__import__("tomllib").loads(SCENE.format(node=node, keys=keys))).simulation()
    assert "\n" not in str(e.value)
