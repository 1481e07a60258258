"""An effect held to its contract on its example scene (``Effect.example``), built in or a
plugin's: its loads are minus the gradient of its potential where it says it is conservative,
they add up to no force and no moment where it says it is internal, a checkpoint round trip
continues its kernel bit for bit, and its ``table_error`` refuses a corrupted index table.
With ``dynamics=True`` the example also runs at two steps: energy plus the work accounts
(driver, actuation, supplied, dissipated) must drift at the scheme's order 2.

``check_effect`` returns a report; tests/test_effect_contract.py asserts it for every
registered effect, and docs/effects.md shows a plugin passing it.
"""

from __future__ import annotations

import math
import tempfile
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path

import numpy as np

from ..core.rotations import matrix_from_quat, qmul, quat_from_rotvec
from ..core.samples import smooth_motion
from ..engine.registry import Binding
from ..engine.simulation import Simulation
from ..kernels.motion import place_line_ends

# relative steps of the finite differences: positions in element lengths, rotations in rad
# (central differences: truncation ~ h^2, round-off ~ eps E / h; both far below 1e-6 here)
H_POSITION = 1e-6
H_ROTATION = 1e-6
SAMPLES = 6        # vertices and elements probed: the most loaded, then random ones
SAMPLED = 50       # times at which the energy balance is read in a run


def quat_mul(a, b) -> np.ndarray:
    """Hamilton products of quaternions a and b, (4,) or (n, 4) each."""
    return np.stack(qmul(np.asarray(a).T, np.asarray(b).T), axis=-1)


@dataclass
class Report:
    """What ``check_effect`` found; None where the check does not apply."""

    effect: str
    gradient_error: float | None = None   # max |load + dE/dq| / max |load| (conservative effects)
    force_sum: float | None = None        # |sum of forces| / sum of |forces| (internal effects)
    moment_sum: float | None = None       # |sum of moments about the origin| / sum of their sizes
    checkpoint_exact: bool | None = None  # a round trip continues the kernel bit for bit
    unrefused: list = field(default_factory=list)   # integer tables whose corruption passed
    unsaved: list = field(default_factory=list)     # accounts of its record a checkpoint leaves out
    energy_order: float | None = None     # observed order of the energy balance's drift


def example_simulation(cls):
    """(sim, effect): the example scene of effect class ``cls`` as a Simulation, and the
    instance of ``cls`` in it (one it declares, or one its net implies)."""
    scene = cls.example()
    if scene is None:
        raise ValueError(f"{cls.__name__}: declares no example (Effect.example) to be checked on")
    net, effects = scene
    sim = Simulation(net, effects)
    found = [e for e in sim.effects if type(e) is cls]
    if not found:
        raise ValueError(f"{cls.__name__}: its example scene holds no {cls.__name__}")
    return sim, found[0]


def _length(sim) -> float:
    """The example's length scale: its mean element length, or for a net of nodes alone
    the size of their box (1 m for a single node)."""
    rest = sim.model.element_rest_length
    if rest.size:
        return float(np.mean(rest))
    x = sim.state.node_x
    return float(np.linalg.norm(x.max(axis=0) - x.min(axis=0))) or 1.0


def _perturb(sim, rng):
    """Move the interior vertices and turn the elements a little (the example's loads then
    leave their symmetric values), the line ends placed on their nodes."""
    st, m = sim.state, sim.model
    ends = np.zeros(st.x.shape[0], bool)
    ends[m.attach_vertex] = True
    scale = _length(sim)
    st.x[~ends] += 2e-3 * scale * rng.standard_normal((int((~ends).sum()), 3))
    turn = quat_from_rotvec(0.02 * rng.standard_normal((st.q.shape[0], 3)))
    st.q[:] = quat_mul(st.q, turn)
    place_line_ends(m, st)


def _energy(effect, p, sim) -> float:
    return float(effect.potential(p, Binding(sim.net, sim.model, sim.state, tuple(sim.effects))))


