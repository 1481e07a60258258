"""Effects as declarations (cosnet.engine.registry): a package of its own registers one through the
entry-point group cosnet.effects and a scene uses it (the example of docs/effects.md, run
here); energy and stability follow the bound record; the scene reference is what the
declarations generate; units are per key of each effect."""

import math
import sys
from pathlib import Path

import pytest

import cosnet
from cosnet.engine import registry
from cosnet.cli import main
from cosnet.scene.loader import build_scene, load_scene
from cosnet.scene.reference import REGENERATE, scene_reference
from cosnet.engine.simulation import stability_interval
from test_docs import fences

REPO = Path(__file__).resolve().parents[1]
PAGE = REPO / "docs" / "effects.md"


def install(root: Path, name: str, entry_points: dict, files: dict):
    """A distribution found by importlib.metadata: modules and a *.dist-info beside them in
    ``root``, which goes on sys.path (as pip would install it, without pip)."""
    for rel, text in files.items():
        (root / rel).write_text(text, encoding="utf-8")
    info = root / f"{name.replace('-', '_')}-0.1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {name}\nVersion: 0.1.0\n", encoding="utf-8")
    lines = "".join(f"{k} = {v}\n" for k, v in entry_points.items())
    (info / "entry_points.txt").write_text(f"[{registry.ENTRY_POINTS}]\n{lines}", encoding="utf-8")


@pytest.fixture
def on_path(tmp_path, monkeypatch):
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.chdir(tmp_path)
    yield tmp_path
    for mod in [m for m in sys.modules if m.startswith("cosnet_tether") or m.startswith("broken_")]:
        del sys.modules[mod]


def page_blocks():
    import tomllib
    blocks = fences(PAGE)
    assert [k for k, _ in blocks] == ["python", "toml", "toml", "python", "python"]
    module, project, scene, run, check = (code for _, code in blocks)
    return module, tomllib.loads(project), scene, run, check


def test_an_effect_of_another_package_works_in_a_scene_file(on_path, capsys):
    """docs/effects.md: the tether package, installed, is a scene kind; a body of 2 kg on
    k = 8 pi^2 N/m swings with a period of 1 s (x(t) = x0 cos 2 pi t to Verlet's (w dt)^2
    error), conserving energy; its stable step is the stepper's interval over sqrt(k / m)."""
    module, project, scene, run, check = page_blocks()
    install(on_path, project["project"]["name"], project["project"]["entry-points"][registry.ENTRY_POINTS],
            {"cosnet_tether.py": module})
    (on_path / "tether.toml").write_text(scene, encoding="utf-8")
    assert "tether" in registry.kinds()
    namespace = {}
    exec(compile(run, "docs/effects.md block 4", "exec"), namespace)
    sim = namespace["sim"]
    k, m, w = 8 * math.pi ** 2, 2.0, 2 * math.pi
    assert sim.time == pytest.approx(0.5, abs=1e-12)
    assert sim.state.node_x[0, 0] == pytest.approx(-0.1, rel=(w * sim.dt) ** 2)
    assert abs(sim.energy() / namespace["e0"] - 1) < (w * sim.dt) ** 2
    assert sim.stable_dt() == pytest.approx(0.9 * stability_interval("verlet") / math.sqrt(k / m), rel=1e-12)
    assert "x = -0.1" in capsys.readouterr().out
    effect = sim.effects[0]
    assert type(effect).__name__ == "Tether" and effect.stage == "load"

    # the bound record is what energy, stability and the kernel read: quadruple k
    e_before, dt_before = sim.energy_parts()["potential"], sim.stable_dt()
    sim.effect_params(effect).k[0] *= 4
    assert sim.energy_parts()["potential"] == pytest.approx(4 * e_before, rel=1e-12)
    assert sim.stable_dt() == pytest.approx(dt_before / 2, rel=1e-12)

    # the tether keeps the effect contract (cosnet.studies.effect_check), energy at order 2
    exec(compile(check, "docs/effects.md block 5", "exec"), namespace)
    report = namespace["report"]
    assert report.gradient_error < 1e-7 and report.checkpoint_exact and report.unrefused == [], report
    assert 1.9 < report.energy_order < 2.1, report


