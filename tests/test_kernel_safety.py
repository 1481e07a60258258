"""Kernels never read or write out of bounds: non-finite or huge coordinates in the contact
broad phase (once a crash with ``double free or corruption``), the CLI at an unstable forced
step, and the debug mode COSNET_BOUNDSCHECK=1 running short scenes with numba's bounds
checks on. Whatever could crash runs in a subprocess, so that a crash fails the test
instead of killing pytest."""

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

# Two free rods crossing at right angles, overlapping and closing along y, and a third rod
# near them but apart (its coordinates are the ones spoilt); shared by the scripts below.
RODS = """
import json, sys
import numpy as np
import cosnet
from cosnet.kernels.contact import add_contact, build_grid
from cosnet.kernels.layout import empty_loads

M = cosnet.Material(E=1e9, G=4e8, density=1000.0, name="stiff")

def rods(third=True, gravity=False):
    net = cosnet.Net()
    a0, a1 = net.add_node((-0.1, -0.009, 0)), net.add_node((0.1, -0.009, 0))
    b0, b1 = net.add_node((0, 0.009, -0.1)), net.add_node((0, 0.009, 0.1))
    la = net.add_line(a0, a1, material=M, section=cosnet.Circle(0.01), elements=4, name="a")
    lb = net.add_line(b0, b1, material=M, section=cosnet.Circle(0.01), elements=4, name="b")
    lines = [la, lb]
    if third:
        c0, c1 = net.add_node((-0.05, 0.06, 0.0)), net.add_node((0.05, 0.06, 0.0))
        lines.append(net.add_line(c0, c1, material=M, section=cosnet.Circle(0.01), elements=4, name="c"))
    contact = cosnet.Contact(k=1e3)
    sim = cosnet.Simulation(net, effects=[cosnet.Gravity(), contact] if gravity else [contact])
    for line, vy in ((la, 0.5), (lb, -0.5)):
        sim.line_velocities(line)[:] = (0.0, vy, 0.0)
        for nd in (line.start, line.end):
            sim.node_velocity(nd)[:] = (0.0, vy, 0.0)
    return sim, contact, lines

def contact_forces(sim, contact):
    loads = empty_loads(sim.model)
    add_contact(contact.params(sim), sim.model, sim.state, loads)
    return loads.f
"""

SPOIL = RODS + """
value = float(sys.argv[1])
out = {}
sim, contact, (la, lb, lc) = rods()
clean = contact_forces(sim, contact).copy()
out["clean_grid"] = list(build_grid(contact.params(sim), sim.state.x))
sim.line_positions(lc)[2, 0] = value   # an interior vertex: its two elements' midpoints
p = contact.params(sim)
out["grid"] = list(build_grid(p, sim.state.x))
start = p.bucket_start
out["csr"] = bool(start[0] == 0 and np.all(np.diff(start) >= 0) and start[-1] == p.elements.size)
out["permutation"] = sorted(p.sorted_elem.tolist()) == sorted(p.elements.tolist())
f = contact_forces(sim, contact)
rows = np.r_[sim.vertex_range(la), sim.vertex_range(lb)]
out["touching"] = bool(np.abs(clean[rows]).max() > 0)
out["same_forces"] = bool(np.allclose(f[rows], clean[rows], rtol=1e-12, atol=0.0))
out["runs"] = []
for i in range(3):
    try:
        sim.run(steps=1)
        out["runs"].append("ok")
    except cosnet.InstabilityError as e:
        out["runs"].append(str(e))
print(json.dumps(out))
"""


def run_script(code, *args, env=None, timeout=900):
    return subprocess.run([sys.executable, "-c", code, *map(str, args)], capture_output=True, text=True,
                          cwd=ROOT, env=env, timeout=timeout)


