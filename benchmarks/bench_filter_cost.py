"""Each filter's cost per step in the scenario loop (isl_core.scenario.cost.filter_costs) and the IMM filter's per mode.

    PYTHONPATH=. python benchmarks/bench_filter_cost.py [--repeats 7] [--horizon 200] [--save now.json]
                                                       [--compare before.json]

The filters are those of the fair table at its minimax knobs if a tuning is cached for α = 1, m = 3, w = 3 at the
table's defaults (isl scenario --tune), else at the knobs given here (the issue's first measurements); the IMM bank
also with 1, 6, 11 and 16 modes. Printed: ns per step of each (min of --repeats runs; copies filling a lane group,
minus the loop's own three filters), the loop's own cost, the load average before and after (timings on a shared
machine are noisy: read it). ``--save`` writes the figures as JSON; ``--compare`` prints them beside an earlier
file's (before → now, and the ratio), e.g. across a change of the IMM kernel.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
from pathlib import Path

from isl_core import Model, filter_costs, imm_kbf
from isl_core.scenario.tuning import FAMILIES, family_filter, tune

KNOBS = {
    "isl": {"ell": -4.0},
    "isl_model": {"ell": -4.0},
    "kbf_adaptive": {"memory": 10.0},
    "vb": {"memory": 10.0},
    "kbf_robust": {"c": 2.0, "memory": 10.0},
    "imm": {"switch": 0.01, "modes": 16},
}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--horizon", type=float, default=200.0)
    ap.add_argument("--save", type=Path, default=None)
    ap.add_argument("--compare", type=Path, default=None)
    args = ap.parse_args()
    print(f"load average before: {os.getloadavg()[0]:.2f} ({os.cpu_count()} cores)")
    model = Model.from_w(1.0, 3.0, 20.0, 3)
    tuning = tune(1.0, compute=False)
    if tuning is not None:
        specs = [dataclasses.replace(s, name=f) for f, s in zip(FAMILIES, tuning.tuned_filters(model), strict=True)]
        print(f"knobs: the cached tuning ({tuning.origin})")
    else:
        specs = [family_filter(f, model, KNOBS[f]) for f in FAMILIES]
        print(f"knobs (no tuning cached): {KNOBS}")
    specs += [dataclasses.replace(imm_kbf(model, modes=j), name=f"imm_{j}_modes") for j in (1, 6, 11, 16)]
    costs = filter_costs(model, specs, horizon=args.horizon, repeats=args.repeats)
    now = {**costs.ns_per_step, "loop (clairvoyant, Kalman–Bucy, ISL)": costs.base}
    before = json.loads(args.compare.read_text()) if args.compare else {}
    print(costs.how)
    print(f"{'filter':40} {'ns/step':>10}" + (f" {'before':>10} {'now/before':>11}" if before else ""))
    for name, value in now.items():
        line = f"{name:40} {value:10.1f}"
        if name in before:
            line += f" {before[name]:10.1f} {value / before[name]:11.2f}"
        print(line)
    if args.save:
        args.save.write_text(json.dumps(now, indent=1))
        print(f"wrote {args.save}")
    print(f"load average after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
