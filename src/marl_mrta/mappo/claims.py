"""Sequential decisions within a step: each robot sees the tasks already claimed (`decision_order`).

With `decision_order: simultaneous` (the default) every robot chooses from its own observation
at once, and two robots may pick the same task: the later one's trip is wasted, and under a
team reward neither learns which of them should have yielded. With `sequential` the robots
choose in index order and robot i also sees the tasks robots 0..i-1 chose in this step (the
paper's assigned-task list, /Global_assigned_task): one flag per task appended to its
observation, and those tasks are masked out, so a task is never given twice. None stays
allowed. `sequential_logic` (with the `finished` action mask) also keeps a task closed until
each of its predecessors is finished or claimed before this robot in the same step: the `logic`
mask, widened by the claims, so a robot may head for B1 while another is doing A1 (the 4-robot
optimum does exactly that; whether it arrives in order is still judged by the task rules).
The set actor may also take turns by `turn_order: nearest_ready` (env/observation.py,
turn_ranks): the robot nearest a ready task first, so that the robot about to claim a
predecessor does so before the others look at its successors. Execution stays decentralised:
each robot's actor needs its own observation and the list of claimed tasks, nothing else.
"""
from __future__ import annotations

from typing import Callable, Optional, Sequence

import numpy as np
import torch

from marl_mrta.env.observation import (ROBOT_FEATURES, SELF_FEATURES, TASK_FEATURES, TIME_CAP, SetLayout, feature,
                                        precedence_matrix, turn_ranks)


def is_sequential(decision_order: str) -> bool:
    return decision_order != "simultaneous"


def actor_input_size(obs_dim: int, n_actions: int, n_agents: int, append_agent_id: bool, decision_order: str) -> int:
    """Width of the actor's input: the environment observation, the claimed-task flags
    (sequential orders), then the one-hot robot index (append_agent_id)."""
    return obs_dim + (n_actions - 1 if is_sequential(decision_order) else 0) + (n_agents if append_agent_id else 0)


def claimed_flags(actions_so_far: torch.Tensor, n_tasks: int) -> torch.Tensor:
    """actions (..., k) of the robots that already chose -> (..., n_tasks) bool, True = claimed.
    The None action (index n_tasks) claims nothing."""
    flags = torch.zeros(*actions_so_far.shape[:-1], n_tasks + 1, dtype=torch.bool)
    if actions_so_far.shape[-1]:
        flags.scatter_(-1, actions_so_far.long(), True)
    return flags[..., :n_tasks]


def with_claims(obs: torch.Tensor, claimed: torch.Tensor) -> torch.Tensor:
    """One robot's observation (..., obs_dim) with the claimed flags (..., n_tasks) appended."""
    return torch.cat([obs, claimed.to(obs.dtype)], dim=-1)


def with_set_claims(rows: torch.Tensor, claimed: torch.Tensor, precedence: Optional[torch.Tensor] = None) -> torch.Tensor:
    """Set rows (..., width) of one robot (env/observation.py, SetLayout) with the claimed tasks
    (..., task_slots; ClaimRules.decide_in_turn's marks: k + 1 = robot k's, 0 = free) marked in
    their tokens: the flag and the claimer's leg (how long its trip makes the step); on the robot
    itself the longest of those legs (the step's length so far). Flags alone (bool) name no
    claimer: the leg is then that of the nearest robot that decided before. With the precedence
    ([..., task, predecessor], ClaimRules.precedence), each task's margin: this robot's arrival
    there minus the finish of its latest claimed predecessor (arriving first breaks the order)."""
    layout = SetLayout.of(rows.shape[-1], claimed.shape[-1])
    own, robots, tasks, travel = layout.split(rows)
    flags = claimed > 0 if claimed.dtype != torch.bool else claimed
    if claimed.dtype == torch.bool:
        decided = (robots[..., feature(ROBOT_FEATURES, "decided")] > 0.5) & (robots[..., feature(ROBOT_FEATURES, "valid")] > 0.5)
        legs = torch.where(decided.unsqueeze(-1), travel, torch.full_like(travel, float("inf"))).amin(dim=-2)
    else:
        legs = travel.gather(-2, (claimed - 1).clamp(min=0).unsqueeze(-2)).squeeze(-2)
    claim_leg = torch.where(flags & torch.isfinite(legs), legs, torch.zeros_like(legs))
    tasks = tasks.clone()
    tasks[..., feature(TASK_FEATURES, "claimed")] = flags.to(rows.dtype)
    tasks[..., feature(TASK_FEATURES, "claim_leg")] = claim_leg
    if precedence is not None:
        done_at = claim_leg + tasks[..., feature(TASK_FEATURES, "service")]
        waits = precedence & flags.unsqueeze(-2)                                     # [task, claimed predecessor]
        latest = torch.where(waits, done_at.unsqueeze(-2), torch.full_like(waits, -1.0, dtype=rows.dtype)).amax(dim=-1)
        margin = torch.where(latest >= 0.0, tasks[..., feature(TASK_FEATURES, "my_time")] - latest,
                             tasks[..., feature(TASK_FEATURES, "margin")])
        tasks[..., feature(TASK_FEATURES, "margin")] = margin.clamp(max=TIME_CAP)
    own = own.clone()
    own[..., feature(SELF_FEATURES, "claimed_step")] = claim_leg.amax(dim=-1) if claim_leg.shape[-1] else 0.0
    lead = rows.shape[:-1]
    return torch.cat([own, robots.reshape(*lead, -1), tasks.reshape(*lead, -1), travel.reshape(*lead, -1)], dim=-1)