@pytest.mark.parametrize("value", ["nan", "inf", "-inf", "1e300"])
def test_spoilt_coordinates_stay_in_bounds(value):
    """A NaN, infinite or huge coordinate (the grid then hashes, or parks the segment) still
    sorts every segment exactly once into a valid CSR table, leaves the contact forces of the
    rods that touch unchanged (the spoilt segments meet nothing), and every later run() raises
    InstabilityError or runs on: the process exits cleanly (it used to die with 134 or 139)."""
    r = run_script(SPOIL, value)
    assert r.returncode == 0, r.stderr[-2000:]
    out = json.loads(r.stdout.strip().splitlines()[-1])
    assert out["csr"] and out["permutation"] and out["touching"] and out["same_forces"], out
    # NaN midpoints stay out of the bounding box: the dense grid of the others (where a NaN
    # once got bucket -1); an infinite box is hashed; a huge segment makes one huge cell
    expect = {"nan": out["clean_grid"], "inf": [0, 0, 0], "-inf": [0, 0, 0], "1e300": [1, 1, 1]}[value]
    assert out["clean_grid"] != [0, 0, 0] and out["grid"] == expect, out
    first = out["runs"][0]
    assert first.startswith("unstable at t = ")
    if value == "1e300":
        assert "strain" in first  # finite: the watch's strain check catches it
    else:
        assert all("non-finite position at line 'c'" in msg for msg in out["runs"]), out["runs"]


def test_cli_unstable_forced_step_exits_3_in_one_line(tmp_path):
    """cases/contact.toml at a forced unstable step: exit 3 and one line naming the
    instability (was: the message, then ``double free or corruption``, exit 134)."""
    text = (ROOT / "cases" / "contact.toml").read_text()
    text = text.replace("until = 0.3\n", "until = 0.02\ndt = 3.35e-05\nforce_dt = true\n")
    assert "force_dt = true" in text
    scene = tmp_path / "contact_unstable.toml"
    scene.write_text(text)
    r = subprocess.run([sys.executable, "-m", "cosnet.cli", "run", str(scene), "--out", str(tmp_path / "out")],
                       capture_output=True, text=True, cwd=ROOT, timeout=900)
    assert r.returncode == 3, r.stderr[-2000:]
    # the header and the progress line come first; the error is the one last line
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    errors = [ln for ln in lines if "error" in ln or "free" in ln or "Traceback" in ln]
    assert errors == lines[-1:] and lines[-1].startswith("cosnet: error: unstable at t = "), r.stderr[-2000:]


DEBUG = RODS + """
from cosnet.kernels import contact as kc, motion
from cosnet.kernels.stepping import advance_verlet
assert kc.sweep.targetoptions["boundscheck"] and advance_verlet.targetoptions["boundscheck"]
out = {"cache": add_contact._cache._cache_path}

# the checks are live: a line end attached to a vertex past the end of the state
sim, contact, _ = rods(third=False, gravity=True)
bad = sim.model._replace(attach_vertex=sim.model.attach_vertex + sim.state.x.shape[0])
try:
    motion.place_line_ends(bad, sim.state)
    out["caught"] = False
except IndexError:
    out["caught"] = True

# an elastic bounce (undamped contact) under gravity conserves energy
e0 = sim.energy()
sim.run(until=0.03)
out["touched"] = contact.narrow_tests(sim) > 0
out["contact_drift"] = abs(sim.energy() - e0) / e0
print(json.dumps(out))
"""


