"""cosnet.studies.accuracy: Richardson estimates of the time-step error against the true error, the
observed orders of the two steppers, element-count refinement of a scene, and the
``cosnet accuracy`` command."""

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from cosnet.studies.accuracy import resolve_probes, run_window, scaled_scene, time_series
from cosnet.scene.loader import load_scene
from nets import ROD_SCENE

REPO = Path(__file__).resolve().parents[1]


GRAVITY = '[[effects]]\nkind = "gravity"\n'          # released from rest: smooth motion
KICK = "[initial.nodes.tip]\nvelocity = [0.0, 0.3, 0.0]\n"


@pytest.fixture
def scene_file(tmp_path):
    def make(elements=4, extra=GRAVITY):
        p = tmp_path / f"rod{elements}.toml"
        p.write_text(ROD_SCENE.format(title="soft rod", E="2.0e7", G="8.0e6", elements=elements,
                                      rest=f"{extra}\n[run]\nuntil = 1.0\n"))
        return p
    return make


def test_richardson_estimate_of_verlet_dt_error_matches_the_true_error(scene_file):
    scene = load_scene(scene_file())
    window = 0.1
    s = time_series(scene, "verlet", window)
    assert not s.nominal and abs(s.order - 2.0) < 0.2, s.observed
    # true error: against a PEFRL run with a far smaller step (same mesh, so time error only)
    ref = run_window(scene, resolve_probes(scene, None), "pefrl", 8 * s.runs[-1].steps, window).value
    for r in s.runs:
        true = np.linalg.norm(r.value - ref)
        assert 0.5 < r.error / true < 2.0, (r.dt, r.error, true)


def test_observed_order_of_pefrl_is_four(scene_file):
    """A kicked one-element rod: PEFRL's error is well above round-off over a short window."""
    scene = load_scene(scene_file(elements=1, extra=KICK))
    dt = scene.simulation(stepper="pefrl").dt / 2
    s = time_series(scene, "pefrl", 0.01, dt=dt)
    assert not s.nominal and abs(s.order - 4.0) < 0.35, s.observed


def test_scaled_scene_multiplies_every_element_count(scene_file):
    path = scene_file(elements=3)
    sc = scaled_scene(path, 4)
    assert [l.elements for l in sc.net.lines] == [12]
    assert sc.net.line("rod").length == pytest.approx(0.5)
    probes = resolve_probes(sc, ["tip", "rod@0.5"])
    assert probes[1].vertex == 6
    with pytest.raises(ValueError, match="names no node or line"):
        resolve_probes(sc, ["nowhere"])


def cosnet(*args):
    return subprocess.run([sys.executable, "-m", "cosnet.cli", *map(str, args)], capture_output=True,
                          text=True, cwd=REPO, timeout=300)


def test_cli_prints_the_table_and_a_recommendation(scene_file):
    r = cosnet("accuracy", scene_file(elements=2), "--window", "0.02", "--tol", "0.05",
               "--probe", "tip")
    assert r.returncode == 0, r.stderr
    out = r.stdout
    assert "refinement series" in out and "est. error" in out and "wall s / sim s" in out
    assert "verlet" in out and "pefrl" in out and "x4 (8)" in out
    assert "recommended for tol = 0.05 m" in out


def test_cli_refuses_a_bad_tolerance(scene_file):
    for bad in ("-1", "zero", "nan"):
        r = cosnet("accuracy", scene_file(), "--tol", bad)
        assert r.returncode == 2
        assert "--tol must be a positive number" in r.stderr
        assert "Traceback" not in r.stderr


WIRE_SCENE = """
title = "steel wire"
[materials.steel]
E = 2.1e11
G = 8.1e10
density = 7850.0
[sections.wire]
kind = "circle"
radius = 0.001
[nodes.root]
position = [0.0, 0.0, 0.0]
fixed = true
[nodes.tip]
position = [0.4, 0.0, 0.0]
[lines.wire]
start = "root"
end = "tip"
material = "steel"
section = "wire"
elements = 4
[[effects]]
kind = "gravity"
[run]
until = 0.04
"""


@pytest.mark.parametrize("own", ["resolve", "auto"])
def test_fast_modes_settings_are_listed_and_the_cheapest_one_within_tol_is_recommended(tmp_path, own):
    """A slender wire (l/r = 100), resolving or treating its own fast modes: every fast_modes
    setting is listed, measured against the full scheme; the softened ones take longer steps;
    the recommendation meets tol and no cheaper listed setting does."""
    from cosnet.studies.accuracy import study
    from cosnet.core.fast_modes import FAST_MODES
    path = tmp_path / "wire.toml"
    path.write_text(WIRE_SCENE + f'fast_modes = "{own}"\n')
    st = study(path, window=0.0005, probes=["tip"])
    fm = {}
    for s in st.settings:       # each setting at its longest step on the scene's mesh
        if s.factor == 1 and s.stepper == "verlet" and s.dt > getattr(fm.get(s.fast_modes), "dt", 0.0):
            fm[s.fast_modes] = s
    assert set(fm) == set(FAST_MODES)
    assert fm["soften"].dt > 4 * fm["resolve"].dt
    assert all(s.measured and math.isfinite(s.error) and s.error > 0 for s in fm.values())
    for tol in sorted({s.error for s in st.settings})[::3]:
        best = st.recommend(tol)
        assert best is not None and best.error <= tol
        assert not [s for s in st.settings if s.cost < best.cost and s.error <= tol]
