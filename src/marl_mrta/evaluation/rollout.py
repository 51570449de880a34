"""A learned actor improved by rollout: a plan from the policy, without training on the scenario.

The rollout algorithm (Bertsekas, "Rollout algorithms for discrete optimization", 2013): the
actor's greedy episode is the incumbent. At each decision step, at every robot's turn, other
actions are tried: the actor's most likely ones (`alternatives`) and as many of the nearest open
tasks its precedence mask holds back. Each is played out to the episode's end on the embedded
executor's nominal times, the actor deciding everything else, and the shortest episode becomes
the incumbent when it is strictly shorter; the step then tries one more deviation at its other
turns, and so on, before the next step is decided. The result is therefore never longer than the
greedy episode. Each play-out replays the episode from its reset (the ideal profile draws
nothing, so a replay is the same episode). After `max_rollouts` play-outs the actor decides the
rest alone.

With a precedence margin (evaluate --precedence-margin, real.launch's precedence_margin), episodes are
scored as the plans they become in the instance's nominal run: an episode with a successor reached
within the margin of its predecessor's finish is no plan, and among such episodes the one with
fewer of them leads, so that an actor whose own episode breaks the margin is led to one that keeps it.

A set actor (the generalist) reads the floor only through offsets in the map's axes, and decides
otherwise on the same floor turned or mirrored (env/observation.py, ORIENTATIONS), so its rollout
is run once per orientation (`orientations`, as test-time augmentation in POMO, Kwon et al.
2020), and the shortest plan is kept (the first on a tie: the floor as it is comes first). The
orientations share `max_rollouts`: those it leaves no play-out are not tried. An MLP actor has one.

The result is a plan (joint actions), executed as the planners' are: on any executor and in ROS
(evaluate --method rollout --policy P). The robots' own actor nodes (execute.launch) decide from
the actor alone, or search each step the same way from what they observe (evaluation/lookahead.py).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np
import torch

from marl_mrta.baselines.plan import NominalRun, Plan, SchedulingInstance, decode_task_lists, plan_from_run
from marl_mrta.baselines.settings import RolloutBudget
from marl_mrta.env.api import StepOutput, TaskAllocationEnv
from marl_mrta.env.factory import make_env
from marl_mrta.evaluation.loop import MAX_STEPS
from marl_mrta.mappo.claims import busy_claims
from marl_mrta.mappo.policy import ActorPolicy
from marl_mrta.model.scenario import Scenario

class RolloutError(ValueError):
    """An actor the rollout cannot use on this scenario; str(error) is one line."""


#: One step's deviations from the actor: {turn: action} at those turns of the in-turn decision
#: (empty: the actor's own joint action).
Deviation = Dict[int, int]


@dataclass
class _Turn:
    """One turn of the watched step: who chose, from what, and from where."""
    robot: int
    logits: torch.Tensor                # (n_actions,), blocked actions at the lowest float
    mask: torch.Tensor                  # (n_actions,) what the actor could choose
    claimed: torch.Tensor               # (n_tasks,) bool: claimed at the turns before
    node: int                           # the robot's node in the travel table


@dataclass
class _PlayOut:
    makespan: float                     # inf: incomplete or out of precedence order
    late: float                         # successors reached within the instance's precedence margin (inf: no plan)
    run: NominalRun                     # the episode as a plan of the instance
    turns: Optional[List[_Turn]]        # the watched step's turns (None: the episode ended before it)
    finished: List[bool]                # the tasks finished before the watched step

    @property
    def plan_makespan(self) -> float:
        """The makespan as a plan: inf when it is none (incomplete, out of order, within the margin)."""
        return self.makespan if self.late == 0 else math.inf


class RolloutPlanner:
    """Plans a scenario with an in-turn actor (ActorPolicy.act_team's `pick` hook) on an embedded,
    ideal environment of it; `instance` is the same scenario in nominal numbers (travel times,
    robot nodes)."""

    def __init__(self, actor: ActorPolicy, env: TaskAllocationEnv, instance: SchedulingInstance,
                 budget: RolloutBudget, seed: int = 0):
        if not actor.sequential:
            raise RolloutError(f"the robots of {actor.source} decide at once; rollout tries other actions at each "
                               f"robot's turn, so it needs an actor that decides in turn (presets sequential, set, "
                               f"finetune, or the generalist)")
        if (actor.obs_dim, actor.n_actions) != (env.obs_dim, env.n_actions):
            raise RolloutError(f"{actor.source}: the actor expects observations of {actor.obs_dim} values and "
                               f"{actor.n_actions} actions; this scenario has {env.obs_dim} and {env.n_actions}")
        self.actor, self.env, self.instance, self.budget, self.seed = actor, env, instance, budget, seed
        self.none = env.n_tasks
        self.play_outs = 0

    def play(self, deviations: Sequence[Deviation], watch: Optional[int] = None) -> _PlayOut:
        """The episode with `deviations` at its first steps and the actor's choices after them;
        with `watch`, also the turns of that step. In event mode a step is a decision instant (its
        turns those of the robots that decide at it) and the plan is the episode's routes."""
        output: StepOutput = self.env.reset(seed=self.seed)
        hidden = self.actor.initial_hidden(self.env.n_agents)
        event = self.instance.decision_mode == "event"
        run = NominalRun(self.instance)                 # the robots' nodes and finished tasks, step by step
        turns: Optional[List[_Turn]] = None
        finished: List[bool] = []
        for step in range(MAX_STEPS):
            deviation = deviations[step] if step < len(deviations) else {}
            seen: Optional[List[_Turn]] = [] if step == watch else None
            if event:   # a robot stands where it last finished a task (its start before)
                run.finished = list(output.info.finished)
                for robot, task in enumerate(output.info.finished_task or []):
                    if task is not None:
                        run.positions[robot] = self.instance.node(task)

            def pick(turn: int, robot: int, logits: torch.Tensor, mask: torch.Tensor, claimed: torch.Tensor,
                     deviation=deviation, seen=seen) -> Optional[int]:
                if seen is not None:
                    seen.append(_Turn(robot, logits, mask, claimed, run.positions[robot]))
                return deviation.get(turn)

            if seen is not None:
                finished = list(run.finished)
            claimed = None if output.deciding is None else busy_claims(output.info.robot_tasks, output.deciding,
                                                                        self.none)
            actions, hidden = self.actor.act_team(output.obs, output.action_mask, hidden, pick=pick,
                                                  deciding=output.deciding, claimed=claimed)
            turns = turns if seen is None else seen
            joint = [int(a) for a in np.asarray(actions).reshape(-1)]
            if not event:
                run.apply([None if a == self.none else a for a in joint])
            output = self.env.step(joint)
            if output.done or output.truncated:
                # Scored as the plan it becomes: in the instance's nominal run, whose precedence
                # margin (evaluate --precedence-margin) the environment's rules do not know.
                record = output.info.episode
                done = record.complete and record.logic_consistent
                if event:   # the routes the episode took, carried out on events
                    run = decode_task_lists(self.instance, record.robot_task_lists())
                    done = done and run.complete
                return _PlayOut(run.elapsed if done else math.inf, run.violations if done else math.inf,
                                run, turns, finished)
        raise RuntimeError(f"the rollout's episode did not end within {MAX_STEPS} steps")

    def alternatives(self, turn: _Turn, finished: Sequence[bool]) -> List[int]:
        """The actions tried at a turn besides the actor's (other_actions)."""
        legs = self.instance.travel_rows[turn.node]
        return other_actions(turn.logits, turn.mask, turn.claimed, finished,
                             [legs[self.instance.node(t)] for t in range(self.none)], self.budget.alternatives)

    def plan(self) -> Tuple[_PlayOut, float]:
        """The improved episode, and the actor's own episode's makespan as a plan (inf: none)."""
        deviations: List[Deviation] = []
        watched = self.play(deviations, watch=0)   # the incumbent, with the turns of the step being decided
        self.play_outs = 1
        greedy = watched.plan_makespan
        while watched.turns is not None and self.play_outs < self.budget.max_rollouts:
            step: Deviation = {}
            while True:   # one more deviation in this step while one shortens the episode
                best, chosen = watched, None
                for index, turn in enumerate(watched.turns):
                    if index in step:
                        continue
                    for action in self.alternatives(turn, watched.finished):
                        if self.play_outs >= self.budget.max_rollouts:
                            break
                        trial = {**step, index: action}
                        played = self.play(deviations + [trial])
                        self.play_outs += 1
                        if _better(played, best):
                            best, chosen = played, trial
                if chosen is None:
                    break
                step = chosen
                watched = self.play(deviations + [step], watch=len(deviations))   # the turns after the new deviation
            deviations.append(step)
            watched = self.play(deviations, watch=len(deviations))
        return watched, greedy


def other_actions(logits: torch.Tensor, mask: torch.Tensor, claimed: Sequence[bool], finished: Sequence[bool],
                  legs: Sequence[float], count: int) -> List[int]:
    """The actions worth trying at a robot's turn besides the actor's own: its `count` most likely
    other allowed ones, and the `count` nearest open tasks (by `legs`, per task) its precedence mask
    holds back: a robot heading for a successor whose predecessor a robot after it takes, plans
    the actor's in-turn decision cannot make."""
    ranked = torch.where(mask, logits, torch.full_like(logits, -math.inf))
    order = sorted(range(len(ranked)), key=lambda a: (-float(ranked[a]), a))
    own = [a for a in order if bool(mask[a])][1:1 + count]
    held = [t for t in range(len(legs)) if not (finished[t] or claimed[t] or mask[t])]
    held.sort(key=lambda t: (legs[t], t))
    return own + held[:count]


def _better(played: _PlayOut, incumbent: _PlayOut) -> bool:
    """Fewer successors within the margin first (without a margin, every complete episode in
    order has none), then strictly shorter: an actor whose own episode breaks the margin is led
    towards plans that keep it."""
    if played.late != incumbent.late:
        return played.late < incumbent.late
    return played.makespan < incumbent.makespan - 1e-9


def rollout_plan(actor: ActorPolicy, scenario: Scenario, instance: SchedulingInstance, budget: RolloutBudget,
                 mask: str, seed: int = 0) -> Plan:
    """The rollout's episode on an embedded, ideal environment of `scenario` under the actor's
    `mask`, as a plan of `instance` (the scenario's nominal numbers)."""
    # The play-outs run under the instance's rules, so that the environment and the nominal run agree.
    env = make_env(scenario, "embedded", profile="ideal", mask=mask, seed=seed, hold_successors=instance.hold_successors,
                   decision_mode=instance.decision_mode)
    on_scenario = actor.for_scenario(scenario)
    best: Optional[_PlayOut] = None
    chosen, greedy, play_outs, budget_reached = 0, math.inf, 0, False
    makespans: List[Optional[float]] = []
    for orientation in range(min(budget.orientations, on_scenario.orientations)):
        left = budget.max_rollouts - play_outs    # one budget for all orientations: the time stays bounded
        if left <= 0:
            break
        planner = RolloutPlanner(on_scenario.turned(orientation), env, instance, replace(budget, max_rollouts=left), seed)
        final, own = planner.plan()
        play_outs += planner.play_outs
        budget_reached |= planner.play_outs >= left
        makespans.append(final.plan_makespan if math.isfinite(final.plan_makespan) else None)
        if orientation == 0:
            greedy = own
        if best is None or _better(final, best):
            best, chosen = final, orientation
    if best is None or not math.isfinite(best.plan_makespan):
        margin = f" with a precedence margin of {instance.precedence_margin:g} s" if instance.precedence_margin else ""
        raise RolloutError(f"{scenario.source}: no complete plan in precedence order{margin} in {play_outs} "
                           f"play-outs (the actor's own episode is not one); a larger max_rollouts"
                           f"{' or a smaller --precedence-margin' if margin else ''} may find one")
    return plan_from_run("rollout", best.run, play_outs=play_outs,
                         greedy_makespan=greedy if math.isfinite(greedy) else None,
                         budget_reached=budget_reached, orientation=chosen, orientation_makespans=makespans)
