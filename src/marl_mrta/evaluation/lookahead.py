"""A robot's own decision with lookahead: the team's step searched by rollout, by every robot alike.

At its turn, a robot deciding with a set actor (the generalist) looks ahead before it answers.
From the state it observes in its own observation row (where every robot stands, which tasks are
finished, the episode time) it searches the team's joint action for this step on an embedded,
ideal model of the scenario, as the rollout planner searches a step (evaluation/rollout.py):
the shared actor's episode from here is the incumbent; at every robot's turn its most likely
other actions and the nearest open tasks its precedence mask holds back (other_actions) are each
played out to the end with the actor deciding the rest, the shortest becomes the incumbent, and
one more deviation is tried at the other turns while one shortens it. This runs once per
orientation of the floor (env/observation.py, ORIENTATIONS: the same actor decides otherwise on
the floor turned or mirrored), and the shortest episode gives the step's joint action. The robot
answers with its own part of it.

Every robot observes the same state and runs the same deterministic search, so each finds the
same joint action, and the team acts on it without sending anything beyond what the robots are
sent today: no robot needs another's search. The tasks claimed before a robot in this step are
the check: should they differ from the joint action (a robot that decided otherwise), the robot
searches again with those robots' choices fixed.

Play-outs start every step as an episode resumed there would: fresh recurrent states and no
durations of a last step. An episode played from the next step is then the rest of this one, so
the search at the next step starts from the episode found at this one, and the team's episode
is never longer than the actor's own from any state (the rollout's cost improvement, Bertsekas
2013). The price is compute: at most `max_play_outs` play-outs per step and robot
(config/task_baselines.yaml, lookahead).

With `opening` (the default), every robot also makes the actor's rollout plan at the episode's
first step (evaluation/rollout.py: deterministic, so the same plan for all), and the team goes
by the episode it keeps, the plan's rest played from the state observed, while no step's search
finds one strictly shorter (the fortified rollout of Bertsekas 2013). The rollout plan's search replays whole
episodes, the steps' searches resume them: the two find different episodes, and the team keeps the
better at every step, so on the ideal model its episode is never longer than the rollout plan.

With a precedence margin (evaluate --precedence-margin, the launch files' precedence_margin), a
successor reached within the margin of its predecessor's finish counts as out of order on the
model, so the team keeps only episodes that leave it: where legs run late (stock navigation,
real robots without the hold) an episode found on the ideal model keeps its order.
"""
from __future__ import annotations

import math
import threading
import time
from dataclasses import dataclass, replace
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np
import torch

from marl_mrta.baselines.plan import Plan
from marl_mrta.baselines.reference import scheduling_instance
from marl_mrta.baselines.settings import LookaheadBudget
from marl_mrta.env.factory import make_env
from marl_mrta.evaluation.loop import MAX_STEPS
from marl_mrta.evaluation.rollout import RolloutError, other_actions, rollout_plan
from marl_mrta.mappo.claims import busy_claims
from marl_mrta.mappo.policy import SetActorPolicy


@dataclass(frozen=True)
class ObservedState:
    """The episode as one robot's observation row has it, in the travel table's terms."""
    nodes: List[int]            # per robot: the table's node nearest where it stands
    finished: List[bool]        # per task
    elapsed: float              # s of episode time
    step_index: int
    at_task: Tuple[Tuple[int, int], ...] = ()   # event mode: (robot, task) of busy robots, shown at their task


@dataclass(frozen=True)
class LookaheadChoice:
    action: int                 # the action taken (n_tasks: None)
    own: int                    # the actor's own choice
    makespan: float             # of the team's episode the search found (inf: none complete in order)
    orientation: int            # whose play-out it was (-1: the episode kept, the opening plan's rest)
    play_outs: int              # played for this decision (0: the step's search was done already)


@dataclass
class _PlayOut:
    makespan: float                             # inf: not complete in precedence order, or cut off
    joints: List[List[int]]                     # the episode's joint actions from the state (n_tasks: None)
    turns: List[Tuple[int, torch.Tensor, torch.Tensor, torch.Tensor]]   # (robot, logits, mask, claimed) in turn order


