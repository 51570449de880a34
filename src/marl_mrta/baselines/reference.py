"""The planners' view of a scenario and the reference every method is measured against.

`scheduling_instance` reduces a scenario to the nominal numbers the planners work on (the
travel-time table of the configured travel model, min_step, the longest leg the goal timeout
allows: a fixed timeout's seconds, or with an auto goal timeout every finite leg). `solve_reference`
finds the best known plan under the step rules and a proven lower bound on the optimum;
`choose_solver` is where it is decided which solver serves a scenario:

- "astar" when a state's (n_tasks+1)^n_robots joint actions and the tasks are few (exact.py,
  proves the optimum; for the lab scenarios in well under a second);
- "cpsat" otherwise, and when the A* stops at a budget: the asynchronous and the synchronous
  relaxations, and the stepwise one when the synchronous one was solved, give lower bounds and
  routes (relaxation.py), the step model the best plan it finds from the best one so far, and
  its own bound (step_model.py); when a gap remains and the last relaxation was not solved,
  makespan caps on the stepwise relaxation proven infeasible raise the bound, within one more
  time limit for all caps (probing.py; the schedules found within caps are candidate plans).

With the instance's hold_successors (the episodes run under the hold) the A* searches the hold's
rules; where CP-SAT serves, its step models are of the paper's rules, so their plan competes (it
keeps its makespan under the hold), and of their bounds only the asynchronous relaxation's is kept,
which holds under the hold too (relaxation.py).

The auction's plan is the first upper bound, and plans of other methods passed in compete for
the best known. Proven optimal means the gap between the best plan and the bound is 0 (within
GAP_TOLERANCE). Training, evaluation, execution and the benchmarks all take the reference from
here.
"""
from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass, field
from typing import Dict, List, Optional, Sequence, Tuple, Union

from marl_mrta.baselines.auction import solve_auction
from marl_mrta.baselines.cpsat import STEP_TIME
from marl_mrta.baselines.exact import batch_size, refusal, root_lower_bound, solve_exact
from marl_mrta.baselines.plan import (INFINITE_TIME, Plan, SchedulingInstance, decode_task_lists, plan_from_run,
                                     under_either_rules)
from marl_mrta.baselines.probing import probe_lower_bound
from marl_mrta.baselines.relaxation import solve_relaxation
from marl_mrta.baselines.settings import BaselineSettings, load_baseline_settings
from marl_mrta.baselines.step_model import solve_step_model
from marl_mrta.env.factory import scenario_travel_table
from marl_mrta.model.goal_timeout import GoalTimeout
from marl_mrta.model.scenario import Scenario, ScenarioError

#: s: a best plan within this of the lower bound is proven optimal (the CP-SAT models count time
#: in microseconds, rounded, so their bounds sit a few ticks under an exact optimum).
GAP_TOLERANCE = 1e-4


@dataclass
class Reference:
    """The best known plan of a scenario and what is proven about the optimum."""

    plan: Plan                       # the best known plan, as method "exact" (proven_optimal set)
    lower_bound: float               # s, proven: no plan under the step rules is shorter
    solver: str                      # astar | cpsat: which one served (choose_solver)
    best_source: str                 # what found the best plan (astar, cpsat_steps, auction, ...)
    bound_source: str                # what proved the lower bound
    log: List[str] = field(default_factory=list)   # one line per solver run
    seconds: float = 0.0
    bounds: Dict[str, float] = field(default_factory=dict)   # s, the best bound of each source

    @property
    def best_makespan(self) -> float:
        return self.plan.makespan

    @property
    def gap(self) -> float:
        """(best − bound) / best; 0 when proven optimal, inf without a plan."""
        if not math.isfinite(self.best_makespan):
            return math.inf
        if self.best_makespan - self.lower_bound <= GAP_TOLERANCE:
            return 0.0
        return (self.best_makespan - self.lower_bound) / self.best_makespan

    @property
    def proven_optimal(self) -> bool:
        return self.gap == 0.0

    @property
    def ratio_basis(self) -> str:
        """What a ratio to best_makespan is a ratio to: "exact" (a proven optimum) or "best known"."""
        return "exact" if self.proven_optimal else "best known"

    def gap_text(self) -> str:
        """The gap in percent, and in seconds where the percentage rounds to 0.0 (a bound a few
        of the relaxations' 10 ms ticks under the plan)."""
        text = f"gap {100 * self.gap:.1f} %"
        if round(100 * self.gap, 1) == 0.0:
            text += f" ({self.best_makespan - self.lower_bound:.3f} s)"
        return text

    def describe(self) -> str:
        """One line: best, bound, gap and who found them."""
        if not math.isfinite(self.best_makespan):
            return f"reference: no plan found, lower bound {self.lower_bound:.2f} s ({self.bound_source}), {self.seconds:.1f} s"
        state = "proven optimal" if self.proven_optimal else f"{self.gap_text()}, NOT proven optimal"
        return (f"reference: best {self.best_makespan:.2f} s ({self.best_source}), lower bound {self.lower_bound:.2f} s "
                f"({self.bound_source}), {state}, {self.seconds:.1f} s")

    def as_dict(self) -> Dict[str, object]:
        return {"best_makespan": self.best_makespan, "lower_bound": self.lower_bound, "gap": self.gap,
                "proven_optimal": self.proven_optimal, "method": self.best_source, "bound_method": self.bound_source,
                "solver": self.solver, "seconds": self.seconds, "log": list(self.log)}


