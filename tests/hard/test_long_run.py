"""A long undamped run of a free net: Verlet's energy error stays a bounded oscillation (no
secular drift) and the momenta stay exact. 1e5 steps in CI, 1e6 with COSNET_FULL=1 (and in
bench/long_run.py, which prints the error envelope over time)."""

import os

import numpy as np
import pytest

import cosnet
from nets import smooth_motion
from nets_hard import long_run_net

FULL = os.environ.get("COSNET_FULL") == "1"


def start_long_run():
    """The long-run net in smooth motion (lines swinging, nodes spinning, the body drifting)."""
    net, p = long_run_net()
    sim = cosnet.Simulation(net)
    smooth_motion(sim)
    sim.node_velocity(p["body"])[:] = (0.3, -0.2, 0.1)
    return sim


def energy_envelope(sim, steps, windows=100):
    """Run 'steps' steps; return per window the (min, max) relative energy error, sampled
    every steps / (windows * 20) steps."""
    e0 = sim.energy()
    per = max(1, steps // (windows * 20))
    env = []
    for _ in range(windows):
        errs = []
        for _ in range(20):
            sim.run(steps=per)
            errs.append(sim.energy() / e0 - 1)
        env.append((min(errs), max(errs)))
    return np.array(env)


@pytest.mark.slow
def test_long_run_energy_error_stays_bounded_and_momenta_exact():
    """1e5 (CI) or 1e6 (full) steps at the automatic step: the energy error envelope of the
    last tenth is no wider than 1.5 times that of the first tenth and its centre has not moved
    by more than half the first tenth's width (no drift), |error| < 1e-3 (measured 4e-4);
    linear and angular momentum conserved to 1e-9 of their scale; quaternions unit to 1e-12."""
    steps = 1_000_000 if FULL else 100_000
    sim = start_long_run()
    p0, l0 = sim.momentum(), sim.angular_momentum()
    scale_p = np.abs(sim.state.v).sum(axis=1) @ sim.model.vertex_mass + np.abs(p0).sum()
    env = energy_envelope(sim, steps)
    first, last = env[:10], env[-10:]
    w_first = first[:, 1].max() - first[:, 0].min()
    w_last = last[:, 1].max() - last[:, 0].min()
    shift = abs(0.5 * (last[:, 1].max() + last[:, 0].min()) - 0.5 * (first[:, 1].max() + first[:, 0].min()))
    print(f"{sim.steps} steps: |error| max {np.abs(env).max():.3g}, band first {w_first:.3g} last "
          f"{w_last:.3g}, centre shift {shift:.3g}")
    assert sim.steps == steps
    assert np.abs(env).max() < 1e-3
    assert w_last < 1.5 * w_first and shift < 0.5 * w_first
    assert np.abs(sim.momentum() - p0).max() < 1e-9 * scale_p
    assert np.abs(sim.angular_momentum() - l0).max() < 1e-9 * np.abs(l0).max()
    assert np.abs(np.linalg.norm(sim.state.q, axis=1) - 1).max() < 1e-12
