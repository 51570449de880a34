"""Decision makers the evaluation runs through the environment: plans, learned actors.

Every one offers begin_episode(first_output, episode) and act(output) -> one action per robot.
"""
from __future__ import annotations

from typing import List, Optional

import numpy as np

from marl_mrta.baselines.plan import NominalRun, Plan, next_goals
from marl_mrta.baselines.replan import fleet_instance, planned_finishes, repair
from marl_mrta.baselines.settings import ReplanSettings
from marl_mrta.env.api import StepOutput
from marl_mrta.mappo.claims import busy_claims
from marl_mrta.model.event_rules import route_actions
from marl_mrta.mappo.policy import ActorPolicy, PolicyFileError, SetActorPolicy, load_policy
from marl_mrta.model.scenario import Scenario, ScenarioError


class PlanPolicy:
    """Replays a plan's joint actions; once they run out with tasks still open (a goal failed
    under noise, or the plan has none), the rest is carried out as the planners decode task
    lists (baselines/plan.next_goals, from the episode's finished tasks and the robots' nodes):
    each robot on its own list, in order, over other goals where a leg exceeds the goal timeout,
    and robots with nothing left taking ready tasks, so every episode that can end complete does."""

    def __init__(self, plan: Plan, n_agents: int, n_tasks: int):
        if plan.instance is None:
            raise ValueError(f"plan {plan.method!r} carries no scheduling instance to continue from")
        self.name = plan.method
        self.plan = plan
        self.n_agents = n_agents
        self.n_tasks = n_tasks
        self._step = 0
        self._run = NominalRun(plan.instance)
        self._sent: List[Optional[int]] = [None] * n_agents

    def begin_episode(self, first: StepOutput, episode: Optional[int] = None) -> None:
        self._step = 0
        self._run = NominalRun(self.plan.instance)
        self._sent = [None] * self.n_agents

    def _track(self, output: StepOutput) -> None:
        """The robots' nodes and the finished tasks as the episode has them."""
        run = self._run
        if self._step and output.info.reached:
            for robot, (task, reached) in enumerate(zip(self._sent, output.info.reached)):
                if task is not None and reached:
                    run.positions[robot] = run.instance.node(task)
        run.stalled = self._step > 0 and list(output.info.finished) == run.finished
        run.finished = list(output.info.finished)

    def act(self, output: StepOutput) -> List[int]:
        none = self.n_tasks
        self._track(output)
        step, self._step = self._step, self._step + 1
        if step < len(self.plan.joint_actions):
            goals = list(self.plan.joint_actions[step])
        else:
            goals = next_goals(self._run, self.plan.robot_tasks) or [None] * self.n_agents
        self._sent = goals
        return [none if g is None else g for g in goals]


class EventPlanPolicy:
    """Carries out a plan's routes in event mode (baselines/plan.py): each robot, when it
    decides, takes the first task of its route that is not finished (a leg that failed is driven
    again); a robot whose route is done stays idle."""

    def __init__(self, plan: Plan, n_agents: int, n_tasks: int):
        self.name = plan.method
        self.plan = plan
        self.n_agents = n_agents
        self.n_tasks = n_tasks

    def begin_episode(self, first: StepOutput, episode: Optional[int] = None) -> None:
        pass

    def act(self, output: StepOutput) -> List[int]:
        return route_actions(self.plan.robot_tasks, output.info.finished, output.deciding, self.n_tasks)


class ReplanPolicy:
    """A live fleet's allocator (baselines/replan.py): plans the fleet as it stands at the first
    decision, again at every change of the fleet (env.fleet_version) and when a task runs
    `delay` s later than planned, and carries the plan out as events (route_actions). Acts on an
    event-mode environment it reads directly (in process: evaluate, the task manager)."""

    name = "replan"

    def __init__(self, env, settings: ReplanSettings):
        if getattr(env, "decision_mode", "synchronous") != "event":
            raise ValueError("the replanning allocator decides in event mode (decision_mode event)")
        self.env = env
        self.settings = settings
        self.plans = 0                   # plans made in this episode
        self._routes: List[List[int]] = []
        self._version: Optional[int] = None
        self._planned: dict = {}

    def begin_episode(self, first: StepOutput, episode: Optional[int] = None) -> None:
        self._routes, self._version, self._planned, self.plans = [], None, {}, 0

    def _late(self) -> bool:
        now, rules = self.env.elapsed, self.env.rules
        return any(not rules.closed(j) and now > finish + self.settings.delay for j, finish in self._planned.items())

    def replan(self) -> None:
        env = self.env
        view = fleet_instance(env)
        index = {j: k for k, j in enumerate(view.tasks)}
        previous = [[index[t] for t in self._routes[r] if t in index] if r < len(self._routes) else []
                    for r in view.robots]
        plan = repair(view.instance, previous, self.settings)
        self._routes = view.to_episode(plan.robot_tasks, env.n_agents)
        self._planned = planned_finishes(view, plan)
        self._version = env.fleet_version
        self.plans += 1

    def act(self, output: StepOutput) -> List[int]:
        env = self.env
        if self._version != env.fleet_version or self._late():
            self.replan()
        closed = [env.rules.closed(j) for j in range(env.n_tasks)]
        actions = route_actions(self._routes, closed, output.deciding, env.n_tasks)
        if any(a < env.n_tasks and env.rules.taken(a, by_other_than=r) for r, a in enumerate(actions)):
            self.replan()   # the plan sends a robot where another one is: it is out of date
            actions = route_actions(self._routes, closed, output.deciding, env.n_tasks)
        # Never onto a task another robot has: it waits instead, and decides again at the next event.
        return [env.n_tasks if a < env.n_tasks and env.rules.taken(a, by_other_than=r) else a
                for r, a in enumerate(actions)]


