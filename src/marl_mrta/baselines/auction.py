"""Sequential single-item auction (the market-based family of the paper's Table 2).

Rounds until every task is sold: every task whose predecessors are already sold is offered;
each robot bids for appending it to its route: with the `minimax` objective the route's new
finish time (its estimated start waits for the predecessors' estimated finish; a leg beyond the
goal timeout counts as the quickest chain of legs over other goals), with `minsum` the increase
of that time. The lowest bid over all (task, robot) pairs wins (ties: lower task, then lower
robot index). The routes are then turned into steps by plan.decode_task_lists, the same decoder
as the GA's. Each route follows the order of sale, in which a task comes after its predecessors,
so the decoded schedule never waits on a robot that waits in turn.
"""
from __future__ import annotations

from typing import List

from marl_mrta.baselines.plan import Plan, SchedulingInstance, decode_task_lists, plan_from_run


def solve_auction(instance: SchedulingInstance, objective: str = "minimax") -> Plan:
    n_r, n_t = instance.n_robots, instance.n_tasks
    chains = instance.chain_times()
    travel = [[leg if leg <= instance.goal_timeout else float(chains[a, b]) for b, leg in enumerate(row)]
              for a, row in enumerate(instance.travel_rows)]
    routes: List[List[int]] = [[] for _ in range(n_r)]
    end_node = list(range(n_r))
    end_time = [0.0] * n_r
    finish_estimate = [0.0] * n_t
    sold = [False] * n_t
    for _ in range(n_t):
        best = None
        for task in range(n_t):
            if sold[task] or not all(sold[p] for p in instance.predecessors[task]):
                continue
            ready = max((finish_estimate[p] for p in instance.predecessors[task]), default=0.0)
            for robot in range(n_r):
                arrive = end_time[robot] + travel[end_node[robot]][instance.node(task)]
                finish = max(arrive, ready) + instance.service[task]
                bid = finish if objective == "minimax" else finish - end_time[robot]
                if best is None or bid < best[0] - 1e-12:
                    best = (bid, task, robot, finish)
        _, task, robot, finish = best
        sold[task] = True
        routes[robot].append(task)
        end_node[robot] = instance.node(task)
        end_time[robot] = finish
        finish_estimate[task] = finish
    run = decode_task_lists(instance, routes)
    return plan_from_run("auction", run, objective=objective)
