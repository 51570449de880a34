"""What the actor's decision process leaves out: the best schedule a policy deciding in turn
could choose, against the step rules' optimum.

For each scenario (the lab's and generated ones, as bench_generalise draws them) the A* of
baselines/exact.py is run twice: over every joint action, and over those the in-turn decision
(mappo/claims.py, ClaimRules.allowed) can produce under the `finished` mask, with the robots
choosing in a given order:
- index: robot 0 first, as ClaimRules.decide_in_turn does;
- nearest_ready: per state, the robot with the shortest nominal leg to a ready task (open, every
  predecessor finished) first, ties by index (what `turn_order: nearest_ready` does).
The ratio masked ÷ full is the ceiling of any policy with that decision order.

    python3 tools/mask_ceiling.py --scenarios 40 --orders index,nearest_ready [--decision-order sequential_logic]
"""
import argparse
import sys
import tempfile
from pathlib import Path
from typing import Callable, Sequence

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

from marl_mrta.apps.train_generalist import LAB_SCENARIOS, generated_scenarios  # noqa: E402
from marl_mrta.baselines.exact import solve_exact  # noqa: E402
from marl_mrta.baselines.plan import SchedulingInstance  # noqa: E402
from marl_mrta.baselines.reference import scheduling_instance  # noqa: E402
from marl_mrta.common.paths import package_root  # noqa: E402
from marl_mrta.env.observation import TURN_ORDERS  # noqa: E402
from marl_mrta.env.settings import load_task_settings  # noqa: E402
from marl_mrta.mappo.claims import in_turn_filter  # noqa: E402
from marl_mrta.model.scenario import load_scenario  # noqa: E402

ORDERS = TURN_ORDERS


def ceilings(instance: SchedulingInstance, decision_order: str, orders: Sequence[str]) -> dict:
    full = solve_exact(instance)
    row = {"full": full.makespan if full.proven_optimal else None}
    for kind in orders:
        masked = solve_exact(instance, allowed=in_turn_filter(instance, decision_order, kind))
        row[kind] = masked.makespan if masked.proven_optimal else None
    return row


def main(argv: Sequence[str] = ()) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scenarios", type=int, default=40, help="generated scenarios (bench_generalise's test draw)")
    parser.add_argument("--seed", type=int, default=9, help="their seed (bench_generalise's default)")
    parser.add_argument("--orders", default="index,nearest_ready", help=f"robot orders, of {', '.join(ORDERS)}")
    parser.add_argument("--decision-order", default="sequential_logic", choices=("sequential", "sequential_logic"))
    args = parser.parse_args(list(argv))
    orders = [o for o in args.orders.split(",") if o]
    if any(o not in ORDERS for o in orders):
        parser.error(f"--orders: each of {', '.join(ORDERS)}")
    task = load_task_settings()
    log: Callable[[str], None] = lambda line: print(line, flush=True)
    ratios = {kind: [] for kind in orders}
    with tempfile.TemporaryDirectory(prefix="mask_ceiling_") as tmp:
        labs = [load_scenario(package_root() / "scenarios" / f"{name}.xml") for name in LAB_SCENARIOS]
        tests = generated_scenarios(args.scenarios, args.seed, Path(tmp), "test", (2, 4), (4, 12))
        for k, scenario in enumerate(labs + tests):
            name = scenario.name if k < len(labs) else f"test_{k - len(labs):03d}"
            row = ceilings(scheduling_instance(scenario, task.min_step, task.goal_timeout), args.decision_order, orders)
            if row["full"] is None or any(row[kind] is None for kind in orders):
                log(f"{name}: not proven within the A*'s budget, left out")
                continue
            parts = []
            for kind in orders:
                ratio = row[kind] / row["full"]
                parts.append(f"{kind} {row[kind]:.2f} ({ratio:.3f})")
                if k >= len(labs):
                    ratios[kind].append(ratio)
            log(f"{name} {scenario.n_robots}x{scenario.n_tasks}: optimum {row['full']:.2f}, " + ", ".join(parts))
    for kind in orders:
        values = np.array(ratios[kind])
        log(f"{kind}: masked / optimum over {len(values)} generated scenarios: mean {values.mean():.4f}, "
            f"p90 {np.percentile(values, 90):.4f}, max {values.max():.4f}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
