"""What the CP-SAT models (step_model.py, relaxation.py) share: budgets, time units, the solve.

CP-SAT works on integers: times are ticks of a TimeScale, microseconds for the step model
(exact order of arrivals), 10 ms rounded down for the relaxations (bounds).

Reproducibility: the time limit is CP-SAT's deterministic time (about seconds of one core's
work, counted the same way on every machine), so a solve with the same settings and seed
returns the same answer on a loaded or an idle machine. The wall-clock limit (WALL_FACTOR times
the deterministic limit) only guards against a machine so slow that deterministic seconds take
much longer; a solve stopped by it may differ from run to run. With more than one worker CP-SAT
runs several searches in parallel (interleaved, deterministically): they find the same optimum
value but may return another plan of that value than one worker does.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Dict, Optional

from ortools.sat.python import cp_model

WALL_FACTOR = 4.0


@dataclass(frozen=True)
class CpSatBudget:
    """Limits of one CP-SAT solve (config/task_baselines.yaml, `cpsat`)."""

    time_limit: float = 30.0     # s of CP-SAT deterministic time per model
    workers: int = 1
    seed: int = 0
    memory_mb: float = 2048.0    # CP-SAT stops near this; models whose estimate exceeds it are not built


@dataclass(frozen=True)
class TimeScale:
    """Integer time units of a model."""

    per_second: int

    def ticks(self, seconds: float) -> int:
        return int(round(seconds * self.per_second))

    def floor(self, seconds: float) -> int:
        """Rounded down: a lower bound stays a lower bound in ticks."""
        return int(math.floor(seconds * self.per_second))

    def seconds(self, value: float) -> float:
        return value / self.per_second


#: The step model: microseconds, so rounding cannot change which of two arrivals comes first
#: unless they are less than a microsecond apart.
STEP_TIME = TimeScale(1_000_000)
#: The relaxations: 10 ms, rounded down. Their arrivals are only known to a tick, and at finer
#: ticks the search spends itself on improvements of a tick at a time; a bound stays a bound.
BOUND_TIME = TimeScale(100)


@dataclass
class SolveOutcome:
    """How a solve ended: status name, the best solution's objective and the proven bound (ticks)."""

    status: str                      # OPTIMAL, FEASIBLE, INFEASIBLE, UNKNOWN, MODEL_INVALID
    objective: Optional[float]
    bound: float
    wall_seconds: float
    deterministic_seconds: float
    stats: Dict[str, float] = field(default_factory=dict)

    @property
    def has_solution(self) -> bool:
        return self.status in ("OPTIMAL", "FEASIBLE")

    @property
    def optimal(self) -> bool:
        return self.status == "OPTIMAL"

    def as_dict(self) -> Dict[str, object]:
        return {"status": self.status, "wall_seconds": round(self.wall_seconds, 3),
                "deterministic_seconds": round(self.deterministic_seconds, 3), **self.stats}


#: Search parameters of every model here. Their linear relaxations give no bound beyond what
#: propagation finds (the makespan is a max of sums over literals) while the LP takes most of the
#: time, and probing in presolve adds millions of clauses on the larger models: without both,
#: the 16-robot relaxation is solved in seconds instead of not at all within a minute.
SEARCH_PARAMETERS = {"linearization_level": 0, "cp_model_probing_level": 0}


def solve(model: cp_model.CpModel, budget: CpSatBudget) -> "tuple[cp_model.CpSolver, SolveOutcome]":
    solver = cp_model.CpSolver()
    params = solver.parameters
    for name, value in SEARCH_PARAMETERS.items():
        setattr(params, name, value)
    params.max_deterministic_time = budget.time_limit
    params.max_time_in_seconds = WALL_FACTOR * budget.time_limit
    params.num_workers = budget.workers
    params.random_seed = budget.seed
    params.max_memory_in_mb = int(budget.memory_mb)
    params.interleave_search = budget.workers > 1
    params.log_search_progress = False
    started = time.monotonic()
    status = solver.Solve(model)
    wall = time.monotonic() - started
    name = solver.StatusName(status)
    has = status in (cp_model.OPTIMAL, cp_model.FEASIBLE)
    outcome = SolveOutcome(name, solver.ObjectiveValue() if has else None, solver.BestObjectiveBound(),
                           wall, solver.ResponseProto().deterministic_time,
                           {"conflicts": solver.NumConflicts(), "branches": solver.NumBranches()})
    return solver, outcome
