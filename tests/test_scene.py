"""Scene files: a scene builds exactly the net the Python API builds, and every broken scene
(misspelt key, wrong type, missing reference, unphysical value) is refused with a one-line
ValueError naming the file, the table and the key."""

import copy
import math
import re
import tomllib

import numpy as np
import pytest

import cosnet
from cosnet.engine.flatten import flatten
from cosnet.scene.loader import build_scene, load_scene

SCENE = """
title = "everything"

[materials.steel]
E = 2.1e11
G = 8.1e10
density = 7850.0

[materials.soft]
E = 5.0e6
poisson = 0.25
density = 1000.0

[sections.rod]
kind = "circle"
radius = 0.01

[sections.bar]
kind = "rectangle"
width = 0.03
height = 0.02

[sections.pipe]
kind = "tube"
radius = 0.02
thickness = 0.004

[nodes.root]
position = [0.0, 0.0, 0.0]
fixed = true

[nodes.body]
position = [1.0, 0.0, 0.0]
mass = 0.5
inertia = [[2e-3, 1e-4, 0.0], [1e-4, 3e-3, 0.0], [0.0, 0.0, 4e-3]]
frame = { d1 = [0.0, 1.0, 0.0], d3 = [1.0, 0.0, 0.0] }

[nodes.hinge]
position = [1.0, 1.0, 0.0]
mass = "inf"
inertia = [1e-3, 1e-3, "inf"]

[lines.arm]
start = "root"
end = "body"
material = "steel"
section = "rod"
elements = 5
end_offset = [0.0, 0.0, -0.1]

[lines.bent]
start = "body"
end = "hinge"
material = "soft"
section = "bar"
elements = 4
start_offset = [0.1, 0.0, 0.0]
rest_curvature = [0.5, 0.0, 0.0]
d1 = [0.0, 0.0, 1.0]
points = [[1.0, 0.1, 0.0], [1.2, 0.5, 0.1], [1.0, 1.0, 0.0]]

[lines.brace]
start = "root"
end = "hinge"
material = "steel"
section = { kind = "explicit", A = 1e-4, I11 = 2e-9, I22 = 1e-9, J = 2.5e-9, I12 = 5e-10 }
elements = 3
start_frame = [[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]]

[[effects]]
kind = "gravity"
g = [0.0, 0.0, -9.81]

[[effects]]
kind = "node_load"
node = "body"
force = [0.0, 1.0, 0.0]
torque = [0.0, 0.0, 0.1]
omega = 3.0

[[effects]]
kind = "line_load"
line = "arm"
force_per_length = [0.0, 0.0, -2.0]

[[effects]]
kind = "damping"
translational = 0.5
rotational = 0.2

[initial.nodes.body]
velocity = [0.0, 0.0, 0.1]

[initial.perturbation]
velocity = 0.01
seed = 3

[run]
until = 0.01
dt = "auto"
stepper = "pefrl"
output_interval = 0.001
probes = ["body", "arm@0.5"]
"""


