"""The exact A* baseline: the minimum makespan under the environment's own step rules, proven.

Model. A state is (finished tasks, node of every robot). A move is any joint action of the
environment that sends at most one robot to each goal (each robot: any task, finished ones
included, or None; all-None is left out since it only burns the idle step). Two robots cannot
both stand on one goal: the second would find the first in its costmap there and fail, so no
plan asks for it (plan.SchedulingInstance). Its cost is the
step duration of model/rules.py with nominal travel times; moves that would finish a task
before one of its predecessors are excluded, since the goal is a complete, logic-consistent
episode, and so are moves with a leg beyond the goal timeout (it fails: the robot stays and the
step only gets longer). With the instance's hold_successors every move is in order: a robot
reaching a task early waits for its predecessors, or stands there unserved until a later step
(the state's node of that robot), as model/rules.py rules. The minimum makespan is the cheapest
path to "all finished".

Search. A* with an admissible heuristic, re-opening a state whenever a cheaper path to it is
found, so the first goal state taken from the queue is optimal; the proof is the search
itself (every state with a lower f was expanded). Lower bounds used:
- per open task j: it cannot be finished before some robot gets there (shortest chain of
  feasible legs, SchedulingInstance.chain_times) nor before its predecessors are finished;
  plus its service time;
- the open tasks' cheapest incoming legs and service times, shared over the robots.

All (n_tasks+1)^n_robots joint actions of a state are evaluated at once with numpy: this is a
batched copy of the rules of model/rules.py, kept identical by test_task_baselines.py, which
compares both on random states and checks the solver against brute-force enumeration through
rules.py. That batch and the search's tables grow fast with the team, so the search runs
within budgets (AStarBudget): a batch whose estimated size exceeds the memory budget is
refused before anything is allocated, and the search stops at its state, expansion, time or
memory limit, with the best lower bound it proved and no plan.
"""
from __future__ import annotations

import heapq
import math
import time
from dataclasses import dataclass
from typing import Callable, Dict, List, Optional, Tuple

import numpy as np

from marl_mrta.baselines.plan import Plan, SchedulingInstance, simulate_joint_actions

_EPS = 1e-9
#: Bytes a state costs in the search's tables (cost and parent dictionaries, queue entries), measured
#: generously on CPython 3.8–3.11 so that the memory budget holds.
STATE_BYTES = 400


@dataclass(frozen=True)
class AStarBudget:
    """Limits of one search (config/task_baselines.yaml, `exact`)."""

    max_expansions: int = 2_000_000
    max_states: int = 5_000_000
    time_limit: float = 60.0          # s of wall time
    memory_mb: float = 2048.0         # the batch of joint actions plus the search's tables


def batch_size(instance: SchedulingInstance) -> int:
    """Joint actions evaluated per expanded state: (n_tasks + 1)^n_robots."""
    return (instance.n_tasks + 1) ** instance.n_robots


def batch_bytes(instance: SchedulingInstance) -> float:
    """Estimated peak bytes of BatchedRules and one evaluation of a state's joint actions (every
    array of evaluate() and of the bounds at once, numpy temporaries included)."""
    n_r, n_t = instance.n_robots, instance.n_tasks
    return float(batch_size(instance)) * (28 * n_r * n_t + 5 * n_t * n_t + 40 * (n_t + n_r))


def refusal(instance: SchedulingInstance, budget: AStarBudget) -> Optional[str]:
    """Why the search would not fit its memory budget (one line), or None."""
    need = batch_bytes(instance) + 1000 * STATE_BYTES
    if need > budget.memory_mb * 1e6:
        return (f"A* refused: {batch_size(instance):.3g} joint actions per state "
                f"(({instance.n_tasks}+1)^{instance.n_robots}) need about {need / 1e6:.0f} MB, "
                f"over the memory budget of {budget.memory_mb:.0f} MB")
    return None