@pytest.mark.own_cache
def test_boundscheck_mode_runs_scenes_with_checked_kernels(tmp_path):
    """COSNET_BOUNDSCHECK=1 compiles every kernel with numba's bounds checks, cached apart
    from the normal builds: an index past the end raises IndexError instead of writing, a
    short elastic bounce of two rods (gravity and contact, as the case below) runs with the
    energy conserved, and the command of docs/safety.md runs the contact case in this mode
    (its step the bounce's, loaded from the checked cache: each step variant compiled with
    checks costs minutes, so the test compiles one)."""
    env = dict(os.environ, COSNET_BOUNDSCHECK="1")
    r = run_script(DEBUG, env=env)
    assert r.returncode == 0, r.stderr[-3000:]
    out = json.loads(r.stdout.strip().splitlines()[-1])
    assert "-boundscheck" in out["cache"] and out["caught"] and out["touched"], out
    assert out["contact_drift"] < 1e-4, out

    doc = (ROOT / "docs" / "safety.md").read_text()
    blocks = re.findall(r"```sh\n(.*?)```", doc, re.S)
    assert len(blocks) == 1 and blocks[0].startswith("COSNET_BOUNDSCHECK=1 cosnet run ")
    path = os.pathsep.join([str(Path(sys.executable).parent), os.environ.get("PATH", "")])
    r = subprocess.run(["bash", "-c", blocks[0]], capture_output=True, text=True, cwd=tmp_path,
                       env=dict(os.environ, PATH=path), timeout=900)
    last = r.stderr.rstrip().splitlines()[-1]   # "done: N frames in DIR" (and what compiling took)
    assert r.returncode == 0 and re.fullmatch(r"done: 3 frames in checked-run( \(compiling \d+ kernels took \d+ s\))?",
                                              last), r.stderr[-2000:]
    assert (tmp_path / "checked-run" / "series.pvd").exists()


def small_sim():
    """Two rods joined end to end by a hinge, a node load and a line load, gravity and contact."""
    import cosnet
    steel = cosnet.Material(E=2.1e11, G=8.1e10, density=7850.0, name="steel")
    net = cosnet.Net()
    n0, n1, n2, n3 = (net.add_node((0.2 * ((i + 1) // 2), 0.0, 0.0)) for i in range(4))
    a = net.add_line(n0, n1, material=steel, section=cosnet.Circle(0.01), elements=3, name="a")
    b = net.add_line(n2, n3, material=steel, section=cosnet.Circle(0.01), elements=3, name="b")
    effects = [cosnet.Gravity(), cosnet.HingeJoint(a, "end", b, "start", k=1e5, kt=1.0),
               cosnet.NodeLoad(n3, force=(0.0, 1.0, 0.0)), cosnet.LineLoad(a, force_per_length=(0.0, 0.0, 1.0)),
               cosnet.Contact(k=1e3)]
    return cosnet.Simulation(net, effects)


SPOILS = {
    "model.attach_node holds 7, outside [0, 4)": lambda s: s.model.attach_node.__setitem__(1, 7),
    "model.node_attach_list holds -1": lambda s: s.model.node_attach_list.__setitem__(0, -1),
    "model.line_vertex_offsets is not an offset table": lambda s: s.model.line_vertex_offsets.__setitem__(1, 9),
    "model: every line needs": lambda s: s.model.line_element_offsets.__setitem__(1, 2),
    "model: attach_vertex": lambda s: s.model.attach_vertex.__setitem__(1, 0),
    "HingeJointParams.attach_b holds 4, outside [0, 4)": lambda s: s.records[1].attach_b.__setitem__(0, 4),
    "node load.nodes holds 4, outside [0, 4)": lambda s: s.records[2].nodes.__setitem__(0, 4),
    "line load.lines holds -3": lambda s: s.records[3].lines.__setitem__(0, -3),
    "contact.elements holds 6, outside [0, 6)": lambda s: s.records[4].elements.__setitem__(0, 6),
    "contact.elem_index does not name": lambda s: s.records[4].elem_index.__setitem__((5, 0), 7),
    "contact.elem_index (line) holds 2": lambda s: s.records[4].elem_index.__setitem__((5, 1), 2),
    "state.x has shape (3, 3), the net needs 8 rows":
        lambda s: setattr(s, "state", s.state._replace(x=s.state.x[:3])),
}


def test_index_tables_are_checked_before_a_run():
    """The tables the kernels index by unchecked are valid as built, and a spoilt one (a user
    can reach them all) stops run() with one line naming the table, before any kernel runs."""
    from cosnet.engine.bounds import table_error
    sim = small_sim()
    assert table_error(sim.model, sim.state, sim.loads, sim.records, [type(e) for e in sim.effects]) is None
    for message, spoil in SPOILS.items():
        sim = small_sim()
        spoil(sim)
        with pytest.raises(ValueError) as error:
            sim.run(steps=1)
        assert str(error.value).startswith("Simulation.run: " + message) and sim.steps == 0, str(error.value)