def turns_from_rows(rows: torch.Tensor, task_slots: int) -> torch.Tensor:
    """Every robot's own set row of one decision (..., robot_slots, width), as encoded (env/
    observation.py, turn_ranks) -> the robots in the order they choose (..., robot_slots) long:
    by how many robots each row says decided before it, padded slots last. Read from the rows,
    so that the decision follows exactly the turns the rows were encoded with."""
    layout = SetLayout.of(rows.shape[-1], task_slots)
    _, robots, _, _ = layout.split(rows)
    before = robots[..., feature(ROBOT_FEATURES, "decided")].sum(-1).round().long()       # (..., N)
    padded = (robots[..., feature(ROBOT_FEATURES, "is_self")].sum(-1) < 0.5).long()
    slots = torch.arange(layout.robot_slots)
    return ((padded * (layout.robot_slots + 1) + before) * layout.robot_slots + slots).argsort(dim=-1)


def busy_claims(robot_tasks: Sequence[Optional[int]], deciding: Sequence[bool], n_tasks: int) -> torch.Tensor:
    """Event mode: the tasks of the robots that do not decide now (they drive to, hold at or serve
    them), as decide_in_turn's marks (n_tasks,) long: k + 1 for robot k's task, 0 for a free one.
    A robot that comes free decides with these already claimed."""
    claimed = torch.zeros(n_tasks, dtype=torch.long)
    for robot, (task, free) in enumerate(zip(robot_tasks, deciding)):
        if task is not None and task >= 0 and not free:
            claimed[int(task)] = robot + 1
    return claimed


def without_claimed(action_mask: torch.Tensor, claimed: torch.Tensor) -> torch.Tensor:
    """Mask (..., n_tasks + 1) with the claimed tasks forbidden; None (last) is left as it was."""
    free = torch.cat([~claimed, torch.ones_like(claimed[..., :1])], dim=-1)
    return action_mask & free