class BatchedRules:
    """model/rules.py for every joint action of one state at once (nominal times, no time limit)."""

    def __init__(self, instance: SchedulingInstance):
        n_r, n_t = instance.n_robots, instance.n_tasks
        self.n_r, self.n_t = n_r, n_t
        self.travel = np.asarray(instance.travel, dtype=float)
        combos = np.stack(np.unravel_index(np.arange(batch_size(instance)), (n_t + 1,) * n_r), axis=1)
        combos = combos[(combos < n_t).any(axis=1)]                 # drop all-None
        onehot = combos[:, :, None] == np.arange(n_t)[None, None, :]
        one_per_goal = onehot.sum(axis=1).max(axis=1) <= 1           # plans send one robot per goal
        self.actions = combos[one_per_goal]
        self.onehot = onehot[one_per_goal]
        self.has_goal = self.actions < n_t
        self.service = np.asarray(instance.service, dtype=float)
        self.pred = np.zeros((n_t, n_t), dtype=bool)               # pred[j, p]: p before j
        for j, preds in enumerate(instance.predecessors):
            self.pred[j, list(preds)] = True
        self.robot_index = np.arange(n_r)
        self.min_step = instance.min_step
        self.margin = instance.precedence_margin
        self.goal_timeout = instance.goal_timeout
        self.hold = instance.hold_successors
        self.order = topological_order([list(p) for p in instance.predecessors])

    def evaluate(self, done: np.ndarray, pos: np.ndarray):
        """For every joint action: valid flag, step duration, finished-after mask, new positions."""
        n_r, n_t = self.n_r, self.n_t
        nav_by_action = np.zeros((n_r, n_t + 1))
        nav_by_action[:, :n_t] = self.travel[pos][:, n_r:]
        nav = nav_by_action[self.robot_index[None, :], self.actions]          # (B, n_r)
        arrivals = np.where(self.onehot, nav[:, :, None], np.inf)             # (B, n_r, n_t)
        first_arrival = arrivals.min(axis=1)                                   # (B, n_t)
        finisher = arrivals.argmin(axis=1)                                     # lowest index on ties
        newly = np.isfinite(first_arrival) & ~done[None, :]
        if self.hold:
            return self._evaluate_hold(done, pos, nav, first_arrival, finisher, newly)
        finish_rel = first_arrival + self.service[None, :]
        # Task j's finisher is in order if each predecessor p was finished before this step,
        # or in this step strictly before j's arrival (by the instance's margin).
        before = newly[:, None, :] & (finish_rel[:, None, :] + self.margin < first_arrival[:, :, None])
        in_order = (~self.pred[None, :, :] | done[None, None, :] | before).all(axis=2)
        valid = (in_order | ~newly).all(axis=1) & (nav <= self.goal_timeout).all(axis=1)
        finisher_mask = self.onehot & newly[:, None, :] & (finisher[:, None, :] == self.robot_index[None, :, None])
        busy = nav + (finisher_mask * self.service[None, None, :]).sum(axis=2)
        duration = np.maximum(busy.max(axis=1), self.min_step)
        new_pos = np.where(self.has_goal, n_r + self.actions, pos[None, :])
        new_done = done[None, :] | newly
        return valid, duration, new_done, new_pos

    def _evaluate_hold(self, done, pos, nav, first_arrival, finisher, newly):
        """evaluate() under hold_successors: a task reached in the step is served from its arrival
        or its open predecessors' finish in the step, whichever is later (in precedence order, so
        chains within a step resolve), and not at all when one of them is not finished in it; the
        robot then stands on its goal. Every move is in order."""
        finish = np.full(first_arrival.shape, np.inf)                         # (B, n_t), inf: not served
        for j in self.order:
            start = np.where(newly[:, j], first_arrival[:, j], np.inf)
            for p in np.nonzero(self.pred[j] & ~done)[0]:
                start = np.maximum(start, finish[:, p])
            finish[:, j] = start + self.service[j]
        served = np.isfinite(finish)
        valid = (nav <= self.goal_timeout).all(axis=1)
        finisher_mask = self.onehot & served[:, None, :] & (finisher[:, None, :] == self.robot_index[None, :, None])
        busy = np.maximum(nav, np.where(finisher_mask, finish[:, None, :], 0.0).max(axis=2))
        duration = np.maximum(busy.max(axis=1), self.min_step)
        new_pos = np.where(self.has_goal, self.n_r + self.actions, pos[None, :])
        return valid, duration, done[None, :] | served, new_pos


