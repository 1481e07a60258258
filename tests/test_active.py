"""Active lines: a steady muscle torque bends a free line to the curvature M / EI; a rest
curvature, stretch or shear changing in time, and the work it does."""

import math
import tomllib

import numpy as np
import pytest

import cosnet
from cosnet.scene.loader import build_scene
from nets import ROD_SCENE

RUBBER = cosnet.Material(E=1e6, G=4e5, density=1000.0, name="rubber")
# a scene's 4-element rod that the scene-error tests add one effect table to
ROD = ROD_SCENE.format(title="rod", E="1e6", G="4e5", elements=4, rest="")


def test_steady_muscle_torque_bends_a_free_line_to_curvature_m_over_ei():
    """M = EI kappa at every interior Voronoi point once the motion has died out (exact for the
    discrete line: the elastic moment balances the active one point by point), and the line is
    an arc of that circle: its chord 2 sin(kappa L / 2) / kappa, to the discretisation's O(n^-2)."""
    net = cosnet.Net()
    a = net.add_node((0.0, 0.0, 0.0), name="a")
    b = net.add_node((1.0, 0.0, 0.0), name="b")
    line = net.add_line(a, b, material=RUBBER, section=cosnet.Circle(0.02), elements=12, name="rod")
    ei = RUBBER.E * math.pi * 0.02 ** 4 / 4
    kappa = 1.5
    muscle = cosnet.MuscleTorque(line, moment=ei * kappa, direction=(1.0, 0.0, 0.0), ramp_time=1.0)
    sim = cosnet.Simulation(net, [muscle, cosnet.Damping(5.0)])
    sim.run(until=10.0)
    u = sim.line_fields(line)["curvature"][1:-1]
    np.testing.assert_allclose(u[:, 0], kappa, rtol=1e-6)
    np.testing.assert_allclose(u[:, 1:], 0.0, atol=1e-6 * kappa)
    x = sim.line_positions(line)
    chord = np.linalg.norm(x[-1] - x[0])
    assert chord == pytest.approx(2 * math.sin(kappa / 2) / kappa, rel=0.01)


def test_muscle_torque_scene_errors_name_the_key():
    scene = ROD + """
[[effects]]
kind = "muscle_torque"
line = "rod"
moment = [1.0, 2.0]
points = [0.0, 0.5, 1.0]
"""
    with pytest.raises(ValueError, match=r"\(muscle_torque\) (moment|points): .*one finite value per point") as e:
        build_scene(tomllib.loads(scene))
    assert "\n" not in str(e.value)


def free_rod(n):
    net = cosnet.Net()
    a = net.add_node((0.0, 0.0, 0.0), name="a")
    b = net.add_node((1.0, 0.0, 0.0), name="b")
    return net, net.add_line(a, b, material=RUBBER, section=cosnet.Circle(0.02), elements=n, name="rod")


def chord_after_curving(n, kappa=2.0):
    net, line = free_rod(n)
    curve = cosnet.ActiveCurvature(line, curvature=(kappa, 0.0, 0.0), ramp_time=1.0)
    sim = cosnet.Simulation(net, [curve, cosnet.Damping(5.0)])
    sim.run(until=10.0)
    x = sim.line_positions(line)
    return np.linalg.norm(x[-1] - x[0])


def test_rest_curvature_switched_on_slowly_makes_a_free_line_a_circle():
    """u0 = kappa (about d1) at the interior Voronoi points, switched on over 1 s with damping:
    the line becomes a polygon inscribed in the circle of curvature kappa (n^-2 from the arc:
    its chord is h sin(kappa L / 2) / sin(kappa h / 2), not 2 sin(kappa L / 2) / kappa)."""
    kappa = 2.0
    exact = 2 * math.sin(kappa / 2) / kappa
    errors = []
    for n in (8, 16):
        chord = chord_after_curving(n, kappa)
        h = 1.0 / n
        assert chord == pytest.approx(h * math.sin(kappa / 2) / math.sin(kappa * h / 2), rel=1e-6)
        errors.append(abs(chord - exact))
    assert 3.6 < errors[0] / errors[1] < 4.4


CURVATURE_WAVE = dict(curvature=[[0.0, 0.0, 0.0], [3.0, 1.0, 0.5], [0.0, 0.0, 0.0]])