def _most_loaded(values, count, rng, exclude=None):
    size = np.linalg.norm(values, axis=1)
    if exclude is not None:
        size[exclude] = -1.0
    order = [int(i) for i in np.argsort(-size) if size[i] > 0][:count // 2]
    rest = [i for i in rng.permutation(len(size)) if i not in order and size[i] >= 0]
    return order + [int(i) for i in rest[:count - len(order)]]


def node_loads(sim, loads) -> tuple[np.ndarray, np.ndarray]:
    """(nn, 3) forces and (nn, 3) torques about the centres of mass (lab) that ``loads`` put
    on the nodes: their own and those at their line ends, (4.3)/(4.4) as the step gathers them."""
    st, m = sim.state, sim.model
    force, torque = loads.node_f.copy(), loads.node_tau.copy()
    turn = matrix_from_quat(st.node_q)
    ends = matrix_from_quat(quat_mul(st.node_q[m.attach_node], m.attach_frame))
    for a, (nd, vt) in enumerate(zip(m.attach_node, m.attach_vertex)):
        f = loads.f[vt]
        force[nd] += f
        torque[nd] += np.cross(turn[nd] @ m.attach_offset[a], f) + ends[a] @ loads.end_tau[a]
    return force, torque


def _move_node(sim, nd, x0, q0, turn: bool, c: int, d: float):
    """Node nd moved by d along lab axis c from (x0, q0), or turned by d about it (turn)."""
    st = sim.state
    st.node_x[nd], st.node_q[nd] = x0, q0
    if turn:
        axis = np.zeros(3)
        axis[c] = d
        st.node_q[nd] = quat_mul(quat_from_rotvec(axis), q0)
    else:
        st.node_x[nd, c] = x0[c] + d
    place_line_ends(sim.model, st)


def _difference(effect, p, sim, move, undo, h) -> float:
    """-(E(+h) - E(-h)) / 2h for a move(+-h) of the state; undo() restores it."""
    move(h)
    up = _energy(effect, p, sim)
    undo()
    move(-h)
    down = _energy(effect, p, sim)
    undo()
    return -(up - down) / (2 * h)


def gradient_error(sim, effect, rng) -> float:
    """max |load + dE/dq| / max |load| over the most loaded interior vertices (forces, lab),
    elements (torques about the body axes) and nodes (forces and torques about their centres
    of mass, lab, with their line ends), by central differences of potential()."""
    p = sim.effect_params(effect)
    st, m = sim.state, sim.model
    loads = sim.effect_loads(effect)
    h = H_POSITION * _length(sim)
    ends = np.zeros(st.x.shape[0], bool)
    ends[m.attach_vertex] = True
    worst, scale = 0.0, 0.0
    for i in _most_loaded(loads.f, SAMPLES, rng, exclude=ends):
        for c in range(3):
            x0 = st.x[i, c]
            st.x[i, c] = x0 + h
            up = _energy(effect, p, sim)
            st.x[i, c] = x0 - h
            down = _energy(effect, p, sim)
            st.x[i, c] = x0
            worst = max(worst, abs(loads.f[i, c] + (up - down) / (2 * h)))
        scale = max(scale, float(np.abs(loads.f[i]).max()))
    for e in _most_loaded(loads.tau, SAMPLES, rng):
        for c in range(3):
            q0 = st.q[e].copy()
            axis = np.zeros(3)
            axis[c] = H_ROTATION
            st.q[e] = quat_mul(q0, quat_from_rotvec(axis))
            up = _energy(effect, p, sim)
            st.q[e] = quat_mul(q0, quat_from_rotvec(-axis))
            down = _energy(effect, p, sim)
            st.q[e] = q0
            worst = max(worst, abs(loads.tau[e, c] + (up - down) / (2 * H_ROTATION)))
        scale = max(scale, float(np.abs(loads.tau[e]).max()))
    force, torque = node_loads(sim, loads)
    for nd in _most_loaded(np.hstack([force, torque]), SAMPLES, rng):
        x0, q0 = st.node_x[nd].copy(), st.node_q[nd].copy()
        undo = partial(_move_node, sim, nd, x0, q0, False, 0, 0.0)
        for c in range(3):
            shift = partial(_move_node, sim, nd, x0, q0, False, c)
            turn = partial(_move_node, sim, nd, x0, q0, True, c)
            worst = max(worst, abs(force[nd, c] - _difference(effect, p, sim, shift, undo, h)),
                        abs(torque[nd, c] - _difference(effect, p, sim, turn, undo, H_ROTATION)))
        scale = max(scale, float(np.abs(force[nd]).max()), float(np.abs(torque[nd]).max()))
    return worst / scale if scale > 0 else math.inf


def momentum_sums(sim, effect) -> tuple[float, float]:
    """(|sum F| / sum |F|, |sum M| / sum |M|): the effect's loads' total force and total moment
    about the origin (vertex and node forces, element torques, node torques and the torques
    at line ends turned into the lab), each against the sum of the sizes of its terms."""
    return momentum_of(sim, sim.effect_loads(effect))


def momentum_of(sim, L) -> tuple[float, float]:
    """momentum_sums of the loads ``L`` on ``sim``'s state."""
    st, m = sim.state, sim.model
    forces = np.concatenate([L.f, L.node_f])
    points = np.concatenate([st.x, st.node_x])
    lab_tau = np.einsum("eij,ej->ei", matrix_from_quat(st.q), L.tau)
    frames = quat_mul(st.node_q[m.attach_node], m.attach_frame)
    end_tau = np.einsum("aij,aj->ai", matrix_from_quat(frames), L.end_tau)
    moments = np.concatenate([np.cross(points, forces), lab_tau, L.node_tau, end_tau])
    f_size = float(np.abs(forces).sum())
    m_size = float(np.abs(moments).sum())
    return (float(np.linalg.norm(forces.sum(axis=0))) / f_size if f_size else 0.0,
            float(np.linalg.norm(moments.sum(axis=0))) / m_size if m_size else 0.0)


def checkpoint_exact(sim, effect, rng) -> bool:
    """Whether a checkpoint round trip continues the effect's kernel bit for bit: from a
    saved state, the kernel runs twice (the net moved between the calls, so what it keeps
    from call to call, friction anchors, counts), the checkpoint is loaded, and the same two
    calls must give the same loads."""
    st = sim.state
    step = [0.1 * _length(sim) * rng.standard_normal(st.x.shape)
            for _ in range(2)]

    def two_calls():
        out = []
        for d in step:
            out.append(sim.effect_loads(effect))
            st.x[:] += d
        return out

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "check.npz"
        sim.save_checkpoint(path)
        first = two_calls()
        sim.load_checkpoint(path)
        again = two_calls()
    return all(np.array_equal(a, b) for la, lb in zip(first, again) for a, b in zip(la, lb))


def unrefused_tables(cls, sim, effect) -> list[str]:
    """The integer arrays of the effect's record in which a planted entry outside every table
    (one past the largest row the net has, and -1) is not refused by ``cls.table_error``, less
    those the declaration names as no index (``cls.free_integers``)."""
    p = sim.effect_params(effect)
    m = sim.model
    beyond = 1 + max(m.vertex_mass.shape[0], m.element_rest_length.shape[0], m.node_mass.shape[0],
                     m.attach_node.shape[0], *(a.size for a in p if isinstance(a, np.ndarray)))
    missed = []
    for name, a in zip(p._fields, p):
        if not (isinstance(a, np.ndarray) and a.dtype.kind in "iu" and a.size) or name in cls.free_integers:
            continue
        for planted in (beyond, -1) if name not in cls.none_if_negative else (beyond,):
            spoilt = a.copy()
            spoilt.flat[int(np.argmax(np.abs(spoilt)))] = planted
            if cls.table_error(p._replace(**{name: spoilt}), m) is None:
                missed.append(f"{name} = {planted}")
                break
    return missed


# record fields that accumulate over a run (work and energy accounts): a checkpoint must carry
# them (Effect.state_arrays), or a resumed run's budget starts them again from zero
ACCOUNT_FIELDS = ("work", "dissipated", "node_dissipated", "supplied")


def unsaved_accounts(sim, effect) -> list[str]:
    """The account arrays of the effect's record (ACCOUNT_FIELDS) its state_arrays leave out."""
    p = sim.effect_params(effect)
    saved = [id(a) for a in effect.state_arrays(sim).values()]
    return [n for n in ACCOUNT_FIELDS if n in p._fields and id(getattr(p, n)) not in saved]


def energy_order(sim_of, until: float) -> float:
    """Observed order of the largest drift of the energy balance (``sim.balance()``) over ``until``,
    the example's lines set swinging, at a tenth of the stable step and at a quarter of that
    (well inside the scheme's asymptotic range; the wide ratio keeps the estimate clear of
    the few per cent by which the largest drift of an oscillating error wanders);
    ``sim_of(dt)`` builds the example at a step dt (None: its stable step). An order near 0
    is a drift the step does not shrink: work no account holds."""
    dt = 0.1 * sim_of(None).stable_dt()
    steps = max(1, math.ceil(until / dt))
    every = max(1, steps // SAMPLED)
    drifts = []
    for halves in (1, 4):
        sim = sim_of(dt / halves)
        # the lines swinging (their interiors; the nodes as the example set them): Verlet's
        # error then comes from the net's own modes, not only from round-off
        nodes = sim.state.node_w.copy()
        smooth_motion(sim, amplitude=0.05, spin=0.0)
        sim.state.node_w[:] = nodes
        start, worst = sim.balance(), 0.0
        # the largest drift at the same times for both steps: the balance's error oscillates,
        # its size is what falls with the step
        for _ in range(0, steps, every):
            sim.run(steps=every * halves)
            worst = max(worst, abs(sim.balance() - start))
        drifts.append(worst)
    return 0.5 * math.log2(drifts[0] / drifts[1]) if drifts[1] > 0 else math.inf


def check_effect(cls, *, dynamics: bool = False, until: float = 2e-3, seed: int = 0) -> Report:
    """Report of effect class ``cls`` against its contract, on its example scene."""
    rng = np.random.default_rng(seed)
    sim, effect = example_simulation(cls)
    _perturb(sim, rng)
    report = Report(cls.__name__)
    load_effect = cls.stage == "load"
    if effect.conservative and load_effect:
        report.gradient_error = gradient_error(sim, effect, rng)
    if effect.internal and load_effect:
        report.force_sum, report.moment_sum = momentum_sums(sim, effect)
    report.unrefused = unrefused_tables(cls, sim, effect)
    report.unsaved = unsaved_accounts(sim, effect)
    if load_effect:
        report.checkpoint_exact = checkpoint_exact(sim, effect, rng)
    if dynamics:
        def build(dt):
            net, effects = cls.example()
            return Simulation(net, effects, dt=dt)
        report.energy_order = energy_order(build, until)
    return report