def hand_built():
    steel = cosnet.Material(E=2.1e11, G=8.1e10, density=7850.0, name="steel")
    soft = cosnet.Material(E=5.0e6, poisson=0.25, density=1000.0, name="soft")
    net = cosnet.Net()
    root = net.add_node((0, 0, 0), fixed=True, name="root")
    frame = np.column_stack([(0, 1, 0), (0, 0, 1), (1, 0, 0)])
    body = net.add_node((1, 0, 0), mass=0.5, inertia=[[2e-3, 1e-4, 0], [1e-4, 3e-3, 0], [0, 0, 4e-3]],
                        frame=frame, name="body")
    hinge = net.add_node((1, 1, 0), mass=math.inf, inertia=[1e-3, 1e-3, math.inf], name="hinge")
    arm = net.add_line(root, body, material=steel, section=cosnet.Circle(0.01), elements=5,
                       end_offset=(0, 0, -0.1), name="arm")
    net.add_line(body, hinge, material=soft, section=cosnet.Rectangle(0.03, 0.02), elements=4,
                 start_offset=(0.1, 0, 0), rest_curvature=(0.5, 0, 0), d1=(0, 0, 1),
                 points=[[1.0, 0.1, 0.0], [1.2, 0.5, 0.1], [1.0, 1.0, 0.0]], name="bent")
    net.add_line(root, hinge, material=steel,
                 section=cosnet.Section(A=1e-4, I11=2e-9, I22=1e-9, J=2.5e-9, I12=5e-10), elements=3,
                 start_frame=[[1, 0, 0], [0, 0, -1], [0, 1, 0]], name="brace")
    effects = [cosnet.Gravity((0, 0, -9.81)), cosnet.NodeLoad(body, (0, 1, 0), (0, 0, 0.1), omega=3.0),
               cosnet.LineLoad(arm, (0, 0, -2.0)), cosnet.Damping(0.5, 0.2)]
    return net, effects


def write(tmp_path, text, name="scene.toml"):
    p = tmp_path / name
    p.write_text(text)
    return p


def test_scene_builds_the_same_net_as_the_api(tmp_path):
    scene = load_scene(write(tmp_path, SCENE))
    net, effects = hand_built()
    assert [n.name for n in scene.net.nodes] == [n.name for n in net.nodes]
    assert [l.name for l in scene.net.lines] == [l.name for l in net.lines]
    for a, b in zip(scene.net.nodes, net.nodes):
        np.testing.assert_array_equal(a.position, b.position)
        np.testing.assert_array_equal(a.frame, b.frame)
        np.testing.assert_array_equal(a.inertia, b.inertia)
        assert a.mass == b.mass
    for a, b in zip(scene.net.lines, net.lines):
        np.testing.assert_array_equal(a.points, b.points)
        assert a.section == b.section and a.material == b.material and a.elements == b.elements
        for key in ("start_offset", "end_offset", "start_frame", "end_frame", "rest_curvature", "d1"):
            x, y = getattr(a, key), getattr(b, key)
            assert (x is None) == (y is None), key
            if x is not None:
                np.testing.assert_array_equal(x, y)
    # the flattened arrays the kernels see are identical
    (ma, sa, _), (mb, sb, _) = flatten(scene.net), flatten(net)
    for name in ma._fields:
        np.testing.assert_array_equal(getattr(ma, name), getattr(mb, name), err_msg=name)
    for name in sa._fields:
        np.testing.assert_array_equal(getattr(sa, name), getattr(sb, name), err_msg=name)
    assert [type(e) for e in scene.effects] == [type(e) for e in effects]
    np.testing.assert_array_equal(scene.effects[1].force, effects[1].force)
    assert scene.effects[1].node is scene.net.node("body")
    assert scene.effects[1].amp[3][0] == 3.0 and scene.effects[3].rotational == 0.2   # omega of its one row
    assert scene.run.stepper == "pefrl" and scene.run.dt is None and scene.run.until == 0.01
    assert [p.name for p in scene.run.probes] == ["body", "arm@0.5"]


def test_scene_simulation_applies_initial_conditions(tmp_path):
    scene = load_scene(write(tmp_path, SCENE))
    sim = scene.simulation()
    assert sim.stepper == "pefrl" and len(sim.effects) == 4
    np.testing.assert_array_equal(sim.node_velocity(scene.net.node("body")), [0.0, 0.0, 0.1])
    free = sim.model.vertex_inv_mass > 0
    v = sim.state.v[free]
    # a seeded perturbation of amplitude 0.01 m/s on the free vertices, reproducible
    assert 0.005 < v.std() < 0.02
    np.testing.assert_array_equal(scene.simulation().state.v, sim.state.v)