@dataclass(frozen=True)
class _StepPlan:
    makespan: float
    joints: List[List[int]]     # the episode found, from this step: joints[0] is the step's joint action
    order: List[int]            # the robots in turn order
    orientation: int            # -1: the episode kept from an earlier step (the opening plan's rest)

    @property
    def joint(self) -> List[int]:
        return self.joints[0]


class Lookahead:
    """Decisions with lookahead for the robots of one scenario, with a set actor bound to it
    (SetActorPolicy.for_scenario). Robots that share one (in one process) share its searches."""

    def __init__(self, policy: SetActorPolicy, budget: LookaheadBudget, hold_successors: Optional[bool] = None,
                 precedence_margin: float = 0.0, decision_mode: str = "synchronous"):
        if not isinstance(policy, SetActorPolicy) or policy.view is None or not policy.sequential:
            raise ValueError(f"{getattr(policy, 'source', policy)}: lookahead needs a set actor that decides in "
                             f"turn, bound to the scenario (the generalist, or a file fine-tuned from it)")
        self.policy, self.budget = policy, budget
        self.view = policy.view
        scenario = self.view.scenario
        # With a margin, an episode whose successor is reached within it of its predecessor's
        # finish is out of order on the model, so no search keeps it (nor the opening plan).
        self.env = make_env(scenario, "embedded", profile="ideal", mask=policy.action_mask,
                            hold_successors=hold_successors, precedence_margin=precedence_margin,
                            decision_mode=decision_mode)
        self.event = decision_mode == "event"
        if self.event:   # the opening's rollout plan is of joint steps; in event mode the steps' searches alone
            budget = replace(budget, opening=None)
            self.budget = budget
        self.actors = [policy.turned(k) for k in range(min(budget.orientations, policy.orientations))]
        self.none = scenario.n_tasks
        self._searched: Dict[tuple, _StepPlan] = {}
        self._kept: Dict[int, List[List[int]]] = {}     # by step index: the rest of the episode the team goes by
        self.opening: Optional[Plan] = None     # the rollout plan of the first step (None: not made, or none found)
        self.opening_s = 0.0                    # s it took
        self._opened = False
        self._opening_lock = threading.Lock()   # a node makes it in the background (prepare)
        self._play_outs = 0
        self.searches = 0               # steps searched, and play-outs in all, since it was made
        self.play_outs = 0

    def describe(self) -> str:
        """The search in words, for a node's log."""
        budget, margin = self.budget, self.env.settings.precedence_margin
        return (f"looking ahead over {len(self.actors)} orientation(s), {2 * budget.alternatives} other actions per "
                f"turn, up to {budget.max_play_outs} play-outs a step"
                + ("" if budget.opening is None else ", opening with the actor's rollout plan")
                + (f", keeping a precedence margin of {margin:g} s" if margin else ""))

    def state_of(self, row: np.ndarray, agent_index: int, claimed: Optional[np.ndarray] = None) -> ObservedState:
        """The state robot `agent_index` observes in its own row (env/observation.py's layout). In
        event mode, a robot whose claimed task's goal is where it is shown is busy with that task
        (busy robots are shown where they come free; one that decided before this robot in this
        instant is shown where it stands)."""
        flat, encoder = self.view.flat, self.view.encoder
        rows = np.asarray(row, dtype=np.float64).reshape(1, -1)
        nodes = [int(n) for n in encoder.nearest_nodes(encoder.robot_positions(rows, [agent_index]))[0]]
        finished = rows[0, flat.at_finished:flat.at_finished + flat.n_tasks] > 0.5
        at_task = ()
        if self.event and claimed is not None:
            n_robots = len(nodes)
            at_task = tuple((int(k) - 1, task) for task, k in enumerate(np.asarray(claimed).reshape(-1))
                            if k > 0 and nodes[int(k) - 1] == n_robots + task)
        return ObservedState(nodes, [bool(f) for f in finished], float(rows[0, 1]) * flat.timeout,
                             int(round(float(rows[0, 0]) * flat.step_scale)), at_task)

    def choose(self, agent_index: int, row: np.ndarray, logits: torch.Tensor, mask: torch.Tensor,
               claimed: Optional[np.ndarray]) -> LookaheadChoice:
        """Robot `agent_index`'s action, from its observation row, its actor's logits and mask at
        this turn (n_actions,: the actor's own choice, for the record), and the tasks claimed
        before it (n_tasks,: k + 1 = robot k's; None: none)."""
        own = int(torch.argmax(torch.where(mask, logits, torch.full_like(logits, -math.inf))))
        if self.budget.alternatives == 0 and len(self.actors) == 1 and self.budget.opening is None:
            return LookaheadChoice(own, own, math.inf, 0, 0)
        state = self.state_of(row, agent_index, claimed)
        claimers = np.zeros(self.none, dtype=np.int64) if claimed is None else np.asarray(claimed).reshape(-1)
        busy = {robot for robot, _ in state.at_task}
        took = {int(k) - 1: task for task, k in enumerate(claimers) if k > 0 and int(k) - 1 not in busy}
        self._play_outs = 0
        plan = self._search(state, {})
        before = plan.order[:plan.order.index(agent_index)]
        fixed = {robot: took.get(robot, self.none) for robot in before}
        if any(plan.joint[robot] != action for robot, action in fixed.items()):
            plan = self._search(state, fixed)   # a robot before this one decided otherwise: search around it
        self._kept = {state.step_index: self._kept.get(state.step_index, []), state.step_index + 1: plan.joints[1:]}
        return LookaheadChoice(plan.joint[agent_index], own, plan.makespan, plan.orientation, self._play_outs)

    def episodes_alone(self, state: ObservedState) -> List[float]:
        """Per orientation, the makespan of the episode from `state` with the actor deciding
        everything (inf: not complete in precedence order): what the lookahead never exceeds."""
        return [self._play(actor, state, {}).makespan for actor in self.actors]

    def _search(self, state: ObservedState, fixed: Dict[int, int]) -> _StepPlan:
        """The step's joint action by rollout from `state`, the robots in `fixed` holding their actions."""
        key = (tuple(state.nodes), tuple(state.finished), round(state.elapsed, 3), state.step_index,
               state.at_task, tuple(sorted(fixed.items())))
        if key not in self._searched:
            if len(self._searched) > 64:   # one episode's steps at a time
                self._searched.clear()
            self._searched[key] = self._searched_step(state, fixed)
            self.searches += 1
        return self._searched[key]

    def _searched_step(self, state: ObservedState, fixed: Dict[int, int]) -> _StepPlan:
        # Every orientation's own episode first, then the searches from the shortest of them on:
        # the episode the last step's search found goes on as one of them, so the budget cannot
        # leave it out.
        incumbents = [self._play(actor, state, fixed) for actor in self.actors]
        kept = self._kept_plan(state, fixed, [t[0] for t in incumbents[0].turns])
        budget = self.budget.max_play_outs - len(incumbents)
        best: Optional[_StepPlan] = None
        for k in sorted(range(len(self.actors)), key=lambda k: (incumbents[k].makespan, k)):
            actor, incumbent, step = self.actors[k], incumbents[k], dict(fixed)
            while budget > 0:   # one more deviation at another turn while one shortens the episode
                shortest, chosen = incumbent.makespan, None
                for robot, logits, mask, claimed in incumbent.turns:
                    if robot in step:
                        continue
                    legs = self.view.encoder.to_task[state.nodes[robot]]
                    taken = set(step.values()) - {self.none}   # a task another robot deviated to is not free
                    for action in other_actions(logits, mask, claimed, state.finished, legs, self.budget.alternatives):
                        if budget <= 0:
                            break
                        if action in taken:
                            continue
                        trial = {**step, robot: action}
                        played = self._play(actor, state, trial, shortest)
                        budget -= 1
                        if played.makespan < shortest - 1e-9:
                            shortest, chosen = played.makespan, trial
                if chosen is None:
                    break
                step = chosen
                incumbent = self._play(actor, state, step)
                budget -= 1
            found = _StepPlan(incumbent.makespan, incumbent.joints, [t[0] for t in incumbent.turns], k)
            if best is None or found.makespan < best.makespan - 1e-9:
                best = found
        assert best is not None
        # The episode kept goes on unless the search found one strictly shorter (fortified rollout).
        return kept if kept is not None and kept.makespan <= best.makespan + 1e-9 else best

    def _kept_plan(self, state: ObservedState, fixed: Dict[int, int], order: List[int]) -> Optional[_StepPlan]:
        """The rest of the episode the team goes by (the opening plan at the first step, then what
        each step chose), played from `state` with the robots in `fixed` holding their actions:
        None when there is none."""
        if state.step_index == 0 and not state.elapsed and not any(state.finished):
            self._kept = {0: self._opening_plan()}
        joints = self._kept.get(state.step_index)
        if not joints:
            return None
        first = [fixed.get(robot, action) for robot, action in enumerate(joints[0])]
        played = self._play(self.actors[0], state, {}, script=[first] + joints[1:])
        if not math.isfinite(played.makespan):
            return None
        return _StepPlan(played.makespan, played.joints, order, -1)

    def prepare(self) -> None:
        """Makes the opening plan now, if the budget has one: a robot's node does it at start, in
        the background, so that the first step does not wait for it (or waits less)."""
        self._opening_plan()

    def _opening_plan(self) -> List[List[int]]:
        """The shared actor's rollout plan from the episode's start (evaluation/rollout.py, the
        budget's `opening`; made once), as joint actions: [] without one."""
        if self.budget.opening is None:
            return []
        with self._opening_lock:
            self._make_opening()
        if self.opening is None:
            return []
        return [[self.none if a is None else int(a) for a in joint] for joint in self.opening.joint_actions]

    def _make_opening(self) -> None:
        if not self._opened:
            self._opened, started = True, time.perf_counter()
            settings = self.env.settings
            instance = scheduling_instance(self.view.scenario, settings.min_step, settings.goal_timeout,
                                           settings.precedence_margin, settings.hold_successors)
            try:
                self.opening = rollout_plan(self.policy, self.view.scenario, instance, self.budget.opening,
                                            self.policy.action_mask)
            except RolloutError:   # no complete plan in order: the steps' searches alone
                self.opening = None
            self.opening_s = time.perf_counter() - started

    def _play(self, actor: SetActorPolicy, state: ObservedState, step: Dict[int, int],
              cutoff: float = math.inf, script: Sequence[Sequence[int]] = ()) -> _PlayOut:
        """The episode from `state` with the robots in `step` taking those actions in its first
        step (or the joint actions of `script` at its first steps) and `actor` deciding everything
        else: its makespan (inf: not complete in precedence order, or not shorter than `cutoff`,
        where it is given up: an actor that idles can take many steps to its timeout), its joint
        actions and the first step's turns.

        The actor plays every step as it would the first step of an episode resumed there: from a
        fresh recurrent state, and without the last step's durations and arrival flag (a resumed
        episode has none). An episode played from a later step is then this one's rest."""
        self._play_outs += 1
        self.play_outs += 1
        env, flat = self.env, self.view.flat
        if self.event:
            output = env.resume(state.nodes, state.finished, state.elapsed, state.step_index, dict(state.at_task))
        else:
            output = env.resume(state.nodes, state.finished, state.elapsed, state.step_index)
        turns: List[Tuple[int, torch.Tensor, torch.Tensor, torch.Tensor]] = []

        def first_step(turn: int, robot: int, logits: torch.Tensor, mask: torch.Tensor,
                       claimed: torch.Tensor) -> Optional[int]:
            turns.append((robot, logits, mask, claimed))
            return step.get(robot)

        joints: List[List[int]] = []
        for index in range(MAX_STEPS):
            if index < len(script):
                actions = [int(a) for a in script[index]]
            else:
                obs = output.obs.copy()
                obs[:, flat.at_durations:flat.at_durations + 2] = 0.0
                obs[:, flat.at_reached] = 0.0
                claims = None if output.deciding is None else busy_claims(output.info.robot_tasks, output.deciding,
                                                                          self.none)
                chosen, _ = actor.act_team(obs, output.action_mask, actor.initial_hidden(env.n_agents),
                                           pick=first_step if index == 0 else None, deciding=output.deciding,
                                           claimed=claims)
                actions = [int(a) for a in np.asarray(chosen).reshape(-1)]
            joints.append(actions)
            output = env.step(actions)
            if output.done or output.truncated:
                record = output.info.episode
                made = record.makespan if record.complete and record.logic_consistent else math.inf
                return _PlayOut(made, joints, turns)
            if output.info.elapsed >= cutoff:
                return _PlayOut(math.inf, joints, turns)
        raise RuntimeError(f"a play-out did not end within {MAX_STEPS} steps")
