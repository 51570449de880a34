"""Settings of the baseline planners (config/task_baselines.yaml), read strictly."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Optional, Union

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
    violation_penalty: float = 100.0


@dataclass(frozen=True)
class BaselineSettings:
    random_choice: str
    ga: GaSettings
    exact_max_expansions: int
    auction_objective: str


def load_baseline_settings(path: Optional[Union[str, Path]] = None) -> BaselineSettings:
    root = read_yaml(path if path is not None else default_config_path("task_baselines.yaml"))
    random_section = root.section("random")
    ga = root.section("ga")
    exact = root.section("exact")
    auction = root.section("auction")
    settings = BaselineSettings(
        random_choice=random_section.choice("choice", ["unfinished", "all"]),
        ga=GaSettings(
            population=int(ga.number("population", minimum=4)),
            generations=int(ga.number("generations", minimum=1)),
            stall_generations=int(ga.number("stall_generations", minimum=1)),
            tournament=int(ga.number("tournament", minimum=1)),
            elite=int(ga.number("elite", minimum=0)),
            crossover_rate=ga.number("crossover_rate", minimum=0.0, maximum=1.0),
            mutation_rate=ga.number("mutation_rate", minimum=0.0, maximum=1.0),
            violation_penalty=ga.number("violation_penalty", minimum=0.0),
        ),
        exact_max_expansions=int(exact.number("max_expansions", minimum=1)),
        auction_objective=auction.choice("objective", ["minimax", "minsum"]),
    )
    root.check_all_used()
    return settings
