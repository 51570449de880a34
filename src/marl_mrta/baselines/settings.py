"""Settings of the baseline planners (config/task_baselines.yaml), read strictly."""
from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import Optional, Union

from marl_mrta.baselines.cpsat import CpSatBudget
from marl_mrta.baselines.exact import AStarBudget
from marl_mrta.common.config import read_yaml
from marl_mrta.common.paths import default_config_path


@dataclass(frozen=True)
class GaSettings:
    population: int = 60
    generations: int = 150
    stall_generations: int = 50
    tournament: int = 3
    elite: int = 2
    crossover_rate: float = 0.9
    mutation_rate: float = 0.4
    max_evaluations: int = 20000   # decoded chromosomes, evolution and the final search together
    kick_mutations: int = 3        # random mutations per kick of the final iterated local search


@dataclass(frozen=True)
class RolloutBudget:
    """The rollout planner's search (evaluation/rollout.py)."""
    alternatives: int = 3          # tried at each robot's turn: the actor's most likely other actions, and
                                   # as many of the nearest open tasks its precedence mask holds back
    max_rollouts: int = 1000       # episodes played out at the most, over all orientations; then the actor decides
    orientations: int = 8          # the floor as it is, then turned and mirrored (a set actor's): one rollout each


@dataclass(frozen=True)
class LookaheadBudget:
    """A robot's own decision with lookahead (evaluation/lookahead.py): the team's step searched by rollout."""
    alternatives: int = 3          # at each turn: the actor's most likely other actions, and as many held-back nearest tasks
    orientations: int = 8          # the floor as it is, then turned and mirrored: a search each
    max_play_outs: int = 500       # per step and robot, over all orientations; then the best found is taken
    opening: Optional[RolloutBudget] = None   # the rollout plan made at the first step, kept while no search beats it


@dataclass(frozen=True)
class ReplanSettings:
    """A live fleet's re-planning (baselines/replan.py)."""
    method: str = "cpsat"          # insertion | ga (insertion, then the GA) | cpsat (both, then CP-SAT)
    time_limit: float = 2.0        # s of CP-SAT deterministic time per plan
    ga_evaluations: int = 3000     # decoded chromosomes per plan
    delay: float = 10.0            # s a task may run late against the plan before the fleet is planned again
    seed: int = 0


@dataclass(frozen=True)
class BaselineSettings:
    random_choice: str
    ga: GaSettings
    auction_objective: str
    astar: AStarBudget
    astar_max_batch: int           # A* serves a scenario with at most this many joint actions per state
    astar_max_tasks: int           # and at most this many tasks (its states grow as 2^n_tasks)
    cpsat: CpSatBudget
    precedence_margin: float       # s between a predecessor's finish and a successor's arrival in one step
    rollout: RolloutBudget
    lookahead: LookaheadBudget
    replan: ReplanSettings = ReplanSettings()

    def with_cpsat(self, time_limit: Optional[float] = None, workers: Optional[int] = None) -> "BaselineSettings":
        """These settings with the CP-SAT time limit and worker count replaced where given."""
        budget = self.cpsat
        if time_limit is not None:
            budget = replace(budget, time_limit=time_limit)
        if workers is not None:
            budget = replace(budget, workers=workers)
        return replace(self, cpsat=budget)

    def within(self, seconds: float) -> "BaselineSettings":
        """These settings with the reference's solvers held to about `seconds` in all: half of it
        the A*'s wall-time limit, the other half shared by the CP-SAT models' deterministic time limits."""
        astar = replace(self.astar, time_limit=min(self.astar.time_limit, seconds / 2))
        cpsat_share = seconds / 2 / CPSAT_MODELS
        return replace(self.with_cpsat(time_limit=min(self.cpsat.time_limit, cpsat_share)), astar=astar)


#: CP-SAT models the reference may solve one after another (three relaxations, the step model,
#: the probe of a gap): `within` shares half of a planning time among them, the A* has the other half
#: (an A* that stops unproven hands over to CP-SAT).
CPSAT_MODELS = 5


#: The GA's whole-number settings and the least value each may take (its rates lie in [0, 1]).
GA_COUNTS = (("population", 4), ("generations", 1), ("stall_generations", 1), ("tournament", 1), ("elite", 0),
             ("max_evaluations", 1), ("kick_mutations", 1))


def load_baseline_settings(path: Optional[Union[str, Path]] = None) -> BaselineSettings:
    root = read_yaml(path if path is not None else default_config_path("task_baselines.yaml"))
    ga = root.section("ga")
    counts = {name: ga.integer(name, minimum=least) for name, least in GA_COUNTS}
    rates = {name: ga.number(name, minimum=0.0, maximum=1.0) for name in ("crossover_rate", "mutation_rate")}
    exact = root.section("exact")
    astar = AStarBudget(max_expansions=exact.integer("max_expansions", minimum=1),
                        max_states=exact.integer("max_states", minimum=1),
                        time_limit=exact.number("time_limit", above=0.0), memory_mb=exact.number("memory_mb", above=0.0))
    cpsat = root.section("cpsat")
    replan = root.section("replan")
    rollout = root.section("rollout")
    lookahead = root.section("lookahead")
    rollout_budget = RolloutBudget(alternatives=rollout.integer("alternatives", minimum=1),
                                   max_rollouts=rollout.integer("max_rollouts", minimum=1),
                                   orientations=rollout.integer("orientations", minimum=1, maximum=8))
    budget = CpSatBudget(time_limit=cpsat.number("time_limit", above=0.0), workers=cpsat.integer("workers", minimum=1),
                         seed=cpsat.integer("seed", minimum=0), memory_mb=cpsat.number("memory_mb", above=0.0))
    settings = BaselineSettings(
        random_choice=root.section("random").choice("choice", ["unfinished", "all"]),
        ga=GaSettings(**counts, **rates),
        auction_objective=root.section("auction").choice("objective", ["minimax", "minsum"]),
        astar=astar,
        astar_max_batch=exact.integer("astar_max_batch", minimum=1),
        astar_max_tasks=exact.integer("astar_max_tasks", minimum=1, maximum=60),
        cpsat=budget,
        precedence_margin=root.number("precedence_margin", minimum=0.0),
        rollout=rollout_budget,
        lookahead=LookaheadBudget(alternatives=lookahead.integer("alternatives", minimum=0),
                                  orientations=lookahead.integer("orientations", minimum=1, maximum=8),
                                  max_play_outs=lookahead.integer("max_play_outs", minimum=1),
                                  opening=rollout_budget if lookahead.boolean("opening") else None),
        replan=ReplanSettings(method=replan.choice("method", ["insertion", "ga", "cpsat"]),
                              time_limit=replan.number("time_limit", above=0.0),
                              ga_evaluations=replan.integer("ga_evaluations", minimum=1),
                              delay=replan.number("delay", above=0.0),
                              seed=cpsat.integer("seed", minimum=0)),
    )
    root.check_all_used()
    return settings
