"""cosnet as a cosseratbench solver (cosseratbench 0.3.0, ``cosseratbench.solver.Solver``),
registered under the entry point ``cosseratbench.solvers`` as ``cosnet``: with both installed,
``cosseratbench run twist -s cosnet`` runs it (bench/cosseratbench_run.py sets it beside
PyElastica's).

Each scenario rod becomes one cosnet line between two nodes: a clamped end is a fixed node
(position and rotation held), a pinned end a node of infinite mass with free rotation, a free
end a point junction (mass 0). The line is built unstretched and straight in its rest state,
as the scenario says (``rest_curvature = 0``; rest lengths length / n, like the PyElastica
adapter), and then moved to where the scenario starts it: its vertices to
``Rod.nodes(n)`` (which may be stretched, as in the pendulum), its free end node with them.
A driven clamp (``Rod.start_motion`` / ``end_motion``) is a node of the line's own end mass under
a cosnet Drive: its rotation vectors must all lie along one fixed axis (the slide axis when the
end slides, a motor shaft); the angle about it and the displacement follow cosnet Paths,
clamped cubic splines through the motion's samples (the scenario interpolates them linearly,
and asks for smooth motions sampled finely enough for that not to matter). A clamp moved by
a translation only (as the pile's) has its motion sampled every SAMPLE s first, so the spline
follows the scenario's piecewise-linear path, and its rotation held. Point loads are
NodeLoads on the end node, gravity is Gravity, and a quasi-static scenario gets
mass-proportional Damping at twice its slowest frequency (the PyElastica adapter's
choice). Rods touch each other (and themselves, when the scenario says they can reach
themselves) through cosnet's Contact: capsules of the rod radius (frictionless unless the
rods have friction, below), with a penalty as stiff as the step allows without shortening
it -- a contact vibration of the lightest vertex no faster than 0.5 / dt, the PyElastica
adapter's rule -- and half-critical damping. The time step is cosnet's estimated stable step
for position Verlet, shortened so a whole number of steps fits between frames.

Obstacles and friction (``_obstacles``): a Cylinder is a capsule Obstacle of its length (its
rounded ends lie beyond the rods' reach), a Plane a plane Obstacle; both with cosnet's
Coulomb friction that sticks (a tangential spring per touching vertex, as stiff as the
normal penalty), the larger of the obstacle's and the rod's coefficient, static and kinetic
alike (the scenarios give one). Rods with friction touch each other through Contact with
friction between lines (a spring per touching pair of elements). The penalties follow the
rod-rod rule above.

Outside this adapter (the run is then reported as unsupported): a driven clamp turned about a
changing axis.
"""

from __future__ import annotations

import math
from typing import Any
from importlib.metadata import version

import numpy as np
from cosseratbench.scenario import Cylinder, End, EndCondition, Motion, Plane, Scenario
from cosseratbench.solver import Capability, Diverged
from cosseratbench.trajectory import Trajectory

import cosnet
from cosnet.effects.contact import Contact
from cosnet.effects.drives import Drive
from cosnet.effects.loads import Damping, Gravity, NodeLoad
from cosnet.effects.obstacles import Obstacle

SAMPLE = 0.05  # s between the samples of a clamp's motion by a translation only