def actuation_energy_error(fraction, amplitudes=CURVATURE_WAVE):
    """max |E - W - E(0)| and max |W| over 1000 stable steps of a travelling wave of rest
    curvature (or of the ``amplitudes`` given, at the same points) on a free line, no damping,
    at ``fraction`` of the stable step."""
    net, line = free_rod(8)
    wave = cosnet.ActiveCurvature(line, points=[0.0, 0.5, 1.0], period=0.5, wavelength=0.7, **amplitudes)
    dt = cosnet.Simulation(net, [wave, cosnet.Damping(0.0)]).dt * fraction
    sim = cosnet.Simulation(net, [wave, cosnet.Damping(0.0)], dt=dt)
    e0 = sim.energy()
    worst, most = 0.0, 0.0
    for _ in range(20):     # the same sample times at every dt
        sim.run(steps=round(50 / fraction))
        worst = max(worst, abs(sim.energy() - sim.actuation_work() - e0))
        most = max(most, abs(sim.actuation_work()))
    return worst, most


def test_energy_minus_actuation_work_is_conserved_to_second_order():
    """The work the actuation does (the strain energy each change of u0 adds) balances the
    energy to Verlet's order: halving dt quarters the error."""
    e1, most = actuation_energy_error(0.5)
    e2, _ = actuation_energy_error(0.25)
    assert e1 < 1e-3 * most
    assert 3.4 < e1 / e2 < 4.8


def test_muscle_direction_must_be_a_nonzero_vector():
    _, line = free_rod(2)
    for bad in ((0.0, 0.0, 0.0), (1e-300, 0.0, 0.0), (1.0, np.nan, 0.0), (1.0, 0.0)):
        with pytest.raises(ValueError, match=r"^MuscleTorque on .*: direction must be a nonzero 3-vector, got "):
            cosnet.MuscleTorque(line, moment=1.0, direction=bad)
    assert cosnet.MuscleTorque(line, moment=1.0, direction=(0.0, 3.0, 4.0)).direction.tolist() == [0.0, 0.6, 0.8]


def account_error(dt):
    """max |E - W - A + D - E(0)| over a run, and the smallest of max |W|, |A|, D: a line whose
    end a is shaken and turned by a drive, a travelling muscle wave along it, gravity and
    damping (on the driven node too). Everything starts smoothly (the drive at rest, the
    muscle ramped in), so the error is Verlet's on the motion, not a jolt's at the start."""
    net, line = free_rod(6)
    a = line.start
    drive = cosnet.Drive(a, position=dict(amplitude=[0.0, 0.03, 0.02], omega=20.0, phase=math.pi / 2),
                         rotation=dict(amplitude=0.2, omega=15.0, phase=math.pi / 2), axis=(1.0, 0.0, 0.0))
    muscle = cosnet.MuscleTorque(line, moment=[0.0, 2e-3, 0.0], points=[0.0, 0.5, 1.0], direction=(1.0, 1.0, 0.0),
                                 period=0.1, wavelength=0.8, ramp_time=0.05)
    sim = cosnet.Simulation(net, [cosnet.Gravity(), cosnet.Damping(2.0, 3.0), drive, muscle], dt=dt)
    e0, worst, most = sim.energy(), 0.0, np.zeros(3)
    for _ in range(50):      # the same sample times at every dt
        sim.run(steps=round(0.004 / dt))
        w, act, d = sim.driver_work(), sim.actuation_work(), sim.dissipated()
        worst = max(worst, abs(sim.energy() - w - act + d - e0))
        most = np.maximum(most, np.abs([w, act, d]))
    return worst, most.min()


def test_energy_balances_driver_and_muscle_work_and_damping_to_second_order():
    """Every account together: the drive's work (with what damping takes from its node, which
    it puts back), the muscle's work in the kicks and the energy damping takes balance the
    energy to Verlet's order."""
    e1, least = account_error(2e-4)
    e2, _ = account_error(1e-4)
    assert least > 100 * e1
    assert 3.4 < e1 / e2 < 4.6


SCHEDULE = dict(times=[0.0, 0.5, 1.0, 1.5], values=[0.0, 1.0, 1.0, 0.4])


