"""A run's energy budget is written at every frame (energy.csv) and read back with its probes;
``cosnet plot`` and Output.plot draw what the files hold, value for value."""

from pathlib import Path

import numpy as np
import pytest

import cosnet
from cosnet.cli import main
from cosnet.output.plots import budget

CASES = Path(__file__).resolve().parents[1] / "cases"


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """The cantilever case (gravity, damping) run to 0.02 s with two probes; the Simulation."""
    out = tmp_path_factory.mktemp("plots") / "sag"
    sim = cosnet.load_scene(CASES / "cantilever.toml").simulation()
    sim.run(until=0.02, out=out, every=0.005, probes=["tip", "rod@0.5:force"])
    return out, sim


def test_energy_rows_are_the_budget_at_each_frame(run):
    """One row per frame; the last row is what the simulation reports at its end, exactly
    (the accounts as sim.dissipated(), driver_work(), ... give them)."""
    out, sim = run
    e = cosnet.read_output(out).energy()
    assert np.array_equal(e["time"], cosnet.read_output(out).times)
    parts = sim.energy_parts()
    last = {"kinetic": parts["kinetic"], "strain": parts["strain"], "potential": parts["potential"],
            "dissipated": sim.dissipated(), "driver": sim.driver_work(), "actuation": sim.actuation_work(),
            "loads": sim.load_work(), "supplied": sim.supplied()}
    assert {k: float(e[k][-1]) for k in last} == last
    assert e["dissipated"][-1] > 0.0 and e["potential"][-1] < 0.0     # damped, and it sagged


def test_the_plot_draws_the_files_values(run):
    """Each probe component's line is its CSV column; the energy panel's curves are the
    budget of energy.csv (energy = kinetic + strain + potential, and the balance's drift)."""
    out, _ = run
    result = cosnet.read_output(out)
    fig = result.plot("tip", "rod@0.5:force", energy=True)
    rows = np.loadtxt(out / "probes.csv", delimiter=",", skiprows=1)
    header = (out / "probes.csv").read_text().splitlines()[0].split(",")
    lines = {ax.get_ylabel().rsplit(": ", 1)[0]: ax.lines[0] for ax in fig.axes if ": " in ax.get_ylabel()}
    for name in ("tip", "rod@0.5:force"):
        for axis in "xyz":
            line = lines[f"{name} {axis}"]
            np.testing.assert_array_equal(line.get_ydata(), rows[:, header.index(f"{name}_{axis}")])
            np.testing.assert_array_equal(line.get_xdata(), rows[:, 1])
    assert lines["rod@0.5:force x"].axes.get_ylabel().endswith("force (N)")
    energy = next(ax for ax in fig.axes if ax.get_ylabel() == "energy (J)")
    drawn = {ln.get_label(): ln.get_ydata() for ln in energy.lines}
    expected = budget(result.energy())
    assert drawn.keys() == expected.keys() and "dissipated" in drawn and "driver" not in drawn
    for label, values in expected.items():
        np.testing.assert_array_equal(drawn[label], values)
    e = result.energy()
    np.testing.assert_allclose(drawn["energy"], e["kinetic"] + e["strain"] + e["potential"], rtol=0, atol=0)


def test_cosnet_plot_writes_the_file_and_refuses_in_one_line(run, tmp_path, capsys):
    out, _ = run
    assert main(["plot", str(out), "tip", "--energy", "--output", str(tmp_path / "tip.svg")]) == 0
    assert (tmp_path / "tip.svg").read_text().startswith("<?xml")
    assert main(["plot", str(out), "nope"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == f"cosnet: error: {out}/probes.csv: no probe 'nope' (it has tip, rod@0.5:force)"
    assert main(["plot", str(out), "--output", str(tmp_path / "x.jpg")]) == 2
    assert "a plot is written as .png, .svg or .pdf" in capsys.readouterr().err
