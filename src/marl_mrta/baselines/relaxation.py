"""Relaxations of the step rules in CP-SAT: lower bounds on the makespan for any team.

Both give each robot a route of the tasks it finishes (a circuit through its start and those
tasks, AddCircuit; a task's self-loop meaning "not this robot's"), every task on exactly one
route, legs as the quickest chains of feasible legs (SchedulingInstance.chain_times: a robot
may pass over any goal), and a task's arrival no earlier than its predecessors' finishes
(arrival + service). The makespan is the last finish.

- asynchronous: robots do not wait for the end of a decision step; a robot arrives at its next
  task after its previous arrival, that task's service time and the chain between them.
- synchronous: every task is finished in a numbered step; a step ends no earlier than each
  finish in it and at least min_step after it starts, the next step starts when it ends; a
  robot finishes at most one task per step and leaves a task only when its step has ended; an
  arrival comes one feasible leg after its step's start from where its robot stands: its start
  (for its first task) or the goal of a task finished in an earlier step (its previous one, or
  one it passed over), and strictly after the finish of a predecessor. n_tasks steps always
  suffice (steps finishing nothing are dropped), and with an upper bound U at most
  U / (the least possible finishing step) of them.
- stepwise: the synchronous one with the step rules' timing: each numbered step runs from its
  start to its end, and the next starts at that end or later (steps that finish nothing lie
  between); a finisher arrives exactly one leg after its step's start (it cannot wait within
  a step), and it got onto the goal it sets off from over whole steps after its previous
  task's step ended (or from its start), so that step starts at least the quickest chain of
  legs from there later. Much tighter (site_8r: 70.58 s against 60.42 s, the best plan
  70.60 s), and harder to solve: the reference builds it only when the synchronous one was
  solved.

Every plan under the step rules gives a schedule of the asynchronous and the synchronous one
(its finishers' routes, with arrivals at least as late as the relaxation asks and predecessors
finished strictly before). Under hold_successors only of the asynchronous one: a robot that waits
at a task for its predecessors is scheduled to arrive at its service start. For the stepwise one, number the plan's steps that finish a task in
order, with their real starts and ends: a finisher arrives at begin + the leg from the node it
stands on, its start or a goal it was sent to before; a goal sent to while open is finished in
that step by the first to arrive, so it is of a task finished in an earlier step; between its
previous finish and this step the robot drove one leg per step, each step lasting at least its
leg, so at least the chain between. So each optimum, and CP-SAT's bound on it, is a lower
bound of the step-rule optimum. Times are rounded down to ticks of 10 ms (floor(x + y) lies in
[floor x + floor y, floor x + floor y + 1], hence a tick of slack on the stepwise arrival), so
the integer optimum stays a lower bound of the exact one. test_task_cpsat.py compares each
with the A*'s optimum on random instances and the lab scenarios. The routes of the best
solution are also a candidate schedule: plan.decode_task_lists turns them into steps.

With a makespan cap a relaxation answers only whether a schedule within the cap exists;
probing.py bisects caps to raise a bound the optimisation leaves loose.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Dict, List, Optional

import numpy as np
from ortools.sat.python import cp_model

from marl_mrta.baselines.cpsat import BOUND_TIME, CpSatBudget, SolveOutcome, TimeScale, solve
from marl_mrta.baselines.plan import Plan, SchedulingInstance, simulate_joint_actions

#: Bytes CP-SAT needs per arc literal of these models, measured and rounded up.
BYTES_PER_ARC = 8000
KINDS = ("asynchronous", "synchronous", "stepwise")


@dataclass
class RelaxationResult:
    kind: str
    lower_bound: float                    # s, a lower bound of the step-rule optimum (0 if none)
    optimum: Optional[float]              # s, the relaxation's best schedule (None if none found)
    routes: Optional[List[List[int]]]     # per robot, the tasks of that schedule in order
    status: str                           # one line
    outcome: Optional[SolveOutcome] = None
    details: Dict[str, object] = field(default_factory=dict)


def arc_count(instance: SchedulingInstance) -> int:
    n_r, n_t = instance.n_robots, instance.n_tasks
    return n_r * (n_t + 1) ** 2


def solve_relaxation(instance: SchedulingInstance, budget: CpSatBudget, kind: str = "asynchronous",
                     hint: Optional[Plan] = None, upper_bound: Optional[float] = None,
                     known_lower_bound: float = 0.0, makespan_cap: Optional[float] = None,
                     scale: TimeScale = BOUND_TIME, direct_legs: bool = False,
                     least_finishes: bool = False) -> RelaxationResult:
    """One relaxation within the budget; `hint` (a complete plan) gives its first solution,
    known_lower_bound (a bound already proven, e.g. the asynchronous one) its least makespan.

    With `makespan_cap` (s) the question is only whether a schedule of makespan at most
    floor(cap) ticks exists (no objective: CP-SAT stops at the first one, and prunes with the
    cap far better than when it optimises). Infeasible proves every plan at least one tick
    longer (a plan of makespan M gives a schedule of floor(M) ticks or fewer, so a plan shorter
    than cap + 1 tick would give one within the cap): lower_bound = cap + 1 tick. A schedule
    found gives its routes and its makespan as `optimum` (the relaxation's optimum is at most
    that), and no bound. With `direct_legs` (asynchronous only) legs are the direct ones within
    the goal timeout, not the quickest chains over other goals: event mode's own schedule
    (plan.py), of which the optimum is then exact, not a relaxation. With `least_finishes` (and a
    cap) the schedule within the cap of the least sum of finish times: a live fleet's plan then
    leaves no task waiting that could be done sooner (baselines/replan.py)."""
    if kind not in KINDS:
        raise ValueError(f"relaxation kind {kind!r} is not one of {', '.join(KINDS)}")
    if kind != "asynchronous" and scale != BOUND_TIME:
        raise ValueError("only the asynchronous relaxation takes another time scale")
    if instance.live and not direct_legs:
        raise ValueError("a live fleet's instance is planned with the asynchronous model over direct legs")
    cap = scale.floor(makespan_cap) if makespan_cap is not None else None
    if cap is not None:
        # Only plans shorter than cap + 1 tick matter: the step count and the horizon may use that.
        capped_upper = scale.seconds(cap + 1)
        upper_bound = capped_upper if upper_bound is None else min(upper_bound, capped_upper)
    n_r, n_t = instance.n_robots, instance.n_tasks
    arcs = arc_count(instance)
    if arcs * BYTES_PER_ARC > budget.memory_mb * 1e6:
        return RelaxationResult(kind, 0.0, None, None, f"{kind} relaxation not built: {arcs} arcs need about "
                                f"{arcs * BYTES_PER_ARC / 1e6:.0f} MB, over the memory budget of {budget.memory_mb:.0f} MB")
    if direct_legs:   # event mode's own schedule: a robot drives straight to its next task
        if kind != "asynchronous":
            raise ValueError("only the asynchronous relaxation takes direct legs")
        chains = np.where(np.asarray(instance.travel, dtype=float) <= instance.goal_timeout,
                          np.asarray(instance.travel, dtype=float), np.inf)
    else:
        chains = instance.chain_times()
    finite = chains[chains < float("inf")]
    service = [scale.floor(s) for s in instance.service]
    # A live fleet's times are absolute: robots free later, tasks released later (0 otherwise).
    ready = [scale.floor(instance.ready_time(r)) for r in range(n_r)]
    release = [scale.floor(instance.release(j)) for j in range(n_t)]
    horizon = scale.floor(upper_bound) + 1 if upper_bound is not None else \
        max(ready + release + [0]) + sum(service) + \
        n_t * (scale.floor(float(finite.max() if finite.size else 0.0)) + scale.floor(instance.min_step)) + 1

    model = cp_model.CpModel()
    arrival = [model.NewIntVar(0, horizon, f"arrival_{j}") for j in range(n_t)]
    # When task j's robot may leave it: at its finish (asynchronous) or at its step's end.
    leave = [arrival[j] + service[j] for j in range(n_t)]
    least = min(scale.floor(known_lower_bound), horizon)
    makespan = model.NewIntVar(least, max(least, min(horizon, cap)) if cap is not None else horizon, "makespan")
    arc_of: Dict[tuple, cp_model.IntVar] = {}
    steps = None
    if kind != "asynchronous":
        steps = _steps(model, instance, arrival, service, horizon, upper_bound, gaps=kind == "stepwise")
        leave = steps.end
    visits: List[List[cp_model.IntVar]] = [[] for _ in range(n_t)]
    for r in range(n_r):
        circuit = [(0, 0, model.NewBoolVar(f"idle_{r}"))]        # node 0: the robot's start
        for j in range(n_t):
            skip = model.NewBoolVar(f"skip_{r}_{j}")
            circuit.append((j + 1, j + 1, skip))
            visits[j].append(skip.Not())
            circuit.append((j + 1, 0, model.NewBoolVar(f"last_{r}_{j}")))
            if instance.deadline(r) < float("inf"):   # a robot that leaves: its tasks finished before
                model.Add(arrival[j] + service[j] <= scale.floor(instance.deadline(r))).OnlyEnforceIf(skip.Not())
            first_leg = chains[r, instance.node(j)]
            if first_leg < float("inf"):
                lit = arc_of[r, -1, j] = model.NewBoolVar(f"first_{r}_{j}")
                circuit.append((0, j + 1, lit))
                model.Add(arrival[j] >= ready[r] + scale.floor(float(first_leg))).OnlyEnforceIf(lit)
                if instance.committed(r) == j:
                    model.Add(lit == 1)
            for i in range(n_t):
                leg = chains[instance.node(i), instance.node(j)]
                if i == j or leg == float("inf"):
                    continue
                lit = arc_of[r, i, j] = model.NewBoolVar(f"arc_{r}_{i}_{j}")
                circuit.append((i + 1, j + 1, lit))
                model.Add(arrival[j] >= leave[i] + scale.floor(float(leg))).OnlyEnforceIf(lit)
                if steps is not None:
                    model.Add(steps.number[j] >= steps.number[i] + 1 + steps.wait[j]).OnlyEnforceIf(lit)
                    if not steps.gaps:
                        model.Add(steps.number[j] <= steps.number[i] + 1 + steps.wait[j]).OnlyEnforceIf(lit)
        model.AddCircuit(circuit)
    if steps is not None:
        _departures(model, instance, arrival, steps, arc_of)
    for j in range(n_t):
        model.AddExactlyOne(visits[j])
        reach = min(ready[r] + scale.floor(float(chains[r, instance.node(j)])) if chains[r, instance.node(j)] < float("inf")
                    else horizon for r in range(n_r))
        model.Add(arrival[j] >= min(max(reach, release[j]), horizon))
        model.Add(makespan >= leave[j])
        for p in instance.predecessors[j]:
            model.Add(arrival[j] >= arrival[p] + service[p])
    if least_finishes and cap is None:
        raise ValueError("least_finishes needs a makespan cap")
    if cap is None:
        model.Minimize(makespan)
    elif least_finishes:
        model.Add(makespan <= cap)
        model.Minimize(sum(leave))
    else:
        model.Add(makespan <= cap)
    if hint is not None and hint.complete:
        _hint(model, arc_of, hint)

    solver, outcome = solve(model, budget)
    routes = None
    optimum = None
    if outcome.has_solution:
        routes = []
        for r in range(n_r):
            route, at = [], -1
            while True:
                nxt = next((j for j in range(n_t) if (r, at, j) in arc_of and solver.Value(arc_of[r, at, j])), None)
                if nxt is None:
                    break
                route.append(nxt)
                at = nxt
            routes.append(route)
        optimum = scale.seconds(outcome.objective if cap is None else max(solver.Value(e) for e in leave))
    if cap is not None:
        lower = scale.seconds(cap + 1) if outcome.status == "INFEASIBLE" else 0.0
        state = (f"makespan <= {scale.seconds(cap):.2f} s infeasible" if outcome.status == "INFEASIBLE" else
                 f"makespan <= {scale.seconds(cap):.2f} s " + (f"feasible ({optimum:.2f} s)" if routes else "not decided"))
        status = (f"{kind} relaxation ({arcs} arcs): {state}, CP-SAT {outcome.status} "
                  f"after {outcome.deterministic_seconds:.1f} deterministic s")
        return RelaxationResult(kind, lower, optimum, routes, status, outcome, {"arcs": arcs, "cap": cap, **outcome.as_dict()})
    # INFEASIBLE: no schedule at all, so no plan under the step rules either.
    lower = {"INFEASIBLE": float("inf"), "MODEL_INVALID": 0.0}.get(outcome.status, max(scale.seconds(outcome.bound), 0.0))
    state = "optimal" if outcome.optimal else ("feasible" if routes else "no schedule")
    status = (f"{kind} relaxation ({arcs} arcs): {state}, bound {lower:.2f} s, CP-SAT {outcome.status} "
              f"after {outcome.deterministic_seconds:.1f} deterministic s")
    return RelaxationResult(kind, lower, optimum, routes, status, outcome, {"arcs": arcs, **outcome.as_dict()})


@dataclass
class _Steps:
    """The synchronous relaxation's step variables, per task."""

    number: list      # step number (expression)
    member: list      # member[j][k]: task j is finished in step k
    begin: list       # start of the task's step
    end: list         # end of the task's step
    wait: list        # steps between the robot's previous finish and this one (0 for stepwise)
    next_step: list   # synchronous: wait == 0, finished in the step after the robot's previous finish
    gaps: bool        # stepwise: steps that finish nothing lie between


