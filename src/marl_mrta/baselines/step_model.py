"""The exact step model in CP-SAT: the minimum makespan under the environment's own step rules.

The same problem as the A* of exact.py, for teams too large for its (n_tasks+1)^n_robots
joint actions per state. The rules are those of model/rules.py with nominal travel times
(test_task_cpsat.py checks that the optimum equals the A*'s and that every plan replays through
plan.simulate_joint_actions to the objective):

- K decision steps; in each, every robot gets a task's goal or None. A goal may be any task,
  finished ones included (a robot may drive to a finished task's goal to be nearer its next
  one), but not the goal it stands on (that only costs time) nor one beyond the goal timeout,
  and no two robots get one goal in one step (the A*'s moves: the second would find the first
  standing there). Robot r's node at the start of each step follows from its moves (a flow over the steps:
  `stay` and `move` literals per node).
- A task is finished exactly once, in the step of its first arrival, by a robot sent there; a
  robot sent to an open task finishes it unless another arrives first; every robot sent to a
  task finished in that step arrives no earlier than its finisher (ties go to either robot:
  the arrival and so the step are the same, model/rules.py gives it to the lower index).
- Order: a task is finished in the step of its predecessors' finish or later, and in the same
  step only if each predecessor's finish (arrival + service) comes strictly before its arrival,
  by the instance's precedence margin.
- A step lasts at least min_step if any robot has a goal, and at least every robot's arrival
  plus, for its finisher, the service time. Unused steps (every robot None) last 0 and come last.
  The objective is the sum of the step durations.

Steps needed. No optimal plan has a step in which no robot moves to another node (it changes
nothing and costs min_step), so every step of an optimal plan lasts at least step_floor =
max(min_step, the shortest feasible leg), and a plan within the upper bound U has at most
floor(U / step_floor) steps. With that many steps the model's bound is a lower bound of the
problem. A model that large is only built up to PROOF_MOVES move literals; otherwise the model
has K = the starting plan's steps + 1, its bound holds for plans of at most K steps and every
other plan lasts at least (K+1)·step_floor, so the smaller of the two is the lower bound.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Dict, List, Optional, Tuple

from ortools.sat.python import cp_model

from marl_mrta.baselines.cpsat import STEP_TIME, CpSatBudget, SolveOutcome, solve
from marl_mrta.baselines.plan import Plan, SchedulingInstance, simulate_joint_actions

#: Bytes CP-SAT needs per move literal of this model (with its constraints, presolve and one
#: worker's search), measured on 4–16 robot models and rounded up.
BYTES_PER_MOVE = 8000
#: Move literals up to which the model gets every step a plan within the upper bound may need
#: (its bound is then the problem's). Larger models of that many steps neither close nor
#: improve plans within tens of seconds; they get the starting plan's steps plus one instead,
#: where CP-SAT's search does improve plans, and their bound holds for that many steps only.
PROOF_MOVES = 20000


@dataclass
class StepModelResult:
    plan: Optional[Plan]             # the best plan found, replayed; None if none was found
    lower_bound: float               # s, a lower bound of the step-rule optimum
    proven_optimal: bool
    steps: int                       # K, the decision steps of the model
    steps_needed: int                # floor(U / step_floor): K at least this makes the bound exact
    status: str                      # one line
    outcome: Optional[SolveOutcome] = None
    details: Dict[str, object] = field(default_factory=dict)


def step_floor(instance: SchedulingInstance) -> float:
    """The least duration of a step in which some robot moves to another node."""
    n_r = instance.n_robots
    legs = [instance.travel_rows[a][n_r + j] for a in range(n_r + instance.n_tasks) for j in range(instance.n_tasks)
            if a != n_r + j and instance.leg_feasible(a, n_r + j)]
    return max(instance.min_step, min(legs, default=instance.min_step))


def reachable_nodes(instance: SchedulingInstance, robot: int, steps: int) -> List[List[int]]:
    """Per step 0..steps, the nodes robot `robot` can stand on at the start of that step."""
    n_r = instance.n_robots
    layers = [[robot]]
    for _ in range(steps):
        current = set(layers[-1])
        grown = set(current)
        for a in current:
            grown.update(n_r + j for j in range(instance.n_tasks) if a != n_r + j and instance.leg_feasible(a, n_r + j))
        layers.append(sorted(grown))
    return layers


def move_count(instance: SchedulingInstance, steps: int) -> int:
    """Move literals of a model with `steps` steps (its size)."""
    n_r, n_t = instance.n_robots, instance.n_tasks
    total = 0
    for robot in range(n_r):
        for layer in reachable_nodes(instance, robot, steps)[:steps]:
            total += sum(1 for a in layer for j in range(n_t) if a != n_r + j and instance.leg_feasible(a, n_r + j))
    return total


def _hint_values(instance: SchedulingInstance, plan: Plan) -> Tuple[List[List[Optional[int]]], List[int], List[Dict[int, int]]]:
    """The plan's goals per step, each robot's node at the start of every step and after the
    last, and per step {task: finisher}."""
    run = simulate_joint_actions(instance, [])
    positions = []
    finishers = []
    for goals in plan.joint_actions:
        positions.append(list(run.positions))
        resolution = run.apply(goals)
        finishers.append({f.task: f.robot for f in resolution.finished})
    positions.append(list(run.positions))
    return plan.joint_actions, positions, finishers


def solve_step_model(instance: SchedulingInstance, budget: CpSatBudget, hint: Optional[Plan] = None,
                     known_lower_bound: float = 0.0) -> StepModelResult:
    """The step model within the budget, started from `hint` (a complete, logic-consistent plan,
    whose makespan is the upper bound that sizes the model)."""
    n_r, n_t = instance.n_robots, instance.n_tasks
    if hint is None or not hint.complete or hint.logic_violations:
        return StepModelResult(None, 0.0, False, 0, 0, "step model not built: it needs a complete, consistent plan to start from")
    floor = step_floor(instance)
    upper = hint.makespan
    needed = max(len(hint.joint_actions), int(math.floor(upper / floor + 1e-9)))
    affordable = int(budget.memory_mb * 1e6 / BYTES_PER_MOVE)
    steps = needed
    if move_count(instance, needed) > PROOF_MOVES:
        steps = len(hint.joint_actions) + 1
    moves = move_count(instance, steps)
    if moves > affordable:
        return StepModelResult(None, 0.0, False, steps, needed,
                               f"step model not built: {moves} move literals for {steps} steps need about "
                               f"{moves * BYTES_PER_MOVE / 1e6:.0f} MB, over the memory budget of {budget.memory_mb:.0f} MB")

    model = cp_model.CpModel()
    leg = [[STEP_TIME.ticks(t) for t in row] for row in instance.travel_rows]
    service = [STEP_TIME.ticks(s) for s in instance.service]
    margin = STEP_TIME.ticks(instance.precedence_margin)
    min_step = STEP_TIME.ticks(instance.min_step)
    horizon = STEP_TIME.ticks(upper) + 1
    longest = max(leg[a][n_r + j] for a in range(n_r + n_t) for j in range(n_t) if instance.leg_feasible(a, n_r + j))

    finish = [[model.NewBoolVar(f"finish_{j}_{k}") for k in range(steps)] for j in range(n_t)]
    for j in range(n_t):
        model.AddExactlyOne(finish[j])
    finished_by = [[sum(finish[j][:k + 1]) for k in range(steps)] for j in range(n_t)]   # done by the end of step k
    arrival = [model.NewIntVar(0, longest, f"arrival_{j}") for j in range(n_t)]          # within its step
    duration = [model.NewIntVar(0, horizon, f"duration_{k}") for k in range(steps)]
    used = [model.NewBoolVar(f"used_{k}") for k in range(steps)]
    for k in range(steps - 1):
        model.AddImplication(used[k + 1], used[k])

    goal: Dict[Tuple[int, int, int], cp_model.IntVar] = {}
    finisher: Dict[Tuple[int, int, int], cp_model.IntVar] = {}
    move: Dict[Tuple[int, int, int, int], cp_model.IntVar] = {}
    stay: Dict[Tuple[int, int, int], cp_model.IntVar] = {}
    for r in range(n_r):
        layers = reachable_nodes(instance, r, steps)
        at = {r: 1}                     # node -> expression: robot r stands there at the start of step k
        for k in range(steps):
            into: Dict[int, list] = {}
            goal_terms: Dict[int, list] = {}
            nav_terms = []
            for a in layers[k]:
                s = stay[r, k, a] = model.NewBoolVar(f"stay_{r}_{k}_{a}")
                out = [s]
                into.setdefault(a, []).append(s)
                for j in range(n_t):
                    b = n_r + j
                    if a == b or not instance.leg_feasible(a, b):
                        continue
                    m = move[r, k, a, j] = model.NewBoolVar(f"move_{r}_{k}_{a}_{j}")
                    out.append(m)
                    into.setdefault(b, []).append(m)
                    goal_terms.setdefault(j, []).append(m)
                    nav_terms.append(leg[a][b] * m)
                model.Add(sum(out) == at.get(a, 0))
            nav = model.NewIntVar(0, longest, f"nav_{r}_{k}")
            model.Add(nav == sum(nav_terms))
            service_terms = []
            for j, terms in goal_terms.items():
                g = goal[r, k, j] = model.NewBoolVar(f"goal_{r}_{k}_{j}")
                model.Add(g == sum(terms))
                model.AddImplication(g, used[k])
                model.Add(g <= finished_by[j][k])          # an open task a robot is sent to is finished
                model.Add(nav >= arrival[j]).OnlyEnforceIf([g, finish[j][k]])
                f = finisher[r, k, j] = model.NewBoolVar(f"finisher_{r}_{k}_{j}")
                model.AddImplication(f, g)
                model.Add(nav <= arrival[j]).OnlyEnforceIf(f)
                service_terms.append(service[j] * f)
            model.Add(duration[k] >= nav + sum(service_terms))
            at = {b: sum(terms) for b, terms in into.items()}
    for k in range(steps):
        for j in range(n_t):
            sent = [goal[r, k, j] for r in range(n_r) if (r, k, j) in goal]
            if len(sent) > 1:
                model.Add(sum(sent) <= 1)
        model.Add(duration[k] >= min_step * used[k])
        model.Add(sum(g for (r, kk, j), g in goal.items() if kk == k) >= used[k])
    for j in range(n_t):
        for k in range(steps):
            model.Add(sum(finisher.get((r, k, j), 0) for r in range(n_r)) == finish[j][k])
    for j, preds in enumerate(instance.predecessors):
        for p in preds:
            for k in range(steps):
                model.Add(finish[j][k] <= finished_by[p][k])
                model.Add(arrival[j] >= arrival[p] + service[p] + margin + 1).OnlyEnforceIf([finish[j][k], finish[p][k]])
    makespan = sum(duration)
    model.Add(makespan <= horizon)
    model.Add(makespan >= STEP_TIME.floor(known_lower_bound))
    model.Minimize(makespan)

    goals_of, positions, finishers = _hint_values(instance, hint)

    def hinted(k: int) -> bool:
        return k < len(goals_of)
    for k in range(steps):
        model.AddHint(used[k], hinted(k))
        for j in range(n_t):
            model.AddHint(finish[j][k], hinted(k) and j in finishers[k])
    for (r, k, a), var in stay.items():
        node = positions[min(k, len(goals_of))][r]
        model.AddHint(var, node == a and (not hinted(k) or goals_of[k][r] is None))
    for (r, k, a, j), var in move.items():
        model.AddHint(var, hinted(k) and positions[k][r] == a and goals_of[k][r] == j)
    for (r, k, j), var in goal.items():
        model.AddHint(var, hinted(k) and goals_of[k][r] == j)
        model.AddHint(finisher[r, k, j], hinted(k) and finishers[k].get(j) == r)

    solver, outcome = solve(model, budget)
    details = {"steps": steps, "steps_needed": needed, "move_literals": moves, "step_floor": floor, **outcome.as_dict()}
    plan = None
    if outcome.has_solution:
        joint = []
        for k in range(steps):
            row = [next((j for j in range(n_t) if (r, k, j) in goal and solver.Value(goal[r, k, j])), None)
                   for r in range(n_r)]
            if any(g is not None for g in row):
                joint.append(row)
        run = simulate_joint_actions(instance, joint)
        if run.complete and run.violations == 0:
            plan = Plan("exact", run.robot_tasks, run.joint_actions, run.elapsed, 0, details={"solver": "cpsat_steps"},
                        instance=instance)
        details["objective"] = STEP_TIME.seconds(outcome.objective)
    bound = STEP_TIME.seconds(outcome.bound)
    if steps < needed:
        bound = min(bound, (steps + 1) * floor)
    proven = outcome.optimal and steps >= needed and plan is not None
    lower = plan.makespan if proven else max(bound, 0.0)
    state = "optimal" if proven else ("feasible" if plan is not None else "no plan")
    status = (f"step model ({steps} steps{'' if steps >= needed else f' of {needed} needed'}, {moves} moves): "
              f"{state}, CP-SAT {outcome.status} after {outcome.deterministic_seconds:.1f} deterministic s")
    return StepModelResult(plan, lower, proven, steps, needed, status, outcome, details)