def scheduling_instance(scenario: Scenario, min_step: float,
                        goal_timeout: Union[float, GoalTimeout] = INFINITE_TIME,
                        precedence_margin: float = 0.0, hold_successors: bool = False,
                        decision_mode: str = "synchronous") -> SchedulingInstance:
    """The scenario in nominal numbers: plans always come from the nominal travel times.
    goal_timeout: the longest leg a plan may use (s), or the rule (model/goal_timeout.py): fixed,
    its seconds; auto, every finite leg (each leg's own timeout is longer than its nominal time).
    ScenarioError naming the first task no robot can reach (every way to its goal, over other
    goals, has a leg beyond the goal timeout, or there is no way at all), so that no plan could
    ever finish it."""
    limit = goal_timeout.planning_limit if isinstance(goal_timeout, GoalTimeout) else float(goal_timeout)
    instance = SchedulingInstance.from_scenario(scenario, scenario_travel_table(scenario), min_step, limit,
                                                precedence_margin, hold_successors, decision_mode)
    unreachable = instance.unreachable_tasks()
    if unreachable:
        task = scenario.tasks[unreachable[0]]
        why = (f"every way there has a leg longer than the goal timeout ({limit:g} s)" if math.isfinite(limit)
               else "no way leads there")
        raise ScenarioError(f"{scenario.source}: <task id=\"{task.id}\">: no robot can reach its goal "
                            f"({task.goal.x:g}, {task.goal.y:g}): {why}")
    return instance


def choose_solver(instance: SchedulingInstance, settings: BaselineSettings) -> str:
    """astar when a state's joint actions and the tasks are few enough and the batch fits the A*'s
    memory budget, else cpsat."""
    if batch_size(instance) <= settings.astar_max_batch and instance.n_tasks <= settings.astar_max_tasks \
            and refusal(instance, settings.astar) is None:
        return "astar"
    return "cpsat"


def _usable(plan: Optional[Plan]) -> bool:
    return plan is not None and plan.usable


