"""Bad input is refused when the net is built, with a message naming the culprit."""

import numpy as np
import pytest

import cosnet
from nets import STEEL, cantilever


def test_material_and_sections_reject_unphysical_values():
    with pytest.raises(ValueError, match="E must be positive"):
        cosnet.Material(E=-1.0, G=1.0, density=1.0)
    with pytest.raises(ValueError, match="density must be positive"):
        cosnet.Material(E=1.0, G=1.0, density=0.0)
    with pytest.raises(ValueError, match="G must be positive"):
        cosnet.Material(E=1.0, G=-2.0, density=1.0)
    with pytest.raises(ValueError, match="exactly one of G"):
        cosnet.Material(E=1.0, density=1.0)
    with pytest.raises(ValueError, match="E must be finite"):
        cosnet.Material(E=float("nan"), G=1.0, density=1.0)
    with pytest.raises(ValueError, match="radius must be positive"):
        cosnet.Circle(radius=0.0)
    with pytest.raises(ValueError, match="positive definite"):
        cosnet.Section(A=1.0, I11=1.0, I22=1.0, I12=2.0, J=1.0)


def test_python_values_follow_the_scene_files_rule():
    """One rule for a number, in a scene file and in Python alike: a truth value or a string
    is refused (float(True) and float("3") would pass them as 1 and 3)."""
    from cosnet.core import units
    for bad in (True, "3", np.bool_(True)):
        with pytest.raises(ValueError, match="must be a number"):
            cosnet.Material(E=bad, G=1.0, density=1.0)
        with pytest.raises(units.BadValue, match="must be a number"):
            units.number(bad)
    with pytest.raises(ValueError, match="g must be 3 finite numbers"):
        cosnet.Gravity(g=["0", "0", "-9.81"])
    with pytest.raises(ValueError, match="g must be 3 finite numbers"):
        cosnet.Gravity(g=[True, 0.0, 0.0])
    assert cosnet.Material(E=np.int64(2), G=np.float32(1.0), density=1).E == 2.0   # numpy numbers are numbers
    assert np.array_equal(cosnet.Gravity(g=np.array([0, 0, -9])).g, [0.0, 0.0, -9.0])


def test_node_validation_names_the_node():
    net = cosnet.Net()
    with pytest.raises(ValueError, match="node 'n'.*position must be finite"):
        net.add_node((0, np.nan, 0), name="n")
    with pytest.raises(ValueError, match="node 'm'.*mass must be >= 0"):
        net.add_node((0, 0, 0), mass=-1.0, name="m")
    with pytest.raises(ValueError, match="node 'i'.*symmetric"):
        net.add_node((0, 0, 0), inertia=[[1, 0.5, 0], [0, 1, 0], [0, 0, 1]], name="i")
    with pytest.raises(ValueError, match="node 'p'.*positive semidefinite"):
        net.add_node((0, 0, 0), inertia=[[1, 2, 0], [2, 1, 0], [0, 0, 1]], name="p")
    with pytest.raises(ValueError, match="node 'f'.*frame must be a rotation"):
        net.add_node((0, 0, 0), frame=np.diag([1.0, 1.0, -1.0]), name="f")


def test_line_validation_names_the_line():
    net = cosnet.Net()
    a = net.add_node((0, 0, 0), fixed=True, name="a")
    b = net.add_node((1, 0, 0), name="b")
    other = cosnet.Net().add_node((0, 0, 0), name="stranger")
    sec = cosnet.Circle(0.01)
    with pytest.raises(ValueError, match="line 'x'.*unknown end node"):
        net.add_line(a, other, material=STEEL, section=sec, elements=2, name="x")
    with pytest.raises(ValueError, match="line 'loop'.*both ends are node 'a'"):
        net.add_line(a, a, material=STEEL, section=sec, elements=2, name="loop")
    with pytest.raises(ValueError, match="line 'z'.*elements must be a positive integer"):
        net.add_line(a, b, material=STEEL, section=sec, elements=0, name="z")
    with pytest.raises(ValueError, match="line 'r'.*end_frame must be a rotation"):
        net.add_line(a, b, material=STEEL, section=sec, elements=2, end_frame=2 * np.eye(3), name="r")
    with pytest.raises(ValueError, match="line 'n'.*start_offset must be finite"):
        net.add_line(a, b, material=STEEL, section=sec, elements=2, start_offset=(np.nan, 0, 0), name="n")
    c = net.add_node((0, 0, 0), name="c")
    with pytest.raises(ValueError, match="line 'zero'.*length must be positive"):
        net.add_line(a, c, material=STEEL, section=sec, elements=2, name="zero")
    with pytest.raises(ValueError, match="line 'pts'.*must coincide with the node end point"):
        net.add_line(a, b, material=STEEL, section=sec, elements=2, points=[[0, 0, 0], [2, 0, 0]], name="pts")


def test_names_are_unique_per_kind_and_default_to_kind_and_index():
    net = cosnet.Net()
    a = net.add_node((0, 0, 0), fixed=True, name="a")
    b = net.add_node((1, 0, 0))
    assert b.name == "node1"
    with pytest.raises(ValueError, match="^node 'a': a node with this name already exists$"):
        net.add_node((2, 0, 0), name="a")
    line = net.add_line(a, b, material=STEEL, section=cosnet.Circle(0.01), elements=2, name="a")
    assert line.name == "a" and net.line("a") is line    # nodes and lines are named apart
    with pytest.raises(ValueError, match="^line 'a': a line with this name already exists$"):
        net.add_line(a, b, material=STEEL, section=cosnet.Circle(0.01), elements=2, name="a")
    assert net.add_line(b, a, material=STEEL, section=cosnet.Circle(0.01), elements=2).name == "line1"


def test_lonely_massless_node_is_refused_when_simulated():
    net, *_ = cantilever(n=2)
    net.add_node((5, 5, 5), name="ghost")
    with pytest.raises(ValueError, match="node 'ghost'.*no line ends at it"):
        cosnet.Simulation(net)


def test_dt_above_estimate_needs_force_and_bad_effects_are_refused():
    net, line, root, tip = cantilever(n=4)
    est = cosnet.Simulation(net).dt
    with pytest.raises(ValueError, match="exceeds the estimated stable step"):
        cosnet.Simulation(net, dt=3 * est)
    assert cosnet.Simulation(net, dt=3 * est, force_dt=True).dt == 3 * est
    with pytest.raises(ValueError, match="stepper must be one of"):
        cosnet.Simulation(net, stepper="euler")
    with pytest.raises(ValueError, match="Damping: translational rate"):
        cosnet.Damping(-1.0)
    with pytest.raises(ValueError, match="Gravity: g must be 3 finite numbers"):
        cosnet.Gravity((0, np.inf, 0))
    with pytest.raises(ValueError, match="NodeLoad: .* not a node of this simulation"):
        cosnet.Simulation(net, effects=[cosnet.NodeLoad(cosnet.Net().add_node((0, 0, 0)), (1, 0, 0))])


def test_locked_axis_spin_is_refused():
    net = cosnet.Net()
    n = net.add_node((0, 0, 0), mass=1.0, inertia=np.diag([np.inf, 1.0, 1.0]), name="hinge")
    sim = cosnet.Simulation(net, dt=1e-3)
    sim.node_angular_velocity(n)[:] = (1.0, 0.0, 0.0)
    with pytest.raises(ValueError, match="node 'hinge'.*locked"):
        sim.run(steps=1)
