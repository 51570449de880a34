"""Imitation of planned episodes: the set actor learns a planner's joint actions, as a start for MAPPO.

A planner (the GA, the exact solver) gives each scenario a schedule as joint actions. Replayed
through the environment in the decision order of training (ClaimRules.decide_in_turn, each
robot told the tasks the plan gave the robots before it), every step yields, per robot, the set
row it would have seen and the action the plan gave it: a supervised example. An action the
robot's mask forbids (the plan sends a robot to B1 before the robot that does A1 has chosen) is
kept out of the loss. Cross-entropy on these examples teaches an actor in minutes what MAPPO
finds only after many episodes; MAPPO then trains on from there (apps/train_generalist.py).

Examples of scenarios of different sizes are batched by padding their rows to the largest
slots of the batch (SetLayout.pad); each robot of a demonstration is one sequence for the GRU.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Dict, List, Optional, Sequence, Union

import numpy as np
import torch

from marl_mrta.env.api import StepOutput, TaskAllocationEnv
from marl_mrta.env.observation import SetLayout
from marl_mrta.mappo.claims import ClaimRules, busy_claims, is_sequential, turns_from_rows, with_set_claims
from marl_mrta.mappo.set_networks import SetActor
from marl_mrta.mappo.set_view import SetView, slot_mask


#: A plan's actions: per step, a task index or None per robot; or a function of each step's output
#: that gives them (event mode, where the steps depend on when robots come free).
PlannedActions = Union[Sequence[Sequence[Optional[int]]], Callable[[StepOutput], Sequence[Optional[int]]]]
#: Steps after which a demonstration given by a function stops.
MAX_STEPS = 10_000


@dataclass
class Demonstration:
    """A planned episode of one scenario as its robots saw it."""

    rows: np.ndarray       # (T, N, width) float32: set rows, with the claims before each robot
    masks: np.ndarray      # (T, N, M + 1) bool: the masks each robot chose under
    actions: np.ndarray    # (T, N) int64: the plan's action (M = None)
    allowed: np.ndarray    # (T, N) bool: the plan's action is open to the robot (examples of the loss)
    layout: SetLayout
    makespan: float        # s, of the replayed episode
    acting: Optional[np.ndarray] = None   # (T, N) bool: the robot decided at the step (event mode)


def demonstrate(env: TaskAllocationEnv, view: SetView, joint_actions: PlannedActions,
                decision_order: str, seed: int = 0) -> Demonstration:
    """Replay a plan's joint actions (task index or None per robot and step) in `env` (episode
    reset with `seed`), recording what each robot saw and was told to do. Event mode: only the
    robots that decide at a step give examples, the tasks of busy robots claimed before them; the
    actions may come from a function of each step's output (a plan's routes, route_actions)."""
    n, none = env.n_agents, env.n_actions - 1
    rules = ClaimRules(decision_order, env.scenario.predecessors)
    sequential = is_sequential(decision_order)
    out = env.reset(seed=seed)
    rows_t: List[np.ndarray] = []
    masks_t: List[np.ndarray] = []
    actions_t: List[List[int]] = []
    acting_t: List[np.ndarray] = []
    steps = range(MAX_STEPS) if callable(joint_actions) else range(len(joint_actions))
    for k in steps:
        joint = joint_actions(out) if callable(joint_actions) else joint_actions[k]
        planned = [none if a is None else int(a) for a in joint]
        rows = torch.as_tensor(view.rows(out.obs, range(n), sequential))
        seen = rows.clone()
        masks = torch.zeros(n, none + 1, dtype=torch.bool)
        deciding = np.ones(n, dtype=bool) if out.deciding is None else np.asarray(out.deciding, dtype=bool)

        def decide(robot: torch.Tensor, claimed: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
            i = int(robot)
            if sequential:
                seen[i] = with_set_claims(rows[i:i + 1], claimed.unsqueeze(0), rules.precedence)[0]
            masks[i] = mask
            return torch.tensor(planned[i] if deciding[i] else none)

        claimed = None if out.deciding is None else busy_claims(out.info.robot_tasks, deciding, none)
        rules.decide_in_turn(torch.as_tensor(np.asarray(out.action_mask, dtype=bool)), decide,
                             turns_from_rows(rows, none) if sequential else None, claimed)
        rows_t.append(seen.numpy())
        masks_t.append(masks.numpy())
        actions_t.append(planned)
        acting_t.append(deciding)
        out = env.step(planned)
        if out.done or out.truncated:
            break
    actions = np.array(actions_t, dtype=np.int64)
    masks = np.stack(masks_t)
    allowed = np.take_along_axis(masks, actions[..., None], axis=-1)[..., 0] & np.stack(acting_t)
    makespan = out.info.episode.makespan if out.info.episode is not None else float("nan")
    return Demonstration(np.stack(rows_t), masks, actions, allowed, view.layout, float(makespan),
                         np.stack(acting_t))


@dataclass
class ImitationBatch:
    obs: torch.Tensor            # (T, B, width)
    masks: torch.Tensor          # (T, B, A)
    actions: torch.Tensor        # (T, B)
    weight: torch.Tensor         # (T, B) 1 where the example counts
    episode_start: torch.Tensor  # (T, B) bool


def batch_of(demos: Sequence[Demonstration]) -> ImitationBatch:
    """The demonstrations' robots as sequences (columns), padded to their largest slots and length."""
    to = SetLayout(max(d.layout.robot_slots for d in demos), max(d.layout.task_slots for d in demos))
    length = max(len(d.actions) for d in demos)
    columns = sum(d.layout.robot_slots for d in demos)
    obs = np.zeros((length, columns, to.width), dtype=np.float32)
    masks = np.zeros((length, columns, to.task_slots + 1), dtype=bool)
    masks[..., -1] = True
    actions = np.full((length, columns), to.task_slots, dtype=np.int64)
    weight = np.zeros((length, columns), dtype=np.float32)
    column = 0
    for d in demos:
        n, m, steps = d.layout.robot_slots, d.layout.task_slots, len(d.actions)
        cols = slice(column, column + n)
        obs[:steps, cols] = d.layout.pad(d.rows, to)
        for t in range(steps):
            masks[t, cols] = slot_mask(d.masks[t], n, to.task_slots)
        actions[:steps, cols] = np.where(d.actions == m, to.task_slots, d.actions)
        weight[:steps, cols] = d.allowed
        column += n
    start = np.zeros((length, columns), dtype=bool)
    start[0] = True
    return ImitationBatch(torch.from_numpy(obs), torch.from_numpy(masks), torch.from_numpy(actions),
                          torch.from_numpy(weight), torch.from_numpy(start))