def test_scaled_scene_is_the_si_scene(tmp_path):
    """With [scale] the numbers are in the units of §5 (Table 5.2); the net comes out in SI."""
    s = cosnet.Scale(time=0.01, length=0.5, area=1e-4, density=1000.0)
    L, M, T = s.length, s.mass, s.time
    text = f"""
[scale]
time = 0.01
length = 0.5
area = 1e-4
density = 1000.0
[materials.m]
E = {2.1e11 / (M / L / T**2)!r}
G = {8.1e10 / (M / L / T**2)!r}
density = {7850.0 / (M / L**3)!r}
[sections.s]
kind = "circle"
radius = {0.01 / L!r}
[nodes.a]
position = [0.0, 0.0, 0.0]
fixed = true
[nodes.b]
position = [{1.0 / L!r}, 0.0, 0.0]
mass = {0.3 / M!r}
inertia = [{1e-4 / (M * L * L)!r}, {1e-4 / (M * L * L)!r}, {2e-4 / (M * L * L)!r}]
[lines.ab]
start = "a"
end = "b"
material = "m"
section = "s"
elements = 4
[[effects]]
kind = "gravity"
g = [0.0, 0.0, {-9.81 / (L / T**2)!r}]
[run]
until = {0.2 / T!r}
"""
    scene = load_scene(write(tmp_path, text))
    b = scene.net.node("b")
    assert b.position[0] == pytest.approx(1.0, rel=1e-12) and b.mass == pytest.approx(0.3, rel=1e-12)
    np.testing.assert_allclose(np.diag(b.inertia), [1e-4, 1e-4, 2e-4], rtol=1e-12)
    line = scene.net.line("ab")
    assert line.material.E == pytest.approx(2.1e11, rel=1e-12)
    assert line.material.density == pytest.approx(7850.0, rel=1e-12)
    assert line.section.radius == pytest.approx(0.01, rel=1e-12)
    np.testing.assert_allclose(scene.effects[0].g, [0, 0, -9.81], rtol=1e-12)
    assert scene.run.until == pytest.approx(0.2, rel=1e-12)


# ---------------------------------------------------------------------- fuzzed broken scenes
def dumps(data) -> str:
    """A small TOML writer for the scene above (tables, arrays of tables, inline values)."""
    def value(v):
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, str):
            return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
        if isinstance(v, (int, float)):
            return repr(v) if math.isfinite(v) else "nan" if v != v else ("inf" if v > 0 else "-inf")
        if isinstance(v, list):
            return "[" + ", ".join(value(x) for x in v) + "]"
        if isinstance(v, dict):
            return "{ " + ", ".join(f'"{k}" = {value(x)}' for k, x in v.items()) + " }"
        raise TypeError(v)

    out = []

    def table(path, d):
        plain = {k: v for k, v in d.items() if not isinstance(v, dict) and not _is_aot(v)}
        if path:
            out.append("[" + ".".join(f'"{p}"' for p in path) + "]")
        out.extend(f'"{k}" = {value(v)}' for k, v in plain.items())
        for k, v in d.items():
            if isinstance(v, dict):
                table(path + [k], v)
            elif _is_aot(v):
                for item in v:
                    out.append("[[" + ".".join(f'"{p}"' for p in path + [k]) + "]]")
                    out.extend(f'"{kk}" = {value(vv)}' for kk, vv in item.items())
    table([], data)
    return "\n".join(out) + "\n"


def _is_aot(v):
    return isinstance(v, list) and v and all(isinstance(x, dict) for x in v)


BASE = tomllib.loads(SCENE)
NAMED = {("materials",), ("sections",), ("nodes",), ("lines",), ("initial", "nodes")}


def leaves(d, path=()):
    """(path to the containing table, key) of every key the scene sets (names excluded)."""
    if isinstance(d, dict):
        for k, v in d.items():
            if path in NAMED:
                yield from leaves(v, path + (k,))
                continue
            yield path, k
            if isinstance(v, dict) and not (path and path[-1] in ("section",) or k in ("frame",)):
                yield from leaves(v, path + (k,))
            elif _is_aot(v):
                for i, item in enumerate(v):
                    yield from leaves(item, path + (k, i))


