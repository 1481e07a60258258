"""The instability watch stops a blown-up run early with a useful message."""

import numpy as np
import pytest

import cosnet
from cosnet.simulation import CHUNK_STEPS
from nets import cantilever, free_net, smooth_motion


def test_forced_large_dt_stops_with_time_place_and_safe_dt():
    net, line, root, tip = cantilever(n=10)
    est = cosnet.Simulation(net).dt
    sim = cosnet.Simulation(net, effects=[cosnet.Gravity()], dt=3 * est, force_dt=True)
    with pytest.raises(cosnet.InstabilityError) as info:
        sim.run(steps=50 * CHUNK_STEPS)
    err = info.value
    assert sim.steps <= 50 * CHUNK_STEPS and err.time <= sim.time
    assert "line 'rod'" in err.where
    assert err.safe_dt == pytest.approx(est)
    assert "a dt below" in str(err) and "t = " in str(err)
    # the estimate it suggests does run
    ok = cosnet.Simulation(net, effects=[cosnet.Gravity()], dt=err.safe_dt)
    ok.run(steps=2 * CHUNK_STEPS)
    assert np.all(np.isfinite(ok.state.x))


def test_watch_is_silent_on_a_healthy_run():
    sim = cosnet.Simulation(free_net(3), effects=[cosnet.Damping(0.1)])
    smooth_motion(sim)
    sim.run(steps=3 * CHUNK_STEPS)
    assert sim.steps == 3 * CHUNK_STEPS
