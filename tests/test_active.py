"""Active lines: a steady muscle torque bends a free line to the curvature M / EI."""

import math

import numpy as np
import pytest

import cosnet
from cosnet.scene import build_scene

RUBBER = cosnet.Material(E=1e6, G=4e5, density=1000.0, name="rubber")


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
    scene = """
[materials.m]
E = 1e6
G = 4e5
density = 1000.0
[nodes.a]
position = [0, 0, 0]
[nodes.b]
position = [1, 0, 0]
[lines.rod]
start = "a"
end = "b"
material = "m"
section = { kind = "circle", radius = 0.02 }
elements = 4
[run]
until = 0.01
[[effects]]
kind = "muscle_torque"
line = "rod"
moment = [1.0, 2.0]
points = [0.0, 0.5, 1.0]
"""
    import tomllib
    with pytest.raises(ValueError, match=r"\(muscle_torque\) (moment|points): .*one finite value per point") as e:
        build_scene(tomllib.loads(scene))
    assert "\n" not in str(e.value)