def test_a_scheduled_rest_curvature_follows_its_table_exactly():
    """schedule (a table of times and values): u0 = A g(t) at the interior Voronoi points after
    every step, g the clamped cubic spline through the table (held beyond it), to round-off."""
    from scipy.interpolate import CubicSpline
    net, line = free_rod(6)
    curve = cosnet.ActiveCurvature(line, curvature=(2.0, 0.0, 0.5), schedule=SCHEDULE)
    sim = cosnet.Simulation(net, [curve, cosnet.Damping(1.0)])
    g = CubicSpline(SCHEDULE["times"], SCHEDULE["values"], bc_type="clamped")
    v = slice(int(sim.model.line_vertex_offsets[0]) + 1, int(sim.model.line_vertex_offsets[1]) - 1)
    for t in (0.13, 0.5, 0.91, 1.37, 2.2):
        sim.run(until=t)
        want = float(g(min(sim.time, 1.5)))
        np.testing.assert_allclose(sim.model.voronoi_rest_curvature[v], [[2.0 * want, 0.0, 0.5 * want]] * 5,
                                   rtol=1e-12, atol=1e-14)


def schedule_energy_error(fraction):
    """max |E - W - E(0)| and max |W| of a free line whose rest curvature follows SCHEDULE (no
    damping), at ``fraction`` of the stable step, sampled at the same times at every dt."""
    net, line = free_rod(8)
    curve = cosnet.ActiveCurvature(line, curvature=(3.0, 1.0, 0.5), schedule=SCHEDULE)
    dt = cosnet.Simulation(net, [curve]).dt * fraction
    sim = cosnet.Simulation(net, [curve], dt=dt)
    e0 = sim.energy()
    worst, most = 0.0, 0.0
    for _ in range(20):
        sim.run(steps=round(50 / fraction))
        worst = max(worst, abs(sim.energy() - sim.actuation_work() - e0))
        most = max(most, abs(sim.actuation_work()))
    return worst, most


def test_energy_minus_scheduled_actuation_work_is_conserved_to_second_order():
    e1, most = schedule_energy_error(0.5)
    e2, _ = schedule_energy_error(0.25)
    assert e1 < 1e-3 * most
    assert 3.4 < e1 / e2 < 4.8


def test_a_bad_schedule_is_refused_in_one_line():
    _, line = free_rod(2)
    with pytest.raises(ValueError, match=r"^ActiveCurvature on .*: schedule: times must increase strictly"):
        cosnet.ActiveCurvature(line, curvature=(1.0, 0.0, 0.0), schedule=dict(times=[0.0, 1.0, 1.0], values=[0, 1, 2]))
    scene = ROD + """
[[effects]]
kind = "active_curvature"
line = "rod"
curvature = [1.0, 0.0, 0.0]
schedule = { times = [0.0, 1.0], value = [0.0, 1.0] }
"""
    with pytest.raises(ValueError, match=r"schedule") as e:
        build_scene(tomllib.loads(scene))
    assert "\n" not in str(e.value)


# ---------------------------------------------------------------- rest stretch and shear
RAMP = dict(times=[0.0, 1.0], values=[0.0, 1.0])
EA = RUBBER.E * math.pi * 0.02 ** 2


def test_rest_stretch_switched_on_slowly_makes_a_free_line_longer_without_force():
    """v0 = (1 + e) d3 switched on over 1 s with damping: the free line (no gravity) takes the
    length (1 + e) L, and no axial force is left in it (n = K (v - v0) -> 0)."""
    net, line = free_rod(8)
    grow = cosnet.ActiveCurvature(line, stretch=0.2, schedule=RAMP)
    sim = cosnet.Simulation(net, [grow, cosnet.Damping(5.0)])
    sim.run(until=5.0)
    x = sim.line_positions(line)
    assert np.linalg.norm(x[-1] - x[0]) == pytest.approx(1.2, rel=1e-8)
    np.testing.assert_allclose(sim.model.element_rest_strain, [[0.0, 0.0, 1.2]] * 8, rtol=1e-15)
    assert np.abs(sim.line_fields(line)["force"]).max() < 1e-8 * EA
    # a net whose rest strain nothing changes carries none, and steps without the pass that adds it
    plain = cosnet.Simulation(net, [cosnet.ActiveCurvature(line, curvature=(1.0, 0.0, 0.0)), cosnet.Damping(5.0)])
    assert plain.model.element_rest_strain.shape == (0, 3)