def table_of(data, path):
    for p in path:
        data = data[p]
    return data


def table_label(path):
    """How the message names the table: [lines.arm], [[effects]] #2, [run] ..."""
    if len(path) >= 2 and isinstance(path[1], int):
        return f"[[{path[0]}]] #{path[1] + 1}"
    return ".".join(str(p) for p in path)


def MISSPELL(k):
    swapped = k[:-2] + k[-1] + k[-2] if len(k) > 2 else k
    return swapped if swapped != k else k + "x"


WRONG_TYPE = {str: 12345, bool: "yes", int: "seven", float: "seven", list: "seven", dict: 42}
PHYSICAL = {"E": -2.1e11, "G": 0.0, "density": -1.0, "radius": -0.01, "width": 0.0, "height": -1.0,
            "thickness": 0.05, "elements": 0, "mass": -0.5, "until": -1.0, "output_interval": 0.0,
            "translational": -0.5, "A": 0.0, "poisson": 0.7, "dt": -1e-6, "velocity": -0.01}
REFERENCES = {"start": "nowhere", "end": "nowhere", "material": "unobtainium", "section": "nosuch",
              "node": "ghost", "line": "ghost", "kind": "magnetism", "probes": ["ghost"],
              "stepper": "euler"}


def mutations():
    for path, key in leaves(BASE):
        if path == () and isinstance(BASE[key], (dict, list)) and key != "title":
            yield "misspelt", path, key, None
            continue
        val = table_of(BASE, path)[key]
        yield "misspelt", path, key, None
        yield "wrong type", path, key, [1, 2] if val in ("inf", "auto") else WRONG_TYPE[type(val)]
        if key in PHYSICAL and not (key == "velocity" and "perturbation" not in path):
            yield "unphysical", path, key, PHYSICAL[key]
        if key in REFERENCES:
            yield "reference", path, key, REFERENCES[key]
    for path, key in ((("nodes", "body"), "position"), (("lines", "arm"), "start"),
                      (("materials", "steel"), "E"), (("run",), "until"), (("lines", "arm"), "elements")):
        yield "missing", path, key, None


CASES = list(mutations())


def test_fuzz_set_covers_every_key():
    kinds = {c[0] for c in CASES}
    assert kinds == {"misspelt", "wrong type", "unphysical", "reference", "missing"}
    assert len(CASES) > 120


@pytest.mark.parametrize("kind,path,key,new", CASES, ids=[f"{c[0]}:{'.'.join(map(str, c[1]))}.{c[2]}" for c in CASES])
def test_broken_scene_is_refused_naming_the_key(tmp_path, kind, path, key, new):
    data = copy.deepcopy(BASE)
    t = table_of(data, path)
    named = key
    if kind == "misspelt":
        named = MISSPELL(key)
        t = {(named if k == key else k): v for k, v in t.items()}
        if path:
            table_of(data, path[:-1])[path[-1]] = t
        else:
            data = t
    elif kind == "missing":
        del t[key]
    else:
        t[key] = new
    p = write(tmp_path, dumps(data), "broken scene.toml")
    with pytest.raises(ValueError) as info:
        load_scene(p)
    msg = str(info.value)
    assert "\n" not in msg
    assert str(p) in msg
    assert named in msg, msg
    if path:
        assert table_label(path) in msg.replace('"', ""), msg


def test_dumps_round_trips_the_valid_scene(tmp_path):
    """The fuzzer's writer is faithful: the unmutated scene loads and equals the original."""
    assert tomllib.loads(dumps(BASE)) == BASE
    load_scene(write(tmp_path, dumps(BASE)))