def solve_reference(instance: SchedulingInstance, settings: Optional[BaselineSettings] = None,
                    candidates: Sequence[Plan] = ()) -> Reference:
    """The best known plan and the proven lower bound, within the settings' budgets."""
    settings = settings or load_baseline_settings()
    if instance.decision_mode == "event":
        return solve_event_reference(instance, settings, candidates)
    started = time.monotonic()
    solver = choose_solver(instance, settings)
    log: List[str] = []
    plans: List[Tuple[Plan, str]] = [(p, p.method) for p in candidates if _usable(p)]
    auction = under_either_rules(lambda inst: solve_auction(inst, settings.auction_objective), instance)
    if _usable(auction):
        plans.append((auction, "auction"))
    bounds: List[Tuple[float, str]] = [(root_lower_bound(instance), "root bound")]

    def best() -> Optional[Plan]:
        """The shortest plan; of equal ones the solver's last (A* and CP-SAT after the heuristics)."""
        return min(reversed(plans), key=lambda p: p[0].makespan)[0] if plans else None

    astar_done = False
    if solver == "astar":
        upper = best()
        plan = solve_exact(instance, upper_bound=upper.makespan if upper else None, budget=settings.astar)
        if plan.proven_optimal:
            plans.append((plan, "astar"))
            bounds.append((plan.makespan, "astar"))
            astar_done = True
            log.append(f"A*: optimal {plan.makespan:.2f} s, {plan.details['expansions']} expansions, "
                       f"{plan.details['seconds']:.2f} s")
        else:
            bounds.append((plan.details["lower_bound"], "astar"))
            astar_done = not plan.details["status"].startswith("A* stopped")
            log.append(f"{plan.details['status']}; lower bound {plan.details['lower_bound']:.2f} s")
    if not astar_done and instance.hold_successors:
        # The step models are of the paper's rules, under which a robot cannot wait for a
        # predecessor: their plans keep their makespans under the hold, their bounds do not hold.
        # The asynchronous relaxation's does (a held robot's service start is an arrival it allows).
        paper = solve_reference(dataclasses.replace(instance, hold_successors=False),
                                dataclasses.replace(settings, astar_max_tasks=0))
        log.extend(f"paper's rules: {line}" for line in paper.log)
        log.append("hold_successors: the plan of the paper's rules competes; only the asynchronous bound is kept")
        if _usable(paper.plan):
            plans.append((paper.plan, f"{paper.best_source} (paper's rules)"))
        if "asynchronous relaxation" in paper.bounds:
            bounds.append((paper.bounds["asynchronous relaxation"], "asynchronous relaxation"))
    elif not astar_done:
        solved = False
        stepwise_reached = math.inf      # the makespan of a stepwise schedule found
        for kind in ("asynchronous", "synchronous", "stepwise"):
            if kind == "stepwise" and not solved:
                break           # tighter and harder than the synchronous one: hopeless when that is not solved
            upper = best()
            relaxed = solve_relaxation(instance, settings.cpsat, kind, upper, upper.makespan if upper else None,
                                       max(b for b, _ in bounds))
            log.append(relaxed.status)
            solved = relaxed.outcome is not None and relaxed.outcome.optimal
            bounds.append((relaxed.lower_bound, f"{kind} relaxation"))
            if relaxed.routes is not None:
                decoded = plan_from_run("exact", decode_task_lists(instance, relaxed.routes), solver=f"{kind} routes")
                if _usable(decoded):
                    plans.append((decoded, f"{kind} relaxation routes"))
            if kind == "stepwise" and relaxed.optimum is not None:
                stepwise_reached = relaxed.optimum
        known = max(b for b, _ in bounds)
        stepped = solve_step_model(instance, settings.cpsat, best(), known)
        log.append(stepped.status)
        if stepped.plan is not None:
            plans.append((stepped.plan, "cpsat step model"))
        bounds.append((stepped.lower_bound, "cpsat step model"))
        known, upper = max(b for b, _ in bounds), best()
        if not solved and upper is not None and upper.makespan - known > GAP_TOLERANCE:
            # A gap the last relaxation did not close: caps on the stepwise one, the tightest.
            probed = probe_lower_bound(instance, settings.cpsat, "stepwise", known, min(upper.makespan, stepwise_reached))
            log.append(probed.status)
            bounds.append((probed.lower_bound, "stepwise relaxation probed"))
            for routes in probed.routes:
                decoded = plan_from_run("exact", decode_task_lists(instance, routes), solver="stepwise probe routes")
                if _usable(decoded):
                    plans.append((decoded, "stepwise probe routes"))
    lower, bound_source = max(bounds, key=lambda b: b[0])
    chosen = best()
    if chosen is None:
        plan = Plan("exact", [[] for _ in range(instance.n_robots)], [], math.inf, 0, details={"solver": solver},
                    instance=instance)
        source = "none"
    else:
        source = next(name for p, name in plans if p is chosen)
        lower = min(lower, chosen.makespan)
        plan = Plan("exact", chosen.robot_tasks, chosen.joint_actions, chosen.makespan, chosen.logic_violations,
                    details={**chosen.details, "solver": source, "lower_bound": lower}, instance=instance)
    by_source: Dict[str, float] = {}
    for bound, name in bounds:
        by_source[name] = max(bound, by_source.get(name, -math.inf))
    reference = Reference(plan, lower, solver, source, bound_source, log, time.monotonic() - started, by_source)
    plan.proven_optimal = reference.proven_optimal
    plan.details["gap"] = reference.gap
    return reference


