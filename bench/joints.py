"""Junctions that turn, side by side with welds and with penalty joints, in one process.

Cost: a hanging chain of LINKS steel links (5 elements each, 0.2 m; or 50 elements, 2 m: a
joint ten times sparser) whose junctions are welded, free hinges, ball joints, universal joints
(Cardan: about y in the node, z in the joint), ball joints with a spring, or hinges, universal
or ball joints with a spring, a damper and friction; every net stepped at the welded chain's
stable step, one thread, the median of five copies of each, timed in interleaved rounds
(harness.median_of_copies: a copy's step time depends on where its arrays lie). Each row also
gives the net's own stable step against the welded one's.

Rings: a stiff 100-element steel wire between two pins with 0, 1, 10 or 50 rings of 1 kg
sliding on it with friction, each pulled down by a node load, in air and in water (the wire
carrying its added mass across itself); the cost per step and per ring.

Accuracy (python bench/accuracy.py --joints runs it, from double_pendulum, rigid_limit and
accuracy here): a double compound pendulum of two 1 m steel arms (r = 10 mm, 10 elements each)
on a fixed pivot, released from the horizontal, against the rigid-body limit of the same arms
(their vertex masses and rotary inertias; Lagrange's equations by scipy's solve_ivp, rtol
1e-12): the largest distance between the two free ends over 0.5 s, relative to the arms'
length, and the wall time of the run. The middle junction is an exact hinge, or the arms' ends
on nodes of their own held by a penalty HingeJoint (after the Elastica page) of spring k and
torque spring kt = k (1 m)^2, each at its own stable step. Run: python bench/joints.py
[--quick]; writes bench/joints.json (docs/performance.md shows its tables).
"""

import math
import sys
import time

import numpy as np
from scipy.integrate import solve_ivp

import cosnet
from harness import best_interleaved, median_of_copies, table, write_json

STEEL = cosnet.Material(E=2.1e11, poisson=0.3, density=7850.0)
G = 9.81
Y = (0.0, 1.0, 0.0)
# copies of each chain whose median a row takes: with three, a row of the chain of 20 links of 50
# elements moved by ten points from run to run where its joints cost a few
COPIES = 5

JOINTS = {
    "welded": lambda: None,
    "free hinges": lambda: cosnet.Hinge(axis=Y),
    "ball joints": lambda: cosnet.Ball(),
    "universal joints": lambda: cosnet.Universal(axes=(Y, (0.0, 0.0, 1.0))),
    "ball joints with spring": lambda: cosnet.Ball(stiffness=10.0),
    "hinges with spring, damper, friction": lambda: cosnet.Hinge(axis=Y, stiffness=10.0, damping=0.01,
                                                                 friction=(0.5, 0.4)),
    "universal joints with spring, damper, friction": lambda: cosnet.Universal(
        axes=(Y, (0.0, 0.0, 1.0)), stiffness=10.0, damping=0.01, friction=(0.5, 0.4)),
    "ball joints with spring, damper, friction": lambda: cosnet.Ball(stiffness=10.0, damping=0.01,
                                                                     friction=(0.5, 0.4)),
}


def chain(links, joint, elements=5):
    """A chain of links along x from a fixed pivot, each link's start on ``joint()``; each link
    0.2 m long in 5 elements, or 0.04 m an element in as many as given."""
    net = cosnet.Net()
    nodes = [net.add_node((0.0, 0.0, 0.0), fixed=True)]
    for i in range(links):
        nodes.append(net.add_node((0.04 * elements * (i + 1), 0.0, 0.0)))
        net.add_line(nodes[i], nodes[i + 1], material=STEEL, section=cosnet.Circle(0.01), elements=elements,
                     start_joint=joint())
    return net


