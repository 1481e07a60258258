"""cosseratbench 0.3.0's validated experiments for cosnet and PyElastica, side by side.

    python bench/cosseratbench_run.py [--experiments catenary cantilever pendulum twist crossing capstan pile]

Each experiment runs at its default parameters and resolution for both solvers through
``cosseratbench.run`` (which warms each solver up on a short copy of the scenario first, so
compilation stays out of the wall time). Scores are the experiment's own metrics (relative
errors against its analytical reference). An experiment outside a solver's model is reported
as unsupported with the solver's reason. Results go to bench/cosseratbench.json; the entries
of experiments not run this time are kept. An experiment in VARIANTS runs at each listed
value of its parameter (capstan: every overhang, ropes that should hold and ropes that
should slide).
The first five take 1.5 to 6 minutes on 2 shared cores, nearly all of it PyElastica on twist;
capstan's five variants and pile add about 10 minutes under load, nearly all PyElastica's.
"""

from __future__ import annotations

import argparse
import json
from importlib.metadata import version
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import cosseratbench as cb  # noqa: E402
from cosseratbench.registry import load_experiment  # noqa: E402
from cosseratbench.solvers.pyelastica import PyElasticaSolver  # noqa: E402
from cosseratbench_adapter import CosnetSolver  # noqa: E402
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


def kept_results(path: Path, ran) -> list:
    """The results in the JSON at path of the experiments not in ran."""
    if not path.exists():
        return []
    return [r for r in json.loads(path.read_text())["results"] if r["experiment"] not in ran]


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
                r = cb.run(ex, solver, values=values)
                summary = r.summary()
                results.append(summary)
                scores = "; ".join(f"{k} {v:.3g}" for k, v in {**r.metrics, **r.observations}.items())
                why = r.failure or "; ".join(r.missing)
                rows.append([label, sname, r.n_elements, r.outcome,
                             "-" if r.wall_time is None else f"{r.wall_time:.3g}",
                             scores or why])
    table("cosseratbench 0.3.0 (default parameters and resolution; errors are relative)",
          ["experiment", "solver", "elements", "outcome", "wall s", "scores"], rows)
    # bench/cosseratbench.json (named after the benchmark, not this script)
    out = Path(__file__).with_name("cosseratbench.py")
    results = kept_results(out.with_suffix(".json"), set(args.experiments)) + results
    write_json(str(out), {"cosseratbench": version("cosseratbench"), "results": results})


if __name__ == "__main__":
    main()
