"""Reading a sweep's Dataset: a probe quantity per variant, the summary table and the plot."""

from __future__ import annotations

from pathlib import Path

import numpy as np

COMPONENTS = {"x": 0, "y": 1, "z": 2}


def quantity(ds, spec: str | None = None) -> tuple[str, np.ndarray]:
    """(label, values per variant) of ``PROBE[:x|y|z|norm]``: the probe's displacement from
    frame 0 to the last frame (NaN for a variant that did not reach it). Default: the sweep
    file's ``plot``, else the first probe along the component in which it moved most."""
    spec = spec or ds.attrs.get("plot") or None
    probes = [k for k in ds.data_vars if ds[k].dims == ("variant", "time", "component")]
    if not probes:
        raise ValueError("the sweep has no probes: add [run] probes to the scene")
    name, _, comp = (spec or "").partition(":")
    name = name or probes[0]
    if name not in probes:
        raise ValueError(f"--plot {spec}: no probe {name!r}; probes are {', '.join(probes)}")
    arr = np.asarray(ds[name].values, dtype=float)
    disp = arr[:, -1, :] - arr[:, 0, :]
    if not comp:
        with np.errstate(invalid="ignore"):
            mean = np.nanmean(np.abs(disp), axis=0) if np.isfinite(disp).any() else np.zeros(3)
        comp = "xyz"[int(np.argmax(mean))]
    if comp == "norm":
        return f"|displacement| of {name} (m)", np.linalg.norm(disp, axis=1)
    if comp not in COMPONENTS:
        raise ValueError(f"--plot {spec}: the component must be x, y, z or norm, got {comp!r}")
    return f"{comp} displacement of {name} (m)", disp[:, COMPONENTS[comp]]


def summary(ds, spec: str | None = None, limit: int = 40) -> str:
    """A table of the variants: varied values, status, steps, wall time and the quantity."""
    keys = list(ds.attrs.get("varied", []))
    label, q = quantity(ds, spec)
    status = [str(s) for s in ds["status"].values]
    head = ["#"] + keys + ["status", "steps", "wall s", label]
    rows = []
    for i in range(ds.sizes["variant"]):
        st = status[i] if len(status[i]) <= 48 else status[i][:45] + "..."
        rows.append([str(i)] + [_fmt(ds[k].values[i]) for k in keys]
                    + [st, str(int(ds["steps"].values[i])), f"{float(ds['wall_time'].values[i]):.2f}",
                       _fmt(q[i])])
    shown = rows if len(rows) <= limit else rows[:limit // 2] + [["..."] * len(head)] + rows[-limit // 2:]
    width = [max(len(r[j]) for r in [head] + shown) for j in range(len(head))]
    lines = ["  ".join(c.ljust(w) for c, w in zip(r, width)).rstrip() for r in [head] + shown]
    ok = sum(s == "ok" for s in status)
    pend = sum(s == "pending" for s in status)
    lines.append(f"{ok} ok, {len(status) - ok - pend} failed, {pend} pending of {len(status)} variants")
    return "\n".join(lines)


def _fmt(v) -> str:
    if isinstance(v, (float, np.floating)):
        return "nan" if not np.isfinite(v) else f"{float(v):.6g}"
    return str(v)


def plot(ds, path, spec: str | None = None) -> Path:
    """A PNG of the quantity against the first varied key (one curve per value of the
    others), written to ``path``; needs matplotlib (the ``sweep`` extra)."""
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise ValueError("--plot needs matplotlib: pip install 'cosnet[sweep]'") from None
    keys = list(ds.attrs.get("varied", []))
    label, q = quantity(ds, spec)
    n = ds.sizes["variant"]
    x = np.asarray(ds[keys[0]].values) if keys else np.arange(n)
    xlabel = keys[0] if keys else "variant"
    groups: dict = {}
    for i in range(n):
        tag = ", ".join(f"{k} = {_fmt(ds[k].values[i])}" for k in keys[1:])
        groups.setdefault(tag, []).append(i)
    fig, ax = plt.subplots(figsize=(6.4, 4.2), dpi=110)
    numeric = np.issubdtype(x.dtype, np.number)
    for tag, idx in groups.items():
        idx = sorted(idx, key=lambda i: x[i]) if numeric else idx
        ax.plot([x[i] if numeric else str(x[i]) for i in idx], q[idx], "o-", label=tag or None)
    bad = [i for i in range(n) if str(ds["status"].values[i]) != "ok"]
    if bad and numeric:
        floor = np.nanmin(q) if np.isfinite(q).any() else 0.0
        ax.plot(x[bad], np.full(len(bad), floor), "x", color="red", label="failed (no value)")
    if numeric and np.all(x > 0) and x.max() / x.min() >= 100:
        ax.set_xscale("log")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(label)
    ax.set_title(ds.attrs.get("title", ""))
    ax.grid(True, alpha=0.3)
    if len(groups) > 1 or bad:
        ax.legend(fontsize=8)
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path)
    plt.close(fig)
    return path