class _Bounds:
    """Admissible lower bounds on the remaining makespan (see the module docstring)."""

    def __init__(self, instance: SchedulingInstance):
        n_r, n_t = instance.n_robots, instance.n_tasks
        self.to_task = instance.chain_times()[:, n_r:]                       # (nodes, n_t)
        incoming = np.asarray(instance.travel, dtype=float)[:, n_r:].copy()
        incoming[incoming > instance.goal_timeout] = np.inf
        if not instance.hold_successors:
            # A task's leg comes from elsewhere; with the hold a robot may already stand there unserved.
            incoming[n_r + np.arange(n_t), np.arange(n_t)] = np.inf
        self.min_incoming = incoming.min(axis=0) + np.asarray(instance.service)
        self.service = np.asarray(instance.service, dtype=float)
        self.preds = [list(p) for p in instance.predecessors]
        self.order = topological_order(self.preds)
        self.n_r = n_r

    def __call__(self, done: np.ndarray, pos: np.ndarray) -> np.ndarray:
        """done (B, n_t) bool, pos (B, n_r) -> (B,) lower bounds."""
        reach = self.to_task[pos].min(axis=1)                                 # (B, n_t) earliest arrival
        finish = np.zeros_like(reach)
        for j in self.order:
            start = reach[:, j]
            for p in self.preds[j]:
                start = np.maximum(start, finish[:, p])
            finish[:, j] = np.where(done[:, j], 0.0, start + self.service[j])
        chain = finish.max(axis=1)
        shared = np.where(done, 0.0, self.min_incoming[None, :]).sum(axis=1) / self.n_r
        return np.maximum(chain, shared)


def topological_order(preds: List[List[int]]) -> List[int]:
    order: List[int] = []
    placed = set()
    while len(order) < len(preds):
        for j in range(len(preds)):
            if j not in placed and all(p in placed for p in preds[j]):
                order.append(j)
                placed.add(j)
    return order


def root_lower_bound(instance: SchedulingInstance) -> float:
    """The A* heuristic at the start: a lower bound on the makespan that costs nothing to compute."""
    n_r, n_t = instance.n_robots, instance.n_tasks
    return float(_Bounds(instance)(np.zeros((1, n_t), dtype=bool), np.arange(n_r)[None, :])[0])


def _unproven(instance: SchedulingInstance, status: str, lower: float, **details) -> Plan:
    return Plan("exact", [[] for _ in range(instance.n_robots)], [], math.inf, 0, proven_optimal=False,
                details=dict(details, status=status, lower_bound=lower), instance=instance)


#: allowed(actions (B, n_robots) with n_tasks for None, finished (n_tasks,) bool, robot nodes
#: (n_robots,)) -> (B,) bool: the joint actions a narrower decision process offers in a state.
JointActionFilter = Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]