def plan_policy(plan: Plan, n_agents: int, n_tasks: int, decision_mode: str = "synchronous"):
    """The policy that carries out `plan` in the environment's decision mode."""
    if decision_mode == "event":
        return EventPlanPolicy(plan, n_agents, n_tasks)
    return PlanPolicy(plan, n_agents, n_tasks)


class PolicyLoadError(ValueError):
    """The learned policy cannot be used here; str(error) is one line."""


class LearnedPolicy:
    """A trained MAPPO actor (mappo/policy.py's ActorPolicy) deciding for the whole team, one
    recurrent state per robot, greedy unless deterministic is False."""

    name = "policy"

    def __init__(self, actor: ActorPolicy, n_agents: int, deterministic: bool = True):
        self.actor = actor
        self.n_agents = n_agents
        self.deterministic = deterministic
        self._hidden = None

    @staticmethod
    def trained_mask(path: str, asked: Optional[str]) -> str:
        """The action-mask mode to act under: the one the actor file was trained with. Another
        mask would feed the actor inputs it never saw (the generalist, trained with finished,
        completes nothing under none), so asking for another is an error, as in ROS."""
        try:
            trained = load_policy(path).action_mask
        except (PolicyFileError, ScenarioError) as error:
            raise PolicyLoadError(str(error)) from None
        if asked is not None and asked != trained:
            raise PolicyLoadError(f"mask: {asked} differs from the mask the actor {path} was trained with ({trained}); "
                                  f"give mask {trained} (other methods under {asked} in a run of their own)")
        return trained

    @staticmethod
    def trained_hold(path: str) -> bool:
        """Whether the actor file was trained under hold_successors (train --set hold_successors=true)."""
        try:
            return bool(load_policy(path).settings.get("hold_successors", False))
        except (PolicyFileError, ScenarioError) as error:
            raise PolicyLoadError(str(error)) from None

    @classmethod
    def from_file(cls, path: str, n_agents: int, obs_dim: int, n_actions: int, seed: int = 0,
                  deterministic: bool = True, scenario: Optional[Scenario] = None) -> "LearnedPolicy":
        """The actor of an actor file, checked against the
        environment's sizes; a set actor acts on `scenario`, the environment's."""
        try:
            actor = load_policy(path, seed=seed, scenario=scenario)
        except (PolicyFileError, ScenarioError) as error:
            raise PolicyLoadError(str(error)) from None
        if isinstance(actor, SetActorPolicy) and actor.view is None:
            raise PolicyLoadError(f"{path}: a set actor acts on a scenario: give the environment's")
        if actor.obs_dim != obs_dim or actor.n_actions != n_actions:
            raise PolicyLoadError(f"{path}: the actor expects observations of {actor.obs_dim} values and "
                                  f"{actor.n_actions} actions; this scenario has {obs_dim} and {n_actions}")
        return cls(actor, n_agents, deterministic)

    def begin_episode(self, first: StepOutput, episode: Optional[int] = None) -> None:
        self._hidden = self.actor.initial_hidden(self.n_agents)

    def act(self, output: StepOutput) -> List[int]:
        claimed = None if output.deciding is None else \
            busy_claims(output.info.robot_tasks, output.deciding, self.actor.n_actions - 1)
        actions, self._hidden = self.actor.act_team(output.obs, output.action_mask, self._hidden,
                                                    deterministic=self.deterministic, deciding=output.deciding,
                                                    claimed=claimed)
        return [int(a) for a in np.asarray(actions).reshape(-1)]