def _steps(model: cp_model.CpModel, instance: SchedulingInstance, arrival, service, horizon: int,
           upper_bound: Optional[float], gaps: bool) -> _Steps:
    """Numbered finishing steps. Synchronous: each step starts when the one before ends (steps
    that finish nothing are dropped). Stepwise (`gaps`): each from its start to its end, the
    next one starting at that end or later (steps that finish nothing lie between)."""
    n_r, n_t = instance.n_robots, instance.n_tasks
    count = n_t
    if upper_bound is not None:
        # A finishing step lasts at least min_step and some task's shortest incoming leg + service.
        travel = instance.travel_rows
        least = min(min(travel[a][n_r + j] for a in range(n_r + n_t) if a != n_r + j) + instance.service[j]
                    for j in range(n_t))
        count = max(1, min(n_t, int(upper_bound / max(least, instance.min_step) + 1e-9)))
    start = [model.NewIntVar(0, horizon, f"start_{k}") for k in range(count + (0 if gaps else 1))]
    stop = [model.NewIntVar(0, horizon, f"stop_{k}") for k in range(count)] if gaps else start[1:]
    if not gaps:
        model.Add(start[0] == 0)
    used = [model.NewBoolVar(f"used_{k}") for k in range(count)]
    member = [[model.NewBoolVar(f"in_step_{j}_{k}") for k in range(count)] for j in range(n_t)]
    min_step = BOUND_TIME.floor(instance.min_step)
    for k in range(count):
        model.Add(stop[k] >= start[k] + min_step).OnlyEnforceIf(used[k])
        model.Add(stop[k] == start[k]).OnlyEnforceIf(used[k].Not())
        members = [member[j][k] for j in range(n_t)]
        model.Add(sum(members) <= n_r * used[k])
        model.Add(sum(members) >= used[k])
        if k + 1 < count:
            model.AddImplication(used[k + 1], used[k])
            if gaps:
                model.Add(start[k + 1] >= stop[k])
    result = _Steps([], member, [], [], [], [], gaps)
    for j in range(n_t):
        model.AddExactlyOne(member[j])
        result.number.append(sum(k * member[j][k] for k in range(count)))
        begin = model.NewIntVar(0, horizon, f"begin_{j}")
        end = model.NewIntVar(0, horizon, f"end_{j}")
        for k in range(count):
            model.Add(begin == start[k]).OnlyEnforceIf(member[j][k])
            model.Add(end == stop[k]).OnlyEnforceIf(member[j][k])
        model.Add(end >= arrival[j] + service[j])
        result.begin.append(begin)
        result.end.append(end)
        if gaps:
            result.wait.append(0)
            continue
        wait = model.NewIntVar(0, count, f"wait_{j}")
        follows = model.NewBoolVar(f"next_step_{j}")
        model.Add(wait == 0).OnlyEnforceIf(follows)
        model.Add(wait >= 1).OnlyEnforceIf(follows.Not())
        result.wait.append(wait)
        result.next_step.append(follows)
    return result