def test_rest_stretch_of_a_line_clamped_at_both_ends_is_an_axial_force_minus_ea_e():
    """Both ends fixed, so the line keeps its length: v = d3 and n = K (d3 - (1 + e) d3) = -EA e
    along it, exactly (a contraction e < 0 pulls: the line stays straight)."""
    net = cosnet.Net()
    a = net.add_node((0.0, 0.0, 0.0), fixed=True, name="a")
    b = net.add_node((1.0, 0.0, 0.0), fixed=True, name="b")
    line = net.add_line(a, b, material=RUBBER, section=cosnet.Circle(0.02), elements=8, name="rod")
    e = -0.15
    sim = cosnet.Simulation(net, [cosnet.ActiveCurvature(line, stretch=e, ramp_time=0.5), cosnet.Damping(5.0)])
    sim.run(until=3.0)
    n = sim.line_fields(line)["force"]
    np.testing.assert_allclose(n[:, 0], -EA * e, rtol=1e-6)
    np.testing.assert_allclose(n[:, 1:], 0.0, atol=1e-9 * EA)


def test_energy_minus_stretch_and_shear_actuation_work_is_conserved_to_second_order():
    """A travelling wave of rest stretch and shear: the strain energy each change of v0 adds
    balances the energy to Verlet's order, as for the rest curvature. It drives the axial and
    shear modes, whose frequencies set the stable step, so Verlet's error is larger than for a
    bending wave at the same fraction of that step: a quarter and an eighth of it here."""
    wave = dict(stretch=[0.0, 0.3, 0.0], shear=[[0.0, 0.0], [0.03, -0.02], [0.0, 0.0]])
    e1, most = actuation_energy_error(0.25, wave)
    e2, _ = actuation_energy_error(0.125, wave)
    assert e1 < 1e-3 * most
    assert 3.4 < e1 / e2 < 4.8


def test_a_rest_stretch_that_could_reach_zero_length_is_refused_in_one_line():
    """1 + e f(t) > 0 for every value f the time law takes: a wave swings both ways, a ramp
    passes through 0, a schedule's table, harmonic and rate bound it."""
    _, line = free_rod(4)
    for bad in (dict(stretch=-1.0), dict(stretch=-1.2, ramp_time=1.0), dict(stretch=1.0, period=1.0),
                dict(stretch=[0.0, 0.5, 0.0], points=[0.0, 0.5, 1.0], schedule=dict(amplitude=2.0, omega=3.0)),
                dict(stretch=0.5, schedule=dict(times=[0.0, 1.0], values=[0.0, -2.0])),
                dict(stretch=0.01, schedule=dict(rate=-1.0))):
        with pytest.raises(ValueError, match=r"^ActiveCurvature on .*: stretch .* makes the rest stretch "
                                             r"1 \+ e = (-inf|[-0-9.e]+) <= 0$"):
            cosnet.ActiveCurvature(line, **bad)
    for good in (dict(stretch=3.0, ramp_time=1.0), dict(stretch=-0.9, period=1.0),
                 dict(stretch=0.5, schedule=dict(times=[0.0, 1.0], values=[0.0, 1.5])),
                 dict(stretch=0.01, schedule=dict(rate=1.0))):
        cosnet.ActiveCurvature(line, **good)
    with pytest.raises(ValueError, match=r"^ActiveCurvature on .*: give curvature, stretch or shear"):
        cosnet.ActiveCurvature(line)


STRETCH_SCENE = ROD + """
[[effects]]
kind = "active_curvature"
line = "rod"
"""


@pytest.mark.parametrize("extra, message", [
    ("stretch = -1.5", r"\(active_curvature\).*stretch -1.5 .* 1 \+ e = -0.5 <= 0"),
    ("stretch = 0.1\nstreth = 0.2", r"\(active_curvature\).*streth"),
    ("shear = [0.1]", r"\(active_curvature\) shear: must have shape \(2,\)"),
    ("stretch = [0.1, 0.2]\npoints = [0.0, 0.5, 1.0]",
     r"\(active_curvature\).*stretch must give one finite value per point"),
])
def test_bad_stretch_keys_in_a_scene_are_refused_in_one_line(extra, message):
    with pytest.raises(ValueError, match=message) as e:
        build_scene(tomllib.loads(STRETCH_SCENE + extra))
    assert "\n" not in str(e.value)