class ClaimRules:
    """The actions open to a robot, given the environment's mask and the tasks claimed before it."""

    def __init__(self, decision_order: str, predecessors: Sequence[Sequence[int]]):
        self.sequential = is_sequential(decision_order)
        self.n_tasks = len(predecessors)
        self.precedence = None
        if decision_order == "sequential_logic":
            self.precedence = torch.from_numpy(precedence_matrix(predecessors))  # [task, predecessor]

    @classmethod
    def per_row(cls, decision_order: str, predecessors_per_row: Sequence[Sequence[Sequence[int]]],
                n_tasks: int) -> "ClaimRules":
        """The rules for environments that each run their own scenario (training across
        scenarios): row e follows predecessors_per_row[e], tasks padded to n_tasks slots."""
        rules = cls(decision_order, [[] for _ in range(n_tasks)])
        if rules.precedence is not None:
            rules.precedence = torch.from_numpy(np.stack([precedence_matrix(predecessors, n_tasks)
                                                          for predecessors in predecessors_per_row]))
        return rules

    def mask(self, env_mask: torch.Tensor, claimed: torch.Tensor) -> torch.Tensor:
        """env_mask (..., n_tasks + 1) under the `finished` mode (True = open), claimed
        (..., n_tasks) bool -> the mask this robot chooses under. Applying it twice changes nothing."""
        mask = without_claimed(env_mask, claimed)
        if self.precedence is None:
            return mask
        pending = env_mask[..., :self.n_tasks] & ~claimed            # open and nobody on it yet
        blocked = (self.precedence & pending.unsqueeze(-2)).any(-1)   # some predecessor pending
        return mask & torch.cat([~blocked, torch.ones_like(blocked[..., :1])], dim=-1)

    def allowed(self, env_mask: torch.Tensor, actions: torch.Tensor, order: Sequence[int]) -> torch.Tensor:
        """Which joint actions the in-turn decision can produce: actions (B, N) long (n_tasks =
        None), the robots choosing in `order` (decide_in_turn's: 0..N-1) under env_mask (N,
        n_tasks + 1) bool -> (B,) bool. Measures what a decision order leaves out
        (tools/mask_ceiling.py)."""
        claimed = torch.zeros(actions.shape[0], self.n_tasks, dtype=torch.bool)
        offered = torch.ones(actions.shape[0], dtype=torch.bool)
        for robot in order:
            choice = actions[:, robot]
            mask = self.mask(env_mask[robot].expand(actions.shape[0], -1), claimed)
            offered &= mask.gather(1, choice.unsqueeze(1)).squeeze(1)
            claimed |= claimed_flags(choice.unsqueeze(-1), self.n_tasks)
        return offered

    def decide_in_turn(self, env_mask: torch.Tensor,
                       decide: Callable[[torch.Tensor, torch.Tensor, torch.Tensor], torch.Tensor],
                       order: Optional[torch.Tensor] = None, claimed: Optional[torch.Tensor] = None) -> torch.Tensor:
        """The one in-turn decision: robots choose one after another, each offered the
        environment's mask narrowed by the tasks the robots before it claimed in this step.

        env_mask (..., N, n_tasks + 1) bool under the `finished` or `logic` mode; order (..., N)
        long: the robots in the order they choose (turns_from_rows; default index order). decide(robot
        (...,) long, claimed (..., n_tasks) long, mask (..., n_tasks + 1) bool) -> that robot's
        actions (...,) long, for every leading index at once (environments). claimed[j] is 0 for
        a free task and k + 1 for a task robot k claimed (the robots' own actors read
        `claimed > 0`; the set actor also whose trip it is); `claimed` (..., n_tasks) long starts
        it (event mode: the tasks of robots that are busy, busy_claims). Returns the actions (..., N)."""
        lead, n = env_mask.shape[:-2], env_mask.shape[-2]
        if order is None:
            order = torch.arange(n).expand(*lead, n)
        claimed = torch.zeros(*lead, self.n_tasks, dtype=torch.long) if claimed is None else claimed.clone()
        actions = torch.zeros(*lead, n, dtype=torch.long)
        for turn in range(n):
            robot = order[..., turn]
            robot_mask = env_mask.gather(-2, robot[..., None, None].expand(*lead, 1, env_mask.shape[-1])).squeeze(-2)
            action = decide(robot, claimed, self.mask(robot_mask, claimed > 0))
            actions.scatter_(-1, robot.unsqueeze(-1), action.unsqueeze(-1))
            taken = claimed_flags(action.unsqueeze(-1), self.n_tasks) & (claimed == 0)
            claimed = torch.where(taken, (robot + 1).unsqueeze(-1).expand_as(claimed), claimed)
        return actions


def in_turn_filter(instance, decision_order: str, turn_order: str) -> Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]:
    """The joint actions the in-turn decision can produce, as a filter for the A*'s states
    (baselines/exact.py, JointActionFilter) of a SchedulingInstance: the `finished` mask, the
    robots taking turns by `turn_order` (turn_ranks) on the nominal legs from where they stand.
    Measures what a decision process leaves out (tools/mask_ceiling.py)."""
    rules = ClaimRules(decision_order, instance.predecessors)
    n = instance.n_robots
    to_task = np.asarray(instance.travel, dtype=np.float64)[:, n:]
    precedes = precedence_matrix(instance.predecessors)                       # [task, predecessor]

    def allowed(actions: np.ndarray, done: np.ndarray, pos: np.ndarray) -> np.ndarray:
        ready = ~done & ~(precedes & ~done[None, :]).any(axis=1)
        order = np.argsort(turn_ranks(turn_order, to_task[np.asarray(pos)][None], ready[None])[0], kind="stable")
        env_mask = torch.as_tensor(np.append(~done, True)).expand(n, -1)
        return rules.allowed(env_mask, torch.as_tensor(actions, dtype=torch.long), order.tolist()).numpy()
    return allowed
