"""The size-invariant actor and critic (`actor: set`): attention over robots and tasks.

Each robot's set row (env/observation.py, SetLayout) holds one token per robot and per task and
the nominal travel time of every robot to every task. Tasks attend to robots and robots to tasks
with the travel time as a bias on the attention logits (a robot far from a task says little about
it), tasks attend to each other, and the result is read out as a context vector (the robot's own
token, the pooled tasks and robots) that drives a GRU, as in the MLP actor. The logit of task j
is scored from its token and the GRU state; None has a logit of its own. Besides the mask it is
given, the actor closes the tasks it would reach before a predecessor claimed in the same step
is nominally finished (the margin of its token): that would break the order. Nothing depends on a
slot's index, so the same weights act on any number of robots and tasks, and permuting the
tasks permutes the logits (permuting the robots changes nothing). Padded slots (valid = 0) are
never attended to and never chosen.

The critic reads the global state (SetLayout.state_width): robot 0's set row, whose tokens show
every robot and task, and every robot's own features; it gives one value per robot slot.
"""
from __future__ import annotations

import math
from typing import Optional, Tuple

import torch
from torch import nn

from marl_mrta.env.observation import ROBOT_FEATURES, TASK_FEATURES, SetLayout, feature
from marl_mrta.mappo.networks import ActorOutput, gru_cell, layer_init, masked_logits

VALID_ROBOT = feature(ROBOT_FEATURES, "valid")
IS_SELF = feature(ROBOT_FEATURES, "is_self")
VALID_TASK = feature(TASK_FEATURES, "valid")
FINISHED = feature(TASK_FEATURES, "finished")
MARGIN = feature(TASK_FEATURES, "margin")
#: Mean legs by which a robot must arrive after a claimed predecessor's nominal finish (the rules
#: want it finished strictly before; float32 rounding and a little slack stay out of the way).
MARGIN_FLOOR = 1e-3


def _mlp(width_in: int, width: int, width_out: int) -> nn.Sequential:
    return nn.Sequential(layer_init(nn.Linear(width_in, width)), nn.ReLU(), layer_init(nn.Linear(width, width_out)))


def masked_mean(tokens: torch.Tensor, valid: torch.Tensor) -> torch.Tensor:
    """Mean of tokens (..., K, d) over the valid ones (..., K) bool (zeros if none)."""
    weights = valid.to(tokens.dtype).unsqueeze(-1)
    return (tokens * weights).sum(-2) / weights.sum(-2).clamp(min=1.0)