def _departures(model: cp_model.CpModel, instance: SchedulingInstance, arrival, steps: _Steps,
                arc_of: Dict[tuple, cp_model.IntVar]) -> None:
    """Where a task's finisher sets off in its step, and so when it arrives (one leg after the
    step's start): its own start if it is the robot's first task, or the goal of a task
    finished in an earlier step (its previous one, or one it passed over in a step between; a
    robot stands on no other node). Synchronous: finished in the first step, or in the step
    right after its previous task's, from there; it may arrive later than the leg says, which
    keeps the model easy to solve and its bound a bound. Stepwise: see _way_there."""
    n_r, n_t = instance.n_robots, instance.n_tasks
    travel = instance.travel_rows
    depart: Dict[tuple, cp_model.IntVar] = {}
    for j in range(n_t):
        b = instance.node(j)
        options = []
        for w in range(n_t):
            if w != j and instance.leg_feasible(instance.node(w), b):
                lit = depart[w, j] = model.NewBoolVar(f"depart_{w}_{j}")
                model.Add(steps.number[w] + 1 <= steps.number[j]).OnlyEnforceIf(lit)
                options.append((lit, travel[instance.node(w)][b]))
        for r in range(n_r):
            if (r, -1, j) in arc_of and instance.leg_feasible(r, b):
                lit = depart[-1 - r, j] = model.NewBoolVar(f"depart_start_{r}_{j}")
                model.AddImplication(lit, arc_of[r, -1, j])
                options.append((lit, travel[r][b]))
        model.AddExactlyOne([lit for lit, _ in options])
        leg = sum(BOUND_TIME.floor(t) * lit for lit, t in options)
        model.Add(arrival[j] >= steps.begin[j] + leg)
        if steps.gaps:
            # Exactly one leg later, to a tick: floor(begin + leg) <= floor(begin) + floor(leg) + 1.
            model.Add(arrival[j] <= steps.begin[j] + leg + 1)
    if steps.gaps:
        _way_there(model, instance, steps, arc_of, depart)
        return
    for (r, i, j), lit in arc_of.items():
        origin = -1 - r if i < 0 else i
        right_after = steps.member[j][0] if i < 0 else steps.next_step[j]
        if (origin, j) in depart:
            model.AddImplication(right_after, depart[origin, j]).OnlyEnforceIf(lit)
        else:
            model.AddBoolOr([lit.Not(), right_after.Not()])