@pytest.mark.parametrize("text,key", [
    ("[nodes.a]\nposition = [0, 0, 0]\nframe = [[1, 0, 0], [0, 1, 0], [0, 0, 2]]\n[run]\nuntil = 1\n", "frame"),
    ("[nodes.a]\nposition = [0, 0, 0]\n[run]\nuntil = 1\n", "mass"),
    ("[nodes.a]\nposition = [0, 0]\nmass = 1\ninertia = [1, 1, 1]\n[run]\nuntil = 1\n", "position"),
    ("[nodes.a]\nposition = [0, 0, 0]\nfixed = true\nmass = 2\n[run]\nuntil = 1\n", "fixed"),
    ("[nodes.a]\nposition = [0, 0, 0]\nmass = 1\ninertia = [[1, 2, 0], [0, 1, 0], [0, 0, 1]]\n[run]\nuntil = 1\n",
     "inertia"),
])
def test_net_errors_are_wrapped_with_file_table_and_key(tmp_path, text, key):
    p = write(tmp_path, text)
    with pytest.raises(ValueError) as info:
        load_scene(p)
    msg = str(info.value)
    assert "\n" not in msg and str(p) in msg and "nodes.a" in msg and key in msg, msg


def test_line_errors_from_the_net_name_the_line_and_key(tmp_path):
    good = "points = [[1.0, 0.1, 0.0], [1.2, 0.5, 0.1], [1.0, 1.0, 0.0]]"
    assert good in SCENE
    text = SCENE.replace(good, "points = [[1.0, 0.1, 0.0], [1.2, 0.5, 0.1], [1.0, 3.0, 0.0]]")
    p = write(tmp_path, text)
    with pytest.raises(ValueError, match=r"\[lines\.bent\] points: .*last point"):
        load_scene(p)


def test_unreadable_or_invalid_toml_is_a_value_error(tmp_path):
    with pytest.raises(ValueError, match="cannot read"):
        load_scene(tmp_path / "missing.toml")
    with pytest.raises(ValueError, match="not valid TOML"):
        load_scene(write(tmp_path, "[nodes.a\nposition = 1\n"))


def test_build_scene_accepts_parsed_data():
    scene = build_scene(copy.deepcopy(BASE), "inline")
    assert scene.net.element_count == 12 and scene.title == "everything"


def test_a_dt_above_the_stable_step_is_refused_naming_run_dt(tmp_path):
    text = SCENE.replace("output_interval = 0.001\n", "")   # (frames closer than dt are refused)
    p = write(tmp_path, text.replace('dt = "auto"', "dt = 1.0"))
    scene = load_scene(p)
    with pytest.raises(ValueError, match=r"scene\.toml: \[run\] dt: .*exceeds the estimated stable step"):
        scene.simulation()
    forced = load_scene(write(tmp_path, text.replace('dt = "auto"', "dt = 1.0\nforce_dt = true"), "f.toml"))
    assert forced.simulation().dt == 1.0


def test_run_dt_tight_takes_the_highest_modes_step_and_anything_else_is_refused(tmp_path):
    text = SCENE.replace("output_interval = 0.001\n", "")
    tight = load_scene(write(tmp_path, text.replace('dt = "auto"', 'dt = "tight"'))).simulation()
    assert tight.dt == tight.stable_dt(tight=True) >= tight.stable_dt()
    with pytest.raises(ValueError, match=r'b\.toml: \[run\] dt: must be "auto", "tight" or a positive number'):
        load_scene(write(tmp_path, text.replace('dt = "auto"', 'dt = "fast"'), "b.toml"))