class CosnetSolver:
    name = "cosnet"
    backend_version = version("cosnet")
    capabilities = frozenset({Capability.STRETCH, Capability.SHEAR, Capability.ROD_CONTACT,
                              Capability.ROD_FRICTION, Capability.CYLINDER_CONTACT, Capability.PLANE_CONTACT})

    def __init__(self, time_step_scale: float = 1.0, stepper: str = "verlet") -> None:
        if not 0 < time_step_scale <= 1:
            raise ValueError(f"time_step_scale must be in (0, 1], got {time_step_scale}")
        self.time_step_scale = float(time_step_scale)
        self.stepper = stepper

    # ------------------------------------------------------------------ building
    @staticmethod
    def _drive(node, motion: Motion):
        """A cosnet Drive following ``motion`` (rotation vectors along one fixed axis)."""
        turn = np.asarray(motion.rotation, dtype=float)
        if motion.slides_along is not None:
            axis = motion.axis
        else:
            biggest = turn[np.argmax(np.linalg.norm(turn, axis=1))]
            size = np.linalg.norm(biggest)
            axis = biggest / size if size > 0 else np.array([1.0, 0.0, 0.0])
        angle = turn @ axis
        if np.any(np.linalg.norm(turn - np.outer(angle, axis), axis=1) > 1e-12 * (1.0 + np.abs(angle))):
            raise NotImplementedError("cosnet drives turn a node about a fixed axis only")
        times = np.asarray(motion.times, dtype=float)
        moved = np.asarray(motion.displacement, dtype=float)
        if not np.any(turn) and motion.slides_along is None:
            # a translation only: the scenario's piecewise-linear path, sampled finely
            t = np.unique(np.concatenate([times, np.arange(0.0, times[-1], SAMPLE)]))
            moved = np.stack([np.interp(t, times, moved[:, k]) for k in range(3)], axis=1)
            times, angle = t, np.zeros(t.shape)
        return Drive(node, position=cosnet.Path(times=times, values=moved) if np.any(moved) else None,
                     rotation=cosnet.Path(times=times, values=angle), axis=axis,
                     slide=motion.slides_along is not None)

    @staticmethod
    def _node(net, position, condition: EndCondition, name: str, driven: bool = False):
        if driven:      # a drive holds it: the node carries the line end's own mass
            return net.add_node(position, name=name)
        if condition is EndCondition.CLAMPED:
            return net.add_node(position, fixed=True, name=name)
        if condition is EndCondition.PINNED:
            return net.add_node(position, mass=math.inf, name=name)
        return net.add_node(position, name=name)

    def _build(self, scenario: Scenario, n_elements: int):
        net = cosnet.Net()
        placed, effects = [], []
        for i, rod in enumerate(scenario.rods):
            nodes = rod.nodes(n_elements)
            t = np.diff(nodes, axis=0)
            t /= np.linalg.norm(t, axis=1, keepdims=True)
            rest = nodes[0] + np.concatenate(([np.zeros(3)],
                                              np.cumsum(t * rod.length / n_elements, axis=0)))
            a = self._node(net, rest[0], rod.start, f"rod{i}_start", rod.start_motion is not None)
            b = self._node(net, rest[-1], rod.end, f"rod{i}_end", rod.end_motion is not None)
            m = rod.material
            line = net.add_line(a, b, material=cosnet.Material(E=m.youngs_modulus, G=m.shear_modulus,
                                                               density=m.density),
                                section=cosnet.Circle(rod.radius), elements=n_elements,
                                points=rest, rest_curvature=(0.0, 0.0, 0.0), d1=rod.normal,
                                name=f"rod{i}")
            placed.append((line, b, nodes))
            for node, motion in ((a, rod.start_motion), (b, rod.end_motion)):
                if motion is not None:
                    effects.append(self._drive(node, motion))
            for load in rod.loads:
                effects.append(NodeLoad(a if load.at is End.START else b, force=load.force))
        if any(scenario.gravity):
            effects.append(Gravity(scenario.gravity))
        if scenario.quasi_static:
            effects.append(Damping(2.0 * scenario.slowest_frequency()))
        if len(scenario.rods) > 1 or scenario.self_contact or scenario.obstacles:
            k, gamma = self._penalty(net, effects)
            if len(scenario.rods) > 1 or scenario.self_contact:
                effects.append(self._contact(scenario, k, gamma))
            effects.extend(self._obstacles(scenario, k, gamma))
        return net, placed, effects

    def _penalty(self, net, effects) -> tuple[float, float]:
        """(k, gamma): a penalty that leaves the stable step as it is, half-critically damped."""
        sim = cosnet.Simulation(net, effects=effects, stepper=self.stepper)
        mass = sim.model.vertex_mass
        lightest = float(mass[np.isfinite(mass) & (mass > 0)].min())
        omega = 0.5 / sim.stable_dt()
        k = lightest * omega**2
        return k, math.sqrt(k * lightest)

    @staticmethod
    def _contact(scenario: Scenario, k: float, gamma: float):
        """Rod-rod contact, with friction between rods when theirs is given."""
        mu = max(rod.friction for rod in scenario.rods)
        friction: dict[str, Any] = {"mu_s": mu, "mu_k": mu, "pairs_per_element": 8} if mu > 0 else {}
        return Contact(k=k, gamma=gamma, self_contact=scenario.self_contact, **friction)

    @staticmethod
    def _obstacles(scenario: Scenario, k: float, gamma: float) -> list:
        """An Obstacle for each of the scenario's: a Cylinder a capsule of its length, a Plane
        a plane; Coulomb friction the larger of the obstacle's and the rods' coefficient."""
        out = []
        rod_mu = max((rod.friction for rod in scenario.rods), default=0.0)
        for i, ob in enumerate(scenario.obstacles):
            mu = max(ob.friction, rod_mu)
            common: dict[str, Any] = dict(k=k, gamma=gamma, name=f"{ob.kind}{i}",
                                          **({"mu_s": mu, "mu_k": mu} if mu > 0 else {}))
            if isinstance(ob, Cylinder):
                half = ob.unit_axis * ob.length / 2
                out.append(Obstacle("capsule", start=np.asarray(ob.center) - half,
                                    end=np.asarray(ob.center) + half, radius=ob.radius, **common))
            elif isinstance(ob, Plane):
                out.append(Obstacle("plane", point=ob.point, normal=ob.unit_normal, **common))
            else:
                raise NotImplementedError(f"this adapter has no {type(ob).__name__} obstacle")
        return out

    def _steps(self, sim, scenario: Scenario, n_frames: int) -> tuple[float, int]:
        interval = scenario.duration / (n_frames - 1)
        per_frame = max(1, math.ceil(interval / (self.time_step_scale * sim.stable_dt())))
        return interval / per_frame, per_frame

    def settings(self, scenario: Scenario, *, n_elements: int, n_frames: int) -> dict:
        try:
            net, _, effects = self._build(scenario, n_elements)
        except NotImplementedError:
            return {}
        sim = cosnet.Simulation(net, effects=effects, stepper=self.stepper)
        dt, _ = self._steps(sim, scenario, n_frames)
        return {"integrator": f"cosnet {self.stepper}", "time_step": dt,
                "damping_rate": 2.0 * scenario.slowest_frequency() if scenario.quasi_static else 0.0}

    # ------------------------------------------------------------------ running
    def run(self, scenario: Scenario, *, n_elements: int, n_frames: int) -> Trajectory:
        net, placed, effects = self._build(scenario, n_elements)
        sim = cosnet.Simulation(net, effects=effects, stepper=self.stepper)
        dt, per_frame = self._steps(sim, scenario, n_frames)
        sim = cosnet.Simulation(net, effects=effects, stepper=self.stepper, dt=dt)
        for line, end_node, nodes in placed:       # move the unstretched build to the start
            sim.line_positions(line)[:] = nodes
            sim.state.node_x[end_node.index] = nodes[-1]
        frames = [[sim.line_positions(l).copy()] for l, _, _ in placed]
        turned = [[sim.line_directors(l)[:, :, 0].copy()] for l, _, _ in placed]
        try:
            for _ in range(n_frames - 1):
                sim.run(steps=per_frame)
                for (l, _, _), xs, ds in zip(placed, frames, turned):
                    xs.append(sim.line_positions(l).copy())
                    ds.append(sim.line_directors(l)[:, :, 0].copy())
        except RuntimeError as e:                   # cosnet's InstabilityError
            raise Diverged(str(e), time=sim.time) from None
        return Trajectory(np.linspace(0.0, scenario.duration, n_frames),
                          tuple(np.stack(x) for x in frames), tuple(np.stack(d) for d in turned))