def solve_exact(instance: SchedulingInstance, max_expansions: Optional[int] = None,
                upper_bound: Optional[float] = None, budget: AStarBudget = AStarBudget(),
                allowed: Optional[JointActionFilter] = None) -> Plan:
    """A* over (finished set, robot nodes). upper_bound: makespan of a known logic-consistent
    plan (prunes the search; the optimum is still found when it equals the bound). Within the
    budget (max_expansions, if given, replaces the budget's); past it, a plan without tasks,
    not proven, with details["status"] one line saying which limit stopped it and
    details["lower_bound"] what the search proved. With `allowed`, the optimum over the joint
    actions it lets through (a policy's masks: the best schedule that policy could choose; the
    heuristic stays admissible, since fewer moves never make a plan shorter)."""
    started = time.monotonic()
    n_r, n_t = instance.n_robots, instance.n_tasks
    bounds = _Bounds(instance)
    h0 = root_lower_bound(instance)
    refused = refusal(instance, budget)
    if refused:
        return _unproven(instance, refused, h0, expansions=0)
    expansion_limit = budget.max_expansions if max_expansions is None else max_expansions
    state_limit = min(budget.max_states, int((budget.memory_mb * 1e6 - batch_bytes(instance)) / STATE_BYTES))
    rules = BatchedRules(instance)
    n_nodes = n_r + n_t
    weights = (n_nodes ** np.arange(n_r)).astype(np.int64) << n_t
    bits = (1 << np.arange(n_t)).astype(np.int64)

    def encode(done: np.ndarray, pos: np.ndarray) -> np.ndarray:
        return (done.astype(np.int64) * bits).sum(axis=-1) + (pos.astype(np.int64) * weights).sum(axis=-1)

    def decode(key: int) -> Tuple[np.ndarray, np.ndarray]:
        done = ((key & ((1 << n_t) - 1)) >> np.arange(n_t)) & 1
        rest = key >> n_t
        pos = np.array([(rest // n_nodes ** r) % n_nodes for r in range(n_r)], dtype=np.int64)
        return done.astype(bool), pos

    all_done = (1 << n_t) - 1
    start_key = int(encode(np.zeros(n_t, dtype=bool), np.arange(n_r, dtype=np.int64)))
    limit = math.inf if upper_bound is None else upper_bound + 1e-6
    best_g: Dict[int, float] = {start_key: 0.0}
    parent: Dict[int, Tuple[int, int]] = {}
    queue = [(h0, 0.0, start_key)]
    expansions = 0
    goal_key = None
    stopped = ""
    while queue:
        f, g, key = heapq.heappop(queue)
        if g > best_g.get(key, math.inf) + _EPS:
            continue                                            # a cheaper path reached it meanwhile
        if key & all_done == all_done:
            goal_key = key
            break
        if expansions >= expansion_limit:
            stopped = f"A* stopped after {expansions} expansions (its limit)"
        elif len(best_g) >= state_limit:
            stopped = f"A* stopped at {len(best_g)} states (the limit of its memory budget, {budget.memory_mb:.0f} MB)"
        elif time.monotonic() - started > budget.time_limit:
            stopped = f"A* stopped at its time limit ({budget.time_limit:g} s)"
        if stopped:
            heapq.heappush(queue, (f, g, key))
            break
        expansions += 1
        done, pos = decode(key)
        valid, duration, new_done, new_pos = rules.evaluate(done, pos)
        g_new = g + duration
        keep = valid.copy() if allowed is None else valid & allowed(rules.actions, done, pos)
        f_new = np.full(len(valid), math.inf)
        h = bounds(new_done[keep], new_pos[keep])
        f_new[keep] = g_new[keep] + h
        keep &= f_new <= limit
        if not keep.any():
            continue
        idx = np.nonzero(keep)[0]
        keys = encode(new_done[idx], new_pos[idx])
        order = np.lexsort((g_new[idx], keys))                  # per key, cheapest first
        keys, idx = keys[order], idx[order]
        first = np.ones(len(keys), dtype=bool)
        first[1:] = keys[1:] != keys[:-1]
        for k, i in zip(keys[first].tolist(), idx[first].tolist()):
            gk = float(g_new[i])
            if gk < best_g.get(k, math.inf) - _EPS:
                best_g[k] = gk
                parent[k] = (key, i)
                heapq.heappush(queue, (float(f_new[i]), gk, k))
    seconds = time.monotonic() - started
    if goal_key is None:
        # Every state with f below the queue's least f was expanded; with the queue empty no
        # plan beats the bound, so the bound's plan is optimal.
        lower = queue[0][0] if queue else (upper_bound if upper_bound is not None else math.inf)
        return _unproven(instance, stopped or "A*: no plan below the given bound", lower,
                         expansions=expansions, states=len(best_g), seconds=seconds)
    joint_actions: List[List[Optional[int]]] = []
    key = goal_key
    while key != start_key:
        prev, action_index = parent[key]
        joint_actions.append([int(a) if a < n_t else None for a in rules.actions[action_index]])
        key = prev
    joint_actions.reverse()
    run = simulate_joint_actions(instance, joint_actions)
    return Plan("exact", run.robot_tasks, run.joint_actions, run.elapsed, run.violations, proven_optimal=True,
                details={"solver": "astar", "expansions": expansions, "states": len(best_g),
                         "optimal_makespan": best_g[goal_key], "seconds": seconds},
                instance=instance)