def _way_there(model: cp_model.CpModel, instance: SchedulingInstance, steps: _Steps,
               arc_of: Dict[tuple, cp_model.IntVar], depart: Dict[tuple, cp_model.IntVar]) -> None:
    """Stepwise: a finisher got onto the goal it sets off from over whole steps after its
    previous task's step ended (or from its start): the step starts at least the quickest chain
    of legs from there later (no chain: not from there)."""
    chains = instance.chain_times()
    previous: Dict[tuple, list] = {}     # (previous task or -1 - robot, task): arc literals
    for (r, i, j), lit in arc_of.items():
        previous.setdefault((i if i >= 0 else -1 - r, j), []).append(lit)
    for (i, j), lits in previous.items():
        after = model.NewBoolVar(f"after_{i}_{j}")
        model.Add(after == sum(lits))       # one robot at most finishes j right after i
        node = instance.node(i) if i >= 0 else -1 - i
        terms = []
        for (w, jj), lit in depart.items():
            if jj != j or w < 0:
                continue
            chain = float(chains[node, instance.node(w)])
            if chain == float("inf"):
                model.AddImplication(after, lit.Not())
            else:
                terms.append(BOUND_TIME.floor(chain) * lit)
        left = steps.end[i] if i >= 0 else 0
        model.Add(steps.begin[j] >= left + sum(terms)).OnlyEnforceIf(after)


def _hint(model: cp_model.CpModel, arc_of: Dict[tuple, cp_model.IntVar], plan: Plan) -> None:
    """The plan's finishers' routes as the first solution's arcs (an event plan: its routes)."""
    if plan.instance.decision_mode == "event":
        routes = [list(route) for route in plan.robot_tasks]
    else:
        run = simulate_joint_actions(plan.instance, [])
        routes = [[] for _ in range(plan.instance.n_robots)]
        for goals in plan.joint_actions:
            for done in sorted(run.apply(goals).finished, key=lambda f: f.robot):
                routes[done.robot].append(done.task)
    chosen = set()
    for r, route in enumerate(routes):
        at = -1
        for j in route:
            chosen.add((r, at, j))
            at = j
    for key, lit in arc_of.items():
        model.AddHint(lit, key in chosen)
