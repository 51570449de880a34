"""Probing: a relaxation's lower bound raised by proving makespan caps infeasible.

When a relaxation is not solved within its time limit its bound stays far under its optimum,
yet "no schedule of makespan at most L" is often proven quickly: with the makespan capped CP-SAT
prunes every partial schedule that cannot end by L, which optimising from above does not.
`probe_lower_bound` bisects L between the proven bound and the best known makespan on one
relaxation (solve_relaxation with `makespan_cap`): a cap proven infeasible raises the bound to
the cap plus a tick, a schedule found within a cap shows the relaxation's optimum lies at or
below its makespan (no cap from there on can be proven; its routes are candidate plans), and
an undecided cap is taken as out of reach, like a feasible one. The probes share one
deterministic time budget, so the result is reproducible.

Soundness: every plan under the step rules of makespan M gives a schedule of the relaxation
of at most floor(M) ticks (relaxation.py: each relaxation is valid, times rounded down). If
no schedule within c ticks exists, every plan has floor(M) >= c + 1, so M >= c + 1 ticks: the
bound never exceeds the step-rule optimum. The cap also bounds the number of finishing steps
the synchronous and stepwise relaxations get (a plan shorter than c + 1 ticks has at most that
many over the least step duration), which keeps the same argument.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import List

from marl_mrta.baselines.cpsat import BOUND_TIME, CpSatBudget
from marl_mrta.baselines.plan import SchedulingInstance
from marl_mrta.baselines.relaxation import solve_relaxation

#: A probe gets at most this share of the whole budget (the rest when less is left): a cap
#: CP-SAT cannot decide then stops one probe, not the bisection.
PROBE_SHARE = 0.25


@dataclass
class ProbeResult:
    kind: str
    lower_bound: float                      # s, proven: the highest infeasible cap + a tick, else `lower`
    routes: List[List[List[int]]] = field(default_factory=list)   # of schedules found within caps
    probes: int = 0
    deterministic_seconds: float = 0.0
    status: str = ""                        # one line


def probe_lower_bound(instance: SchedulingInstance, budget: CpSatBudget, kind: str, lower: float,
                      upper: float) -> ProbeResult:
    """Bisect makespan caps of the `kind` relaxation between `lower` (a proven bound, s) and
    `upper` (a makespan the relaxation reaches: the best plan's, or its own solution's), within
    budget.time_limit deterministic seconds for all probes together."""
    low_cap = BOUND_TIME.floor(lower)                 # the least cap whose proof raises the bound
    high_cap = _ticks(upper) - 1                      # caps from floor(upper) up have a schedule
    bound = lower
    result = ProbeResult(kind, lower)
    decided: List[str] = []
    share = PROBE_SHARE * budget.time_limit
    while low_cap <= high_cap:
        left = budget.time_limit - result.deterministic_seconds
        if left < 0.1 * share:                        # spent
            break
        cap = (low_cap + high_cap + 1) // 2
        # Half a tick over the cap: floor() gives the cap itself, not one under. No upper bound
        # but the cap: the step count then rests on the cap alone (see above).
        probe = solve_relaxation(instance, replace(budget, time_limit=min(left, share)), kind,
                                 known_lower_bound=bound, makespan_cap=BOUND_TIME.seconds(cap + 0.5))
        result.probes += 1
        result.deterministic_seconds += probe.outcome.deterministic_seconds if probe.outcome else 0.0
        if probe.outcome is None:                     # not built (memory): nothing to probe with
            break
        if probe.outcome.status == "INFEASIBLE":
            bound = max(bound, probe.lower_bound)
            low_cap = cap + 1
            decided.append(f"{BOUND_TIME.seconds(cap):.2f} no")
        elif probe.routes is not None:
            result.routes.append(probe.routes)
            high_cap = min(cap, _ticks(probe.optimum)) - 1
            decided.append(f"{BOUND_TIME.seconds(cap):.2f} yes")
        else:
            high_cap = cap - 1
            decided.append(f"{BOUND_TIME.seconds(cap):.2f} ?")
    result.lower_bound = bound
    result.status = (f"{kind} relaxation probed: bound {bound:.2f} s (from {lower:.2f} s), {result.probes} caps "
                     f"({', '.join(decided) or 'none'}) in {result.deterministic_seconds:.1f} deterministic s")
    return result


def _ticks(seconds: float) -> int:
    """Whole ticks in `seconds`; a count of ticks in seconds may lie a hair under it in floating
    point. Only where the bisection stops depends on it, never a bound."""
    return BOUND_TIME.floor(seconds + 1e-9)
