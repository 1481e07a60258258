"""cosseratbench 0.3.0's validated experiments for cosnet and PyElastica, side by side.

    python bench/cosseratbench_run.py [--experiments catenary cantilever pendulum twist crossing]

Each experiment runs at its default parameters and resolution for both solvers through
``cosseratbench.run`` (which warms each solver up on a short copy of the scenario first, so
compilation stays out of the wall time). Scores are the experiment's own metrics (relative
errors against its analytical reference). An experiment outside a solver's model is reported
as unsupported with the solver's reason. An experiment in VARIANTS runs at each listed value
of its parameter (capstan: every overhang, ropes that should hold and ropes that should
slide). Results go to bench/cosseratbench.json: a run of some experiments replaces their
entries and keeps the others, each entry carrying the machine's load average over the minute
before its run started (the wall times of a loaded machine are not comparable with an idle
one's). The first five take about 15 minutes on 2 idle cores, nearly all of it PyElastica on
twist (721 s); capstan's five variants and pile add about 10 minutes under load, nearly all
PyElastica's.
"""

from __future__ import annotations

import argparse
import json
import os
from importlib.metadata import version
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import cosseratbench as cb  # noqa: E402
from cosseratbench.registry import load_experiment  # noqa: E402
from cosseratbench.solvers.pyelastica import PyElasticaSolver  # noqa: E402
from cosnet.cosserat_bench import CosnetSolver  # noqa: E402
from harness import table, write_json  # noqa: E402

EXPERIMENTS = ("catenary", "cantilever", "pendulum", "twist", "crossing", "capstan", "pile")
# experiments run at several values of one parameter (the others at their defaults)
VARIANTS = {"capstan": ("overhang", (0.5, 0.8, 0.95, 1.1, 1.5))}


def variants(name):
    """The parameter values each run of experiment `name` gets ({} for its defaults)."""
    if name not in VARIANTS:
        return [{}]
    key, values = VARIANTS[name]
    return [{key: v} for v in values]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--experiments", nargs="+", default=list(EXPERIMENTS), choices=EXPERIMENTS)
    ap.add_argument("--solvers", nargs="+", default=["cosnet", "pyelastica"],
                    choices=["cosnet", "pyelastica"])
    args = ap.parse_args(argv)
    solvers = {"cosnet": CosnetSolver, "pyelastica": PyElasticaSolver}
    rows, results = [], []
    for name in args.experiments:
        ex = load_experiment(name)
        for values in variants(name):
            for sname in args.solvers:
                solver = solvers[sname]()
                label = name + "".join(f" {k}={v}" for k, v in values.items())
                print(f"{label} / {sname} ...", file=sys.stderr, flush=True)
                load = os.getloadavg()[0]
                r = cb.run(ex, solver, values=values)
                summary = {**r.summary(), "load_average": round(load, 2)}
                results.append(summary)
                scores = "; ".join(f"{k} {v:.3g}" for k, v in {**r.metrics, **r.observations}.items())
                why = r.failure or "; ".join(r.missing)
                rows.append([label, sname, r.n_elements, r.outcome,
                             "-" if r.wall_time is None else f"{r.wall_time:.3g}",
                             scores or why])
    table("cosseratbench 0.3.0 (default parameters and resolution; errors are relative)",
          ["experiment", "solver", "elements", "outcome", "wall s", "scores"], rows)
    # bench/cosseratbench.json (named after the benchmark, not this script)
    target = Path(__file__).with_name("cosseratbench.py")
    results = _merged(target.with_suffix(".json"), results)
    write_json(str(target), {"cosseratbench": version("cosseratbench"), "results": results})


def _merged(path: Path, results: list) -> list:
    """results, with the entries of a previous run's file for experiments and solvers not rerun,
    in the order of EXPERIMENTS."""
    ran = {(r["experiment"], r["solver"]) for r in results}
    kept = []
    if path.exists():
        kept = [r for r in json.loads(path.read_text(encoding="utf-8"))["results"]
                if (r["experiment"], r["solver"]) not in ran]
    return sorted(kept + results, key=lambda r: (EXPERIMENTS.index(r["experiment"]),
                                                 ("cosnet", "pyelastica").index(r["solver"])))


if __name__ == "__main__":
    main()
