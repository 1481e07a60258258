"""Plots of a run read back (``cosnet plot``): its probes over time, and its energy budget.

matplotlib comes with the ``plot`` extra; the functions return the Figure, the command line
saves it (PNG, SVG or PDF, by the file's suffix).
"""

from __future__ import annotations

import numpy as np

from ..engine.registry import ACCOUNTS
from .fields import ENERGY_COLUMNS, FIELD_UNITS

PLOT_EXTRA = "pip install 'cosnet[plot]'"


def _pyplot():
    try:
        import matplotlib
    except ImportError:
        raise ValueError(f"plots need matplotlib: {PLOT_EXTRA}") from None
    matplotlib.use("Agg")        # off screen, as the pictures are
    import matplotlib.pyplot as plt
    return plt


def _label(quantity: str) -> str:
    unit = FIELD_UNITS.get(quantity, "")
    return f"{quantity.replace('_', ' ')} ({unit})" if unit else quantity.replace("_", " ")


def budget(energy: dict) -> dict:
    """The energy budget's curves over time (J): energy() = kinetic + strain + potential,
    each account with something in it, and the balance's drift from its first value (energy -
    driver - actuation - loads - supplied + dissipated: constant but for the scheme's error)."""
    total = energy["kinetic"] + energy["strain"] + energy["potential"]
    balance = total + sum(sign * energy[name] for name, (_, sign) in ACCOUNTS.items())
    curves = {name: energy[name] for name in ENERGY_COLUMNS if np.any(energy[name] != 0.0)}
    return {"energy": total, **curves, "balance drift": balance - balance[0]}


def plot_output(out, probes=(), energy: bool = False):
    """A Figure of the run ``out`` (cosnet.output.io.Output): for each probe named (every probe
    of probes.csv when none is, and no energy asked), its field's x, y and z against time in
    panels whose y labels start "PROBE x", ...; with ``energy``, the energy budget in the panel "energy".
    ValueError (one line) naming what is missing."""
    series = out.probes()
    names = list(probes) if probes else ([] if energy else list(series))
    unknown = [n for n in names if n not in series]
    if unknown:
        have = ", ".join(series) or "none"
        raise ValueError(f"{out.directory}/probes.csv: no probe {unknown[0]!r} (it has {have})")
    if not names and not energy:
        raise ValueError(f"{out.directory}: nothing to plot: the run has no probes; name some in [run] probes, "
                         f"or plot --energy")
    plt = _pyplot()
    # a probe's x, y and z side by side, each on its own scale (a sag of millimetres under a
    # coordinate of metres stays visible); the energy budget across the bottom
    rows = [[f"{j}{axis}" for axis in "xyz"] for j in range(len(names))] + ([["energy"] * 3] if energy else [])
    fig, axes = plt.subplot_mosaic(rows, figsize=(10.0, 2.4 * len(rows)), layout="constrained")
    times = out.probe_times() if names else None
    for j, name in enumerate(names):
        field = name.partition(":")[2] or "position"
        for c, axis in enumerate("xyz"):
            ax = axes[f"{j}{axis}"]
            ax.plot(times, series[name][:, c], label=f"{name} {axis}")
            ax.set_ylabel(f"{name} {axis}: {_label(field)}")
            ax.set_xlabel("time (s)")
            ax.grid(alpha=0.3)
    if energy:
        e = out.energy()
        ax = axes["energy"]
        for label, values in budget(e).items():
            ax.plot(e["time"], values, label=label, lw=2.0 if label == "energy" else 1.2,
                    ls=":" if label == "balance drift" else "-")
        ax.set_ylabel("energy (J)")
        ax.set_xlabel("time (s)")
        ax.legend(loc="center left", bbox_to_anchor=(1.0, 0.5), fontsize="small")
        ax.grid(alpha=0.3)
    fig.suptitle(str(out.directory.name))
    return fig
