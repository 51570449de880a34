"""The paper's no-training baseline: every robot picks a random action every step.

choice "unfinished" (default): uniform over the tasks still open (None only once all are
finished, which ends the episode anyway). This is what reproduces the paper's ~4.6 decision
steps per episode for 2 robots and ~2.6 for 4 robots with 8 tasks. choice "all": uniform over
every action, finished tasks and None included (many more, mostly wasted, steps).
"""
from __future__ import annotations

import random
from typing import List, Optional

from marl_mrta.env.api import StepOutput


class RandomPolicy:
    name = "random"

    def __init__(self, n_agents: int, n_tasks: int, choice: str = "unfinished", seed: int = 0):
        if choice not in ("unfinished", "all"):
            raise ValueError(f"random choice {choice!r} is not one of unfinished, all")
        self.n_agents = n_agents
        self.n_tasks = n_tasks
        self.choice = choice
        self.seed = seed
        self._rng = random.Random(seed)

    def begin_episode(self, first: StepOutput, episode: Optional[int] = None) -> None:
        if episode is not None:
            self._rng.seed(self.seed * 1_000_003 + episode)

    def act(self, output: StepOutput) -> List[int]:
        rng = self._rng
        if output.deciding is not None:
            return self._act_on_events(output)
        if self.choice == "all":
            return [rng.randrange(self.n_tasks + 1) for _ in range(self.n_agents)]
        open_tasks = [j for j, done in enumerate(output.info.finished) if not done] or [self.n_tasks]
        choice = rng.choice
        return [choice(open_tasks) for _ in range(self.n_agents)]

    def _act_on_events(self, output: StepOutput) -> List[int]:
        """Event mode: each deciding robot, in index order, picks uniformly among the open tasks no
        busy robot or earlier decider has (`unfinished`), or among every action (`all`)."""
        rng = self._rng
        actions = [self.n_tasks] * self.n_agents
        taken = {t for t in output.info.robot_tasks if t is not None}
        for robot, deciding in enumerate(output.deciding):
            if not deciding:
                continue
            if self.choice == "all":
                actions[robot] = rng.randrange(self.n_tasks + 1)
                continue
            own = output.info.robot_tasks[robot]
            open_tasks = [j for j, done in enumerate(output.info.finished)
                          if not done and (j not in taken or j == own)] or [self.n_tasks]
            actions[robot] = rng.choice(open_tasks)
            taken.add(actions[robot])
        return actions