def test_initial_spin_is_a_rigid_motion(tmp_path):
    """velocity + angular_velocity x (x - c) on everything: momentum M V, angular momentum
    about the centre of mass I w, no strain rate (the energy is all kinetic, none elastic)."""
    text = SCENE.split("[nodes.root]")[0] + """
[nodes.a]
position = [0.0, 0.0, 0.0]
mass = 0.5
inertia = [1e-3, 2e-3, 3e-3]
[nodes.b]
position = [1.0, 0.0, 0.0]
[lines.ab]
start = "a"
end = "b"
material = "soft"
section = "rod"
elements = 6
[initial]
velocity = [0.0, 0.5, 0.0]
angular_velocity = [0.0, 0.0, 3.0]
[run]
until = 0.01
"""
    scene = load_scene(write(tmp_path, text))
    sim = scene.simulation()
    mass = scene.net.total_mass()
    np.testing.assert_allclose(sim.momentum(), [0.0, 0.5 * mass, 0.0], rtol=1e-12, atol=1e-14)
    e0 = sim.energy_parts()
    assert e0["strain"] < 1e-20 and e0["kinetic"] > 0.5 * mass * 0.25
    s0 = sim.energy_parts()["strain"]
    sim.run(steps=5)
    # a rigid rotation stays rigid to first order: the strain energy grows only from the
    # centrifugal stretch, O(h^2), far below the kinetic energy
    assert sim.energy_parts()["strain"] - s0 < 1e-6 * e0["kinetic"]
    # the everything scene has a fixed node: a rigid motion of the whole net is refused (on loading)
    with pytest.raises(ValueError, match=r"\[initial\] velocity: a rigid motion of the whole net needs"):
        load_scene(write(tmp_path, SCENE + "\n[initial]\nvelocity = [1.0, 0.0, 0.0]\n", "fixed.toml"))


def test_effects_may_be_named_tables(tmp_path):
    text = SCENE.split("[[effects]]")[0] + """
[effects.weight]
kind = "gravity"
g = [0.0, -1.62, 0.0]

[effects.air]
kind = "damping"
translational = 0.1

[run]
until = 0.01
"""
    scene = load_scene(write(tmp_path, text))
    assert [type(e).__name__ for e in scene.effects] == ["Gravity", "Damping"]
    np.testing.assert_array_equal(scene.effects[0].g, [0.0, -1.62, 0.0])
    with pytest.raises(ValueError, match=r"\[effects\.air\] translatonal: unknown key"):
        load_scene(write(tmp_path, text.replace("translational", "translatonal"), "bad.toml"))


# ---------------------------------------------------------------------- faults found at load
def refused(p, match):
    """load_scene(p) raises a one-line ValueError naming the file and matching ``match``."""
    with pytest.raises(ValueError) as info:
        load_scene(p)
    msg = str(info.value)
    assert len(msg.splitlines()) == 1 and msg.startswith(f"{p}: "), msg
    assert re.search(match, msg), msg
    return msg


def test_invalid_utf8_is_refused_naming_the_file(tmp_path):
    p = tmp_path / "latin1.toml"
    p.write_bytes(SCENE.replace('"everything"', '"caf\xe9"').encode("latin-1"))
    refused(p, r"not UTF-8 text: byte 0xe9 in line 2")


def test_deeply_nested_arrays_are_refused_in_one_line(tmp_path):
    """5,000 nested arrays overflow the TOML reader's recursion; 100 overflow no reader but
    are no position either."""
    deep = SCENE.replace("position = [1.0, 1.0, 0.0]", "position = " + "[" * 5000 + "]" * 5000)
    refused(write(tmp_path, deep), r"nested too deeply")
    deep = SCENE.replace("position = [1.0, 1.0, 0.0]", "position = " + "[" * 100 + "1.0" + "]" * 100)
    msg = refused(write(tmp_path, deep, "500.toml"), r"\[nodes\.hinge\] position: must have shape \(3,\)")
    assert len(msg) < 400


def test_a_zero_d1_is_refused_at_load_naming_the_line(tmp_path):
    text = SCENE.replace("[lines.arm]", '[lines."λ1"]').replace('line = "arm"', 'line = "λ1"')
    text = text.replace('"arm@0.5"', '"λ1@0.5"').replace("end_offset = [0.0, 0.0, -0.1]",
                                                           "end_offset = [0.0, 0.0, -0.1]\nd1 = [0, 0, 0]")
    refused(write(tmp_path, text), r'\[lines\."λ1"\] d1: must be a non-zero vector')