class BiasedAttention(nn.Module):
    """Multi-head attention of queries (B, Q, d) over keys (B, K, d), keys_valid (B, K); with
    edge (B, Q, K) the logits get a learnt per-head function of the edge value (travel time)."""

    def __init__(self, width: int, heads: int, edges: bool):
        super().__init__()
        self.heads = heads
        self.query, self.key, self.value = (layer_init(nn.Linear(width, width), 1.0) for _ in range(3))
        self.out = layer_init(nn.Linear(width, width), 1.0)
        # bias = a_h·t + b_h·√t: monotone shapes of a travel time, cheap on every (query, key) pair
        self.edge = nn.Linear(2, heads) if edges else None

    def forward(self, queries: torch.Tensor, keys: torch.Tensor, keys_valid: torch.Tensor,
                edge: Optional[torch.Tensor] = None) -> torch.Tensor:
        B, Q, d = queries.shape
        K, h = keys.shape[1], self.heads
        q = self.query(queries).view(B, Q, h, d // h).transpose(1, 2)
        k = self.key(keys).view(B, K, h, d // h).transpose(1, 2)
        v = self.value(keys).view(B, K, h, d // h).transpose(1, 2)
        logits = q @ k.transpose(-1, -2) / math.sqrt(d // h)                     # (B, h, Q, K)
        if self.edge is not None and edge is not None:
            shapes = torch.stack([edge, edge.clamp(min=0.0).sqrt()], dim=-1)      # (B, Q, K, 2)
            logits = logits + self.edge(shapes).permute(0, 3, 1, 2)
        logits = logits.masked_fill(~keys_valid[:, None, None, :], torch.finfo(logits.dtype).min)
        mixed = torch.softmax(logits, dim=-1) @ v                                # (B, h, Q, d/h)
        return self.out(mixed.transpose(1, 2).reshape(B, Q, d))


class SetBlock(nn.Module):
    """Tasks ← robots, robots ← tasks (both biased by travel time), tasks ← tasks; residual,
    LayerNorm and a feed-forward layer on each token kind."""

    def __init__(self, width: int, heads: int):
        super().__init__()
        self.tasks_from_robots = BiasedAttention(width, heads, edges=True)
        self.robots_from_tasks = BiasedAttention(width, heads, edges=True)
        self.tasks_from_tasks = BiasedAttention(width, heads, edges=False)
        self.norms = nn.ModuleList(nn.LayerNorm(width) for _ in range(5))
        self.task_ff = _mlp(width, 2 * width, width)
        self.robot_ff = _mlp(width, 2 * width, width)

    def forward(self, tasks, robots, tasks_valid, robots_valid, travel):
        n = self.norms
        tasks = n[0](tasks + self.tasks_from_robots(tasks, robots, robots_valid, travel.transpose(-1, -2)))
        robots = n[1](robots + self.robots_from_tasks(robots, tasks, tasks_valid, travel))
        tasks = n[2](tasks + self.tasks_from_tasks(tasks, tasks, tasks_valid))
        return n[3](tasks + self.task_ff(tasks)), n[4](robots + self.robot_ff(robots))


class SetEncoder(nn.Module):
    """Set rows (B, width) -> task tokens (B, M, d), robot tokens (B, N, d), the row's own
    features embedded (B, d), and the valid flags of tasks and robots."""

    def __init__(self, width: int, heads: int, layers: int, robot_extra: int = 0):
        super().__init__()
        self.self_embed = _mlp(SetLayout.n_self, width, width)
        self.robot_embed = _mlp(SetLayout.n_robot + robot_extra, width, width)
        self.task_embed = _mlp(SetLayout.n_task + 1, width, width)   # + the action mask's flag
        self.blocks = nn.ModuleList(SetBlock(width, heads) for _ in range(layers))

    def forward(self, rows: torch.Tensor, task_slots: int, allowed: torch.Tensor,
                robot_extra: Optional[torch.Tensor] = None):
        layout = SetLayout.of(rows.shape[-1], task_slots)
        own, robots, tasks, travel = layout.split(rows)
        tasks_valid = tasks[..., VALID_TASK] > 0.5
        robots_valid = robots[..., VALID_ROBOT] > 0.5
        robot_in = robots if robot_extra is None else torch.cat([robots, robot_extra], dim=-1)
        task_tokens = self.task_embed(torch.cat([tasks, allowed.to(rows.dtype).unsqueeze(-1)], dim=-1))
        robot_tokens = self.robot_embed(robot_in)
        for block in self.blocks:
            task_tokens, robot_tokens = block(task_tokens, robot_tokens, tasks_valid, robots_valid, travel)
        return task_tokens, robot_tokens, self.self_embed(own), tasks_valid, robots_valid, robots, travel


class SetActor(nn.Module):
    """πθ(a | o_i) over any number of robots and tasks: SetEncoder → context → GRU cell →
    one logit per task slot and one for None (the last action), masked."""

    kind = "set"

    def __init__(self, hidden_size: int, heads: int, layers: int):
        super().__init__()
        self.hidden_size, self.heads, self.layers = hidden_size, heads, layers
        d = hidden_size
        self.encoder = SetEncoder(d, heads, layers)
        self.context = _mlp(4 * d, d, d)
        self.gru = gru_cell(d)
        self.gru_norm = nn.LayerNorm(d)
        self.task_score = nn.Sequential(layer_init(nn.Linear(2 * d + 1, d)), nn.ReLU(),
                                        layer_init(nn.Linear(d, 1), gain=0.01))
        self.none_score = nn.Sequential(layer_init(nn.Linear(2 * d, d)), nn.ReLU(),
                                        layer_init(nn.Linear(d, 1), gain=0.01))

    def initial_hidden(self, batch: int) -> torch.Tensor:
        return torch.zeros(batch, self.hidden_size)

    def forward(self, obs: torch.Tensor, hidden: torch.Tensor, episode_start: torch.Tensor,
                action_mask: torch.Tensor, acting: Optional[torch.Tensor] = None) -> ActorOutput:
        """As networks.Actor.forward; obs (T, B, width) set rows, action_mask (T, B, task_slots + 1)
        (required: it tells the task slots)."""
        T, B = obs.shape[:2]
        task_slots = action_mask.shape[-1] - 1
        rows = obs.reshape(T * B, -1)
        # Never head for a task before its predecessor, claimed in this step, is nominally done.
        margin = SetLayout.of(rows.shape[-1], task_slots).split(rows)[2][..., MARGIN]
        in_order = torch.cat([margin > MARGIN_FLOOR, torch.ones_like(margin[:, :1], dtype=torch.bool)], dim=-1)
        mask = action_mask.reshape(T * B, -1) & in_order
        allowed = mask[:, :task_slots]
        tasks, robots, own, tasks_valid, robots_valid, robot_features, travel = \
            self.encoder(rows, task_slots, allowed)
        is_self = robot_features[..., IS_SELF].unsqueeze(-1)
        me = (robots * is_self).sum(-2)
        my_travel = (travel * is_self).sum(-2)                                    # (TB, M)
        pooled_tasks = masked_mean(tasks, tasks_valid)
        context = self.context(torch.cat([own, me, pooled_tasks, masked_mean(robots, robots_valid)], dim=-1))
        context = context.reshape(T, B, -1)
        outputs = []
        for t in range(T):
            hidden = hidden * (~episode_start[t]).unsqueeze(-1).to(hidden.dtype)
            stepped = self.gru(context[t], hidden)
            outputs.append(stepped)
            hidden = stepped if acting is None else torch.where(acting[t].unsqueeze(-1), stepped, hidden)
        state = self.gru_norm(torch.stack(outputs)).reshape(T * B, -1)
        per_task = torch.cat([tasks, state.unsqueeze(1).expand(-1, task_slots, -1), my_travel.unsqueeze(-1)], dim=-1)
        task_logits = self.task_score(per_task).squeeze(-1)
        none_logit = self.none_score(torch.cat([state, pooled_tasks], dim=-1))
        logits = torch.cat([task_logits, none_logit], dim=-1).reshape(T, B, task_slots + 1)
        return ActorOutput(logits=masked_logits(logits, mask.reshape(T, B, -1)), hidden=hidden)


class SetCritic(nn.Module):
    """V_φ(s) per robot slot from the global state (SetLayout.state_width)."""

    def __init__(self, hidden_size: int, heads: int, layers: int, task_slots: int):
        super().__init__()
        d = hidden_size
        self.task_slots = task_slots
        self.encoder = SetEncoder(d, heads, layers, robot_extra=1 + SetLayout.n_self)
        self.value = nn.Sequential(layer_init(nn.Linear(3 * d, d)), nn.ReLU(), layer_init(nn.Linear(d, 1), gain=1.0))

    def split_state(self, state: torch.Tensor) -> Tuple[torch.Tensor, torch.Tensor]:
        """state (..., state_width) -> per robot slot (..., N, 1 + S), robot 0's row (..., width)."""
        width = state.shape[-1]
        per_robot = 1 + SetLayout.n_self
        # state_width = N (1 + S) + S + N R + M T + N M, linear in N
        robot_slots = (width - SetLayout.n_self - self.task_slots * SetLayout.n_task) // (
            per_robot + SetLayout.n_robot + self.task_slots)
        lead = state.shape[:-1]
        return state[..., :robot_slots * per_robot].reshape(*lead, robot_slots, per_robot), \
            state[..., robot_slots * per_robot:]

    def forward(self, state: torch.Tensor) -> torch.Tensor:
        """state (..., state_width) -> values (..., robot slots)."""
        lead = state.shape[:-1]
        flat = state.reshape(-1, state.shape[-1])
        per_robot, row = self.split_state(flat)
        layout = SetLayout.of(row.shape[-1], self.task_slots)
        _, _, tasks, _ = layout.split(row)
        allowed = (tasks[..., VALID_TASK] > 0.5) & (tasks[..., FINISHED] < 0.5)
        tasks_tok, robots_tok, _, tasks_valid, robots_valid, _, _ = self.encoder(row, self.task_slots, allowed,
                                                                                robot_extra=per_robot)
        pooled = torch.cat([masked_mean(tasks_tok, tasks_valid), masked_mean(robots_tok, robots_valid)], dim=-1)
        values = self.value(torch.cat([robots_tok, pooled.unsqueeze(1).expand(-1, robots_tok.shape[1], -1)], dim=-1))
        return values.squeeze(-1).reshape(*lead, -1)