def imitation_loss(actor: SetActor, batch: ImitationBatch):
    """Mean cross-entropy of the plan's actions over the examples, the share the actor's greedy
    choice gets right, and the number of examples."""
    columns = batch.obs.shape[1]
    out = actor(batch.obs, actor.initial_hidden(columns), batch.episode_start, batch.masks)
    log_probs = torch.log_softmax(out.logits, dim=-1)
    taken = log_probs.gather(-1, batch.actions.unsqueeze(-1)).squeeze(-1)
    # The actor closes some tasks itself (a claimed predecessor not yet finished on arrival):
    # a planned action it cannot take is no example either.
    open_to_actor = taken > torch.finfo(taken.dtype).min / 2
    weight = batch.weight * open_to_actor.to(batch.weight.dtype)
    count = weight.sum().clamp(min=1.0)
    loss = -(torch.where(open_to_actor, taken, torch.zeros_like(taken)) * weight).sum() / count
    right = ((out.logits.argmax(-1) == batch.actions).float() * weight).sum() / count
    return loss, float(right), float(weight.sum())


def imitate(actor: SetActor, demos: Sequence[Demonstration], *, epochs: int, learning_rate: float,
            demos_per_batch: int, seed: int, log: Callable[[str], None] = print,
            until_accurate: bool = False) -> List[Dict[str, float]]:
    """Epochs of Adam on the demonstrations, shuffled with a generator seeded by `seed`; with
    until_accurate, a batch whose every example the greedy choice already takes gets no step,
    and the first epoch in which that holds for every batch is the last.
    Returns each epoch's mean loss and greedy accuracy."""
    optimizer = torch.optim.Adam(actor.parameters(), lr=learning_rate)
    generator = torch.Generator().manual_seed(seed)
    history = []
    actor.train()
    for epoch in range(epochs):
        order = torch.randperm(len(demos), generator=generator).tolist()
        losses, rights, weights = [], [], []
        for start in range(0, len(order), demos_per_batch):
            batch = batch_of([demos[i] for i in order[start:start + demos_per_batch]])
            loss, right, count = imitation_loss(actor, batch)
            losses.append(float(loss.detach()) * count)
            rights.append(right * count)
            weights.append(count)
            if until_accurate and right >= 1.0:   # no step: it could lose an example at the margin
                continue
            optimizer.zero_grad(set_to_none=True)
            loss.backward()
            torch.nn.utils.clip_grad_norm_(actor.parameters(), 10.0)
            optimizer.step()
        total = max(sum(weights), 1.0)
        history.append({"epoch": epoch + 1, "loss": sum(losses) / total, "accuracy": sum(rights) / total})
        log(f"imitation epoch {epoch + 1}/{epochs} | loss {history[-1]['loss']:.4f} | "
            f"accuracy {history[-1]['accuracy']:.3f}")
        if until_accurate and history[-1]["accuracy"] >= 1.0:
            break
    return history


