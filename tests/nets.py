"""Small nets shared by the tests (kept tiny so the suite stays fast)."""

import numpy as np

import cosnet
from cosnet.core.samples import cantilever_scene, free_net, smooth_motion  # noqa: F401  (the tests' nets)

# the tables after the line of the sweep tests' cantilever: its perturbation V and end time T vary
SWEEP_REST = """[[effects]]
kind = "gravity"
g = [0.0, 0.0, -9.81]
[initial.perturbation]
velocity = {V}
seed = 7
[run]
until = {T}
output_interval = 0.004
probes = ["tip", "rod@0.5"]
"""
STEEL = cosnet.Material(E=2.1e11, G=8.1e10, density=7850.0, name="steel")


# A soft rod clamped at one end with a small mass at its tip, as a scene file; fill in the
# title, stiffness, element count and the tables after the line (effects, initial, run).
ROD_SCENE = "\n" + cantilever_scene("{title}", E="{E}", G="{G}", density="1000.0", elements="{elements}",
                                    material="soft", tip="mass = 0.05\ninertia = [1e-6, 1e-6, 1e-6]\n",
                                    rest="{rest}")


def cantilever(n=20, length=1.0, radius=0.01, material=STEEL, axis=(1.0, 0.0, 0.0), tip_mass=0.0):
    """A rod clamped at the origin along ``axis``; returns (net, line, root, tip)."""
    net = cosnet.Net()
    root = net.add_node((0.0, 0.0, 0.0), fixed=True, name="root")
    tip = net.add_node(length * np.asarray(axis, dtype=float), mass=tip_mass, name="tip")
    line = net.add_line(root, tip, material=material, section=cosnet.Circle(radius), elements=n, name="rod")
    return net, line, root, tip


def perturb(sim, rng, scale_v=0.3, scale_w=3.0):
    """Give every vertex, element and node a random velocity/angular velocity."""
    s = sim.state
    s.v[:] = scale_v * rng.standard_normal(s.v.shape)
    s.w[:] = scale_w * rng.standard_normal(s.w.shape)
    s.node_v[:] = scale_v * rng.standard_normal(s.node_v.shape)
    s.node_w[:] = scale_w * rng.standard_normal(s.node_w.shape) * (sim.model.node_locked == 0)


def write_sweep_scene(path, E="2.1e11", V="0.0", T="0.012"):
    """The tiny cantilever of the sweep tests (4 elements, a few hundred steps) at ``path``."""
    path.write_text(cantilever_scene("tiny cantilever", E=E, rest=SWEEP_REST.format(V=V, T=T)))
    return path


def written_run(directory, scene: str):
    """The output directory of `cosnet run` on ``scene`` (TOML text) written in ``directory``."""
    from cosnet.cli import main
    (directory / "scene.toml").write_text(scene)
    assert main(["run", str(directory / "scene.toml"), "--out", str(directory / "out")]) == 0
    return directory / "out"


def resumed(build, path, first: int, then: int):
    """(unbroken, resumed): what build() returns (a Simulation, or a tuple led by one) run
    ``first`` steps, checkpointed at ``path`` and run ``then`` more; and a second build()
    loaded from that checkpoint and run ``then`` steps. A checkpoint that carries everything
    the step reads leaves the two equal bit for bit."""
    def sim_of(built):
        return built[0] if isinstance(built, tuple) else built
    unbroken = build()
    sim_of(unbroken).run(steps=first)
    sim_of(unbroken).save_checkpoint(path)
    sim_of(unbroken).run(steps=then)
    again = build()
    sim_of(again).load_checkpoint(path)
    sim_of(again).run(steps=then)
    return unbroken, again


def balance_drift(sim, until: float, steps: int) -> float:
    """The largest |balance - its start| of ``sim`` run to ``until`` in runs of ``steps``
    (sim.balance(): energy and every account, constant but for the scheme's error)."""
    start, worst = sim.balance(), 0.0
    while sim.time < until:
        sim.run(steps=steps)
        worst = max(worst, abs(sim.balance() - start))
    return worst