def test_a_start_frame_whose_d1_lies_along_the_line_is_refused_at_load(tmp_path):
    """The brace runs along (1, 1, 0) / sqrt 2; a start frame with d1 along it leaves the first
    element without a frame."""
    text = SCENE.replace("start_frame = [[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]]",
                         "start_frame = { d1 = [0.7071067811865476, 0.7071067811865476, 0.0], "
                         "d3 = [0.0, 0.0, 1.0] }")
    refused(write(tmp_path, text), r"\[lines\.brace\] start_frame: d1 hint is parallel")


def test_an_unknown_contact_line_is_refused_at_load_naming_the_effect(tmp_path):
    text = SCENE.replace("[initial.nodes.body]", '[[effects]]\nkind = "contact"\nk = 1e4\nlines = ["arm", "x"]\n'
                                                 "[initial.nodes.body]")
    refused(write(tmp_path, text), r"\[\[effects\]\] #5 \(contact\) lines: unknown line 'x'; lines are")


def test_initial_velocities_that_cannot_apply_are_refused_at_load(tmp_path):
    text = SCENE.replace("[initial.nodes.body]", "[initial]\nvelocity = [1.0, 0.0, 0.0]\n[initial.nodes.body]")
    refused(write(tmp_path, text), r"\[initial\] velocity: a rigid motion of the whole net needs")
    refused(write(tmp_path, SCENE + "[initial.nodes.root]\nvelocity = [1.0, 0.0, 0.0]\n", "r.toml"),
            r"\[initial\.nodes\.root\] velocity: node 'root' is fixed")
    # the hinge's third body axis (d3 = lab z) is locked
    refused(write(tmp_path, SCENE + "[initial.nodes.hinge]\nangular_velocity = [0.0, 0.0, 1.0]\n", "w.toml"),
            r"\[initial\.nodes\.hinge\] angular_velocity: it turns node 'hinge' about a locked")


def test_frames_closer_than_the_step_are_refused(tmp_path):
    text = SCENE.replace('dt = "auto"', "dt = 1e-5").replace("output_interval = 0.001", "output_interval = 1e-12")
    refused(write(tmp_path, text), r"\[run\] output_interval: 1e-12 s is shorter than dt = 1e-05 s")


def test_a_net_above_the_element_limit_is_refused_before_it_is_built(tmp_path):
    from cosnet.core.limits import MAX_ELEMENTS
    text = SCENE.replace("elements = 4", "elements = 100_000_000")
    msg = refused(write(tmp_path, text), r"\[lines\.bent\] elements: 100,000,0\d\d elements in the net "
                                         r"need about [\d.]+ GB of memory")
    assert f"{MAX_ELEMENTS:,} elements" in msg and "limits = false" in msg and "--no-limits" in msg


def test_a_name_with_a_line_break_stays_on_one_line(tmp_path):
    text = SCENE.replace("[materials.soft]", '[materials."so\\nft\\u2028"]').replace(
        'material = "soft"', 'material = "so\\nft\\u2028"').replace("poisson = 0.25", "poisson = 0.25\nmass = 1")
    refused(write(tmp_path, text), r'\[materials\."so\\nft\\u2028"\] mass: unknown key')


@pytest.mark.parametrize("old,new,match", [
    ("radius = 0.01", "radius = 1e300", r"\[sections\.rod\] radius: numbers out of range to compute with"),
    ("position = [1.0, 0.0, 0.0]\nmass = 0.5", "position = [1e300, -1e300, 0.0]\nmass = 0.5",
     r"\[lines\.arm\] end: the line's length overflows"),
])
def test_numbers_that_overflow_are_refused_naming_the_key(tmp_path, recwarn, old, new, match):
    refused(write(tmp_path, SCENE.replace(old, new)), match)
    assert not [w for w in recwarn if issubclass(w.category, RuntimeWarning)]