class SelfImitation:
    """The shortest complete, logic-consistent episode the training has sampled, and the actor
    taught to take it (self-imitation, Oh et al. 2018, on the best episode only).

    Sampling explores around the greedy policy: one of the many sampled episodes of a minute is
    often shorter than the greedy one. PPO moves the greedy choice there only slowly; imitating
    that episode until the greedy choice takes every one of its actions gets there at once. The
    episode is replayed from its seed and actions (Demonstration), so the rows are the ones the
    actor saw, and its replayed makespan is what counts. A planner's schedule may be offered too
    (config teacher, offer_plan); only if the in-turn decision can take every one of its actions."""

    def __init__(self, epochs: int, learning_rate: float, decision_order: str):
        self.epochs = epochs
        self.learning_rate = learning_rate
        self.decision_order = decision_order
        self.best_makespan = float("inf")   # s, of the best sampled episode
        self.best_seed: Optional[int] = None
        self.best_actions: List[List[int]] = []
        self.best_source = ""   # what the best episode is, for the log

    def offer(self, makespan: float, seed: Optional[int], joint_actions: Optional[List[List[int]]],
              source: str = "a sampled episode") -> None:
        """A finished complete, logic-consistent sampled episode, or a planner's schedule: its
        makespan, reset seed and joint actions (None as the last action)."""
        if seed is not None and joint_actions and makespan < self.best_makespan - 1e-9:
            self.best_makespan, self.best_seed, self.best_actions = makespan, seed, [list(j) for j in joint_actions]
            self.best_source = source

    def offer_plan(self, env: TaskAllocationEnv, view: SetView, joint_actions: PlannedActions,
                   source: str) -> Optional[int]:
        """A planner's schedule, replayed as an episode of seed 0: offered when the in-turn decision
        can take every one of its actions; else the first step it cannot take, and nothing offered."""
        demo = demonstrate(env, view, joint_actions, self.decision_order, seed=0)
        acting = demo.acting if demo.acting is not None else np.ones_like(demo.allowed)
        outside = np.flatnonzero(~(demo.allowed | ~acting).all(axis=1))
        if outside.size:
            return int(outside[0])
        self.offer(demo.makespan, 0, demo.actions.tolist(), source)   # as sampled: None is the last action
        return None

    def teach(self, actor: SetActor, env: TaskAllocationEnv, view: SetView, below: float,
              seed: int) -> Optional[Dict[str, object]]:
        """Imitate the best episode when it is shorter than `below` (the best greedy makespan so
        far): its source, replayed makespan, the epochs taken and the greedy accuracy reached;
        None when there is nothing to teach.

        Called every update while the episode stays shorter than every greedy evaluation (whose
        seeds differ from its seed): PPO's next steps may move the greedy choice off it again,
        and a batch the greedy choice still takes costs one forward pass, no optimiser step."""
        if self.best_seed is None or self.best_makespan >= below - 1e-9:
            return None
        none = env.n_actions - 1
        joints = [[None if a == none else a for a in joint] for joint in self.best_actions]
        demo = demonstrate(env, view, joints, self.decision_order, seed=self.best_seed)
        if not demo.makespan < below - 1e-9:   # not replayed as sampled (noise): nothing gained
            self.best_makespan = demo.makespan
            return None
        history = imitate(actor, [demo], epochs=self.epochs, learning_rate=self.learning_rate, demos_per_batch=1,
                          seed=seed, log=lambda line: None, until_accurate=True)
        return {"source": self.best_source, "makespan": demo.makespan, "epochs": len(history),
                "accuracy": history[-1]["accuracy"]}

    def state(self) -> Dict[str, object]:
        return {"makespan": self.best_makespan, "seed": self.best_seed, "actions": self.best_actions,
                "source": self.best_source}

    def load(self, state: Dict[str, object]) -> None:
        self.best_makespan = float(state["makespan"])
        self.best_seed = state["seed"]
        self.best_actions = [list(j) for j in state["actions"]]
        self.best_source = str(state.get("source", "a sampled episode"))