def cost(links, rounds, elements=5):
    welded = cosnet.Simulation(chain(links, JOINTS["welded"], elements), [cosnet.Gravity()], threads=1)
    steps = max(500, 1_500_000 // (links * elements))

    def build(make):   # each copy a simulation of its own (harness.median_of_copies)
        sim = cosnet.Simulation(chain(links, make, elements), [cosnet.Gravity()], dt=welded.dt, force_dt=True,
                                threads=1)
        return lambda: sim.run(steps=steps)
    sims = {name: cosnet.Simulation(chain(links, make, elements), [cosnet.Gravity()], threads=1)
            for name, make in JOINTS.items()}   # (each kind's own stable step)
    times = median_of_copies([lambda make=make: build(make) for make in JOINTS.values()], COPIES, rounds)
    base = times[0] / steps
    out = []
    for (name, sim), t in zip(sims.items(), times):
        out.append({"links": links, "elements_per_link": elements, "junctions": name, "us_per_step": 1e6 * t / steps,
                    "over_weld_percent": 100.0 * (t / steps / base - 1.0),
                    "us_per_joint": 1e6 * (t / steps - base) / links,
                    "stable_dt_over_weld": sim.stable_dt() / welded.stable_dt()})
    return out


def wire_with_rings(rings, dt=None, water=False):
    """A stiff 100-element wire between two pins, loaded by ``rings`` rings of 1 kg spread
    along it (a node load each), sliding; returns the simulation (at step dt if given). In
    ``water``, the wire carries the added mass of a cylinder across itself (no drag, no
    upthrust: the rings' own share of the cost is what differs)."""
    net = cosnet.Net()
    a, b = net.add_node((0.0, 0.0, 0.0), fixed=True), net.add_node((10.0, 0.0, 1.0), fixed=True)
    wire = net.add_line(a, b, material=STEEL, section=cosnet.Circle(0.01), elements=100)
    loads = [cosnet.NodeLoad(b, force=(0.0, 0.0, 0.0))]
    for k in range(rings):
        ring = net.add_ring(wire, s=wire.length * (k + 0.5) / rings, mass=1.0, mu_s=0.1, mu_k=0.05)
        loads.append(cosnet.NodeLoad(ring, force=(0.0, 0.0, -G)))
    fluid = [cosnet.Fluid(1025.0, drag=(0.0, 0.0), added_mass=(1.0, 0.0), buoyancy=False)] if water else []
    return cosnet.Simulation(net, fluid + loads, threads=1, dt=dt, force_dt=dt is not None)


def ring_cost(counts, rounds):
    """us per step of the wire with each number of rings, dry and in water (the rings then move
    the wire by the inverse mass tensors the added mass makes), at the bare dry wire's step."""
    bare = wire_with_rings(0)
    runs = [(water, n) for water in (False, True) for n in (0, *counts)]
    sims = [bare if (water, n) == (False, 0) else wire_with_rings(n, bare.dt, water) for water, n in runs]
    steps = 20_000
    times = best_interleaved([lambda s=s: s.run(steps=steps) for s in sims], rounds)
    base = {water: t / steps for (water, n), t in zip(runs, times) if n == 0}
    return [{"medium": "water" if water else "air", "rings": n, "us_per_step": 1e6 * t / steps,
             "us_per_ring": 0.0 if n == 0 else 1e6 * (t / steps - base[water]) / n}
            for (water, n), t in zip(runs, times)]


def double_pendulum(middle, k=0.0):
    """Two 1 m arms from a fixed pivot along x; the middle junction 'hinge' (exact) or
    'penalty' (HingeJoint of spring k). Returns (sim, tip node)."""
    net = cosnet.Net()
    pivot = net.add_node((0.0, 0.0, 0.0), fixed=True)
    knee = net.add_node((1.0, 0.0, 0.0))
    tip = net.add_node((2.0, 0.0, 0.0))
    sec = cosnet.Circle(0.01)
    arm1 = net.add_line(pivot, knee, material=STEEL, section=sec, elements=10, start_joint=cosnet.Hinge(axis=Y))
    effects = [cosnet.Gravity()]
    if middle == "hinge":
        net.add_line(knee, tip, material=STEEL, section=sec, elements=10, start_joint=cosnet.Hinge(axis=Y))
    else:
        knee2 = net.add_node((1.0, 0.0, 0.0))
        arm2 = net.add_line(knee2, tip, material=STEEL, section=sec, elements=10)
        effects.append(cosnet.HingeJoint(arm1, "end", arm2, "start", k=k, kt=k, normal=(0.0, 1.0, 0.0)))
    return cosnet.Simulation(net, effects, threads=1), tip


def rigid_limit(sim, until):
    """The free end's path (function of t) of the two arms as rigid bodies with the masses
    and rotary inertias of the discrete arms, both released from the horizontal."""
    m, x = sim.model, sim.state.x
    bodies = []
    for line in range(2):
        v = slice(m.line_vertex_offsets[line], m.line_vertex_offsets[line + 1])
        e = slice(m.line_element_offsets[line], m.line_element_offsets[line + 1])
        s = np.abs(x[v, 0] - x[v, 0].min())
        mv = m.vertex_mass[v]
        bodies.append((mv.sum(), (mv * s).sum(), (mv * s * s).sum() + m.element_inertia[e, 0].sum()))
    (m1, mc1, i1), (m2, mc2, i2) = bodies
    length = 1.0

    def rhs(_, y):
        t1, t2, w1, w2 = y
        c, s = math.cos(t1 - t2), math.sin(t1 - t2)
        a = np.array([[i1 + m2 * length ** 2, mc2 * length * c], [mc2 * length * c, i2]])
        b = np.array([-mc2 * length * s * w2 ** 2 - (mc1 + m2 * length) * G * math.sin(t1),
                      mc2 * length * s * w1 ** 2 - mc2 * G * math.sin(t2)])
        return [w1, w2, *np.linalg.solve(a, b)]

    sol = solve_ivp(rhs, (0.0, until), [math.pi / 2, math.pi / 2, 0.0, 0.0], rtol=1e-12, atol=1e-12,
                    dense_output=True)

    def tip(t):
        t1, t2 = sol.sol(t)[:2]
        return np.array([length * (math.sin(t1) + math.sin(t2)), 0.0, -length * (math.cos(t1) + math.cos(t2))])
    return tip


def accuracy(until, samples, stiffness):
    rows = []
    for middle, k in [("hinge", 0.0)] + [("penalty", k) for k in stiffness]:
        sim, tip = double_pendulum(middle, k)
        reference = rigid_limit(sim, until)
        sim.run(steps=1)   # compiled before the clock starts
        sim, tip = double_pendulum(middle, k)
        worst, wall = 0.0, 0.0
        for t in np.linspace(until / samples, until, samples):
            start = time.perf_counter()
            sim.run(until=t)
            wall += time.perf_counter() - start
            worst = max(worst, float(np.linalg.norm(sim.node_position(tip) - reference(sim.time))))
        rows.append({"middle": "exact hinge" if middle == "hinge" else f"penalty HingeJoint k = {k:.0e}",
                     "k": k, "dt": sim.dt, "steps": sim.steps, "error_over_length": worst / 2.0,
                     "wall_s": wall})
    return rows


def main():
    quick = "--quick" in sys.argv
    chains, rounds = (((10, 5),), 3) if quick else (((10, 5), (100, 5), (20, 50)), 9)
    runs = [r for n, e in chains for r in cost(n, rounds, e)]
    table("joints: cost per step of a hanging chain, at the welded chain's step (one thread)",
          ["links", "elements per link", "junctions", "us/step", "over weld %", "us per joint",
           "own stable dt / weld's"],
          [[r["links"], r["elements_per_link"], r["junctions"], r["us_per_step"], r["over_weld_percent"],
            r["us_per_joint"], r["stable_dt_over_weld"]]
           for r in runs])
    rings = ring_cost((1, 10) if quick else (1, 10, 50), rounds)
    table("joints: cost per step of rings sliding on a 100-element wire (one thread, the bare wire's step)",
          ["medium", "rings", "us/step", "us per ring"],
          [[r["medium"], r["rings"], r["us_per_step"], r["us_per_ring"]] for r in rings])
    write_json(__file__, {"command": " ".join(["python", "bench/joints.py", *sys.argv[1:]]),
                          "cost": runs, "rings": rings})


if __name__ == "__main__":
    main()