def test_a_broken_entry_point_is_one_line_naming_it(on_path, capsys):
    install(on_path, "broken-pkg", {"missing_kind": "broken_missing:Nothing", "not_effect": "broken_other:value"},
            {"broken_other.py": "value = 42\n"})
    data = {"nodes": {"a": {"position": [0, 0, 0], "mass": 1.0, "inertia": [1, 1, 1]}},
            "effects": [{"kind": "missing_kind"}], "run": {"until": 1.0, "dt": 0.1}}
    with pytest.raises(ValueError) as info:
        build_scene(data, "s.toml")
    msg = str(info.value)
    assert msg.startswith("s.toml: [[effects]] #1 kind: entry point missing_kind = 'broken_missing:Nothing' "
                          "of group cosnet.effects cannot be loaded (ModuleNotFoundError"), msg
    data["effects"][0]["kind"] = "not_effect"
    with pytest.raises(ValueError, match=r"entry point not_effect = 'broken_other:value' of group "
                                         r"cosnet.effects is not a cosnet Effect declaration \(got 42\)$"):
        build_scene(data, "s.toml")
    (on_path / "s.toml").write_text('[nodes.a]\nposition = [0, 0, 0]\nmass = 1.0\ninertia = [1, 1, 1]\n'
                                    '[[effects]]\nkind = "missing_kind"\n[run]\nuntil = 1.0\ndt = 0.1\n')
    assert main(["info", "s.toml"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "entry point missing_kind" in err


def test_unknown_kind_lists_the_declared_kinds():
    data = {"nodes": {"a": {"position": [0, 0, 0], "mass": 1.0, "inertia": [1, 1, 1]}},
            "effects": [{"kind": "magnetism"}], "run": {"until": 1.0}}
    with pytest.raises(ValueError, match=r"\[\[effects\]\] #1 kind: must be one of \['gravity', 'node_load', "
                                         r"'line_load', 'damping', 'drive', 'muscle_torque', 'active_curvature', "
                                         r"'contact', 'obstacle', 'spherical_joint', 'hinge_joint', "
                                         r"'fixed_joint', 'body'.*\], got 'magnetism'"):
        build_scene(data, "s.toml")


def test_stage_and_kernel_follow_from_the_registration():
    from cosnet.kernels import effects as K
    assert (cosnet.Damping.stage, cosnet.Damping.kernel) == ("flow", K.damp_velocities)
    assert (cosnet.Gravity.stage, cosnet.Gravity.kernel) == ("load", K.add_gravity)
    assert set(registry.builtin_effects().values()) == {getattr(cosnet, n) for n in (
        "Gravity", "NodeLoad", "LineLoad", "Damping", "Drive", "MuscleTorque", "ActiveCurvature", "Contact",
        "Obstacle", "SphericalJoint", "HingeJoint", "FixedJoint", "Body", "Fluid", "InternalDamping")}

    from typing import NamedTuple

    class Unregistered(NamedTuple):
        x: float

    with pytest.raises(TypeError, match="no kernel is registered for its record Unregistered"):
        type("Orphan", (cosnet.Effect,), {"kind": "orphan", "record": Unregistered})
    with pytest.raises(TypeError, match="key 'q' is not a parameter of Bad.__init__"):
        type("Bad", (cosnet.Gravity,), {"kind": "bad", "keys": (cosnet.Key("q", float),)})


def test_units_are_per_key_of_each_effect():
    """[scale] converts contact's k as N/m and a hinge's kt as N m/rad: the same letter k
    scales differently from kt, by the declared units."""
    from cosnet.core.units import ROTARY_STIFFNESS, STIFFNESS
    keys = {k.name: k.unit for k in cosnet.HingeJoint.keys}
    assert keys["k"] == STIFFNESS and keys["kt"] == ROTARY_STIFFNESS
    assert {k.name: k.unit for k in cosnet.Contact.keys}["k"] == STIFFNESS
    data = {"scale": {"time": 2.0, "length": 3.0, "area": 1e-4, "density": 1000.0},
            "nodes": {"a": {"position": [0, 0, 0], "fixed": True}, "b": {"position": [1, 0, 0]},
                      "c": {"position": [2, 0, 0]}},
            "materials": {"m": {"E": 1.0, "density": 1.0, "poisson": 0.3}},
            "lines": {"p": {"start": "a", "end": "b", "material": "m", "elements": 2,
                            "section": {"kind": "circle", "radius": 0.01}},
                      "q": {"start": "b", "end": "c", "material": "m", "elements": 2,
                            "section": {"kind": "circle", "radius": 0.01}}},
            "effects": [{"kind": "hinge_joint", "line_a": "p", "end_a": "end", "line_b": "q",
                         "end_b": "start", "k": 1.0, "kt": 1.0}, {"kind": "contact", "k": 1.0}],
            "run": {"until": 1.0}}
    scene = build_scene(data, "s.toml")
    u = scene.scale._units()   # (length, mass, time) in SI
    hinge, contact = scene.effects
    assert hinge.k == pytest.approx(u[1] / u[2] ** 2, rel=1e-12)
    assert hinge.kt == pytest.approx(u[0] ** 2 * u[1] / u[2] ** 2, rel=1e-12)
    assert contact.k == pytest.approx(hinge.k, rel=1e-12)


def test_built_in_energy_and_stability_read_the_bound_record():
    """Gravity's potential and a joint's stiffness bound follow edits of their records."""
    net = cosnet.Net()
    a0, a1, b0, b1 = (net.add_node(p) for p in ((0, 0, 0), (1, 0, 0), (1, 0, 0), (2, 0, 0)))
    kw = dict(material=cosnet.Material(E=1e7, density=1000.0, poisson=0.3), section=cosnet.Circle(0.01),
              elements=4)
    la, lb = net.add_line(a0, a1, **kw), net.add_line(b0, b1, **kw)
    g = cosnet.Gravity((0, 0, -9.81))
    joint = cosnet.SphericalJoint(la, "end", lb, "start", k=1e3)
    sim = cosnet.Simulation(net, effects=[g, joint])
    sim.state.x[:, 2] += 0.5
    pot, w2 = g.potential_energy(sim), joint.max_omega2(sim)
    sim.effect_params(g).g[2] *= 2
    sim.effect_params(joint).k[0] *= 3
    assert g.potential_energy(sim) == pytest.approx(2 * pot, rel=1e-12) and pot != 0
    assert g.energy_scale(sim) == pytest.approx(2 * cosnet.Gravity((0, 0, -9.81)).energy_scale(sim), rel=1e-12)
    assert joint.max_omega2(sim) == pytest.approx(3 * w2, rel=1e-12)


def test_binding_refuses_parts_of_another_net():
    other = cosnet.Net().add_node((0, 0, 0))
    net = cosnet.Net()
    a, b = net.add_node((0, 0, 0), fixed=True), net.add_node((1, 0, 0))
    net.add_line(a, b, material=cosnet.Material(E=1e7, density=1000.0, poisson=0.3), section=cosnet.Circle(0.01),
                 elements=2)
    with pytest.raises(ValueError, match=r"^NodeLoad: .* is not a node of this simulation's net$"):
        cosnet.Simulation(net, effects=[cosnet.NodeLoad(other, (1, 0, 0))])


def test_scene_reference_is_generated_from_the_declarations():
    page = (REPO / "docs" / "scene_reference.md").read_text(encoding="utf-8")
    assert page == scene_reference(), f"docs/scene_reference.md is stale; regenerate it: {REGENERATE}"
    for kind, cls in registry.builtin_effects().items():
        assert f"## `{kind}`" in page
        for key in cls.keys:
            assert f"| `{key.name}` |" in page
    assert "| `kt` | number > 0 | N m/rad | yes |" in page


def test_scene_reference_includes_an_effect_given_to_it(on_path):
    module, project, _, _, _ = page_blocks()
    install(on_path, "cosnet-tether", {"tether": "cosnet_tether:Tether"}, {"cosnet_tether.py": module})
    text = scene_reference({"tether": registry.effect_class("tether")})
    assert "## `tether`" in text and "| `k` | number > 0 | N/m | yes |" in text
    assert "| `anchor` | 3 numbers | m |  | [0, 0, 0] |" in text


def test_examples_of_the_page_load(tmp_path):
    """The scene of docs/effects.md is refused without the package, naming the kind."""
    _, _, scene, _, _ = page_blocks()
    (tmp_path / "t.toml").write_text(scene, encoding="utf-8")
    if "tether" in registry.kinds():
        pytest.skip("a tether package is installed in this environment")
    with pytest.raises(ValueError, match=r"\[\[effects\]\] #1 kind: must be one of .*got 'tether'"):
        load_scene(tmp_path / "t.toml")


def test_a_kernel_cache_naming_an_uninstalled_effect_still_loads(on_path):
    """The cache index of a kernel typed by effect records (a record's pin, a slot wrapper)
    names each record compiled for: after the package of one is gone, the index still loads
    (its entry is skipped) and other scenes run."""
    import pickle
    from numba.core import caching, types as nt
    from cosnet.kernels.compose import UnresolvedRecord
    (on_path / "broken_gone.py").write_text("from typing import NamedTuple\n\nclass Gone(NamedTuple):\n"
                                            "    x: float\n", encoding="utf-8")
    import broken_gone
    data = pickle.dumps({(nt.NamedUniTuple(nt.float64, 1, broken_gone.Gone),): "entry"})
    del sys.modules["broken_gone"]
    (on_path / "broken_gone.py").unlink()
    with pytest.raises(ModuleNotFoundError):
        pickle.loads(data)
    (key,), = caching.pickle.loads(data)
    assert key.instance_class is UnresolvedRecord
    pickle.loads(pickle.dumps(key))   # an index holding it can be saved again