def solve_event_reference(instance: SchedulingInstance, settings: BaselineSettings,
                          candidates: Sequence[Plan] = ()) -> Reference:
    """Event mode's reference: the asynchronous CP-SAT model (relaxation.py) over direct legs, which
    is event mode's own schedule (a robot leaves a task at its finish and drives straight to its
    next, and serves it no earlier than its predecessors' finishes), within the CP-SAT budget. Its
    bound is a lower bound of every event-mode plan; its routes, dispatched as events
    (plan.py), compete with the auction's and the candidates' plans for the best known.
    Solved to the model's 10 ms ticks, it is solved again in microseconds from its plan, which
    proves the optimum (legs rounded down one by one leave a few ticks of gap)."""
    started = time.monotonic()
    plans: List[Tuple[Plan, str]] = [(p, p.method) for p in candidates if _usable(p)]
    auction = solve_auction(instance, settings.auction_objective)
    if _usable(auction):
        plans.append((auction, "auction"))
    bounds: List[Tuple[float, str]] = [(0.0, "none")]   # the A*'s root bound is of the step rules
    upper = min((p for p, _ in plans), key=lambda p: p.makespan, default=None)
    relaxed = solve_relaxation(instance, settings.cpsat, "asynchronous", upper, upper.makespan if upper else None,
                               direct_legs=True)
    log = [relaxed.status]
    bounds.append((relaxed.lower_bound, "asynchronous model"))
    if relaxed.routes is not None:
        decoded = plan_from_run("exact", decode_task_lists(instance, relaxed.routes), solver="asynchronous routes")
        if _usable(decoded):
            plans.append((decoded, "cpsat asynchronous model"))
    best_plan = min((p for p, _ in plans), key=lambda p: p.makespan, default=None)
    if relaxed.outcome is not None and relaxed.outcome.optimal and best_plan is not None \
            and best_plan.makespan - relaxed.lower_bound > GAP_TOLERANCE:
        # Optimal to the model's 10 ms ticks: the same model in microseconds, from that plan, closes
        # the gap the ticks leave (legs rounded down one by one), or narrows it.
        fine = solve_relaxation(instance, settings.cpsat, "asynchronous", best_plan, best_plan.makespan,
                                relaxed.lower_bound, scale=STEP_TIME, direct_legs=True)
        log.append(f"in microseconds: {fine.status}")
        bounds.append((fine.lower_bound, "asynchronous model"))
        if fine.routes is not None:
            decoded = plan_from_run("exact", decode_task_lists(instance, fine.routes), solver="asynchronous routes")
            if _usable(decoded):
                plans.append((decoded, "cpsat asynchronous model"))
    lower, bound_source = max(bounds, key=lambda b: b[0])
    if not plans:
        plan = Plan("exact", [[] for _ in range(instance.n_robots)], [], math.inf, 0,
                    details={"solver": "cpsat", "decision_mode": "event"}, instance=instance)
        source = "none"
    else:
        chosen, source = min(reversed(plans), key=lambda p: p[0].makespan)
        lower = min(lower, chosen.makespan)
        plan = Plan("exact", chosen.robot_tasks, [], chosen.makespan, 0,
                    details={**chosen.details, "solver": source, "lower_bound": lower, "decision_mode": "event"},
                    instance=instance)
    by_source: Dict[str, float] = {}
    for bound, name in bounds:
        by_source[name] = max(bound, by_source.get(name, -math.inf))
    reference = Reference(plan, lower, "cpsat", source, bound_source, log, time.monotonic() - started, by_source)
    plan.proven_optimal = reference.proven_optimal
    plan.details["gap"] = reference.gap
    return reference


def exact_reference(instance: SchedulingInstance, settings: Optional[BaselineSettings] = None) -> Plan:
    """The reference's best plan (proven optimal when its gap is 0)."""
    return solve_reference(instance, settings).plan


def scenario_reference(scenario: Scenario, min_step: float, settings: Optional[BaselineSettings] = None,
                       goal_timeout: Union[float, GoalTimeout] = INFINITE_TIME, hold_successors: bool = False
                       ) -> Tuple[Plan, SchedulingInstance]:
    """exact_reference of a scenario, with the instance it was solved on."""
    instance = scheduling_instance(scenario, min_step, goal_timeout, hold_successors=hold_successors)
    return exact_reference(instance, settings), instance
