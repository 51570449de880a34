"""The training loop: collect → insert → compute → train → log, with checkpoints and resume.

One Runner owns a run directory:
  checkpoint.pt  everything to continue bit-identically (networks, optimisers, ValueNorm, RNG
                 states, counters, running episodes as seeds + actions, history)
  actor.pt       the standalone actor (load with marl_mrta.mappo.policy.load_policy)
  tb/            TensorBoard scalars
  history.json   per-episode and per-update records; plots/*.png the paper's figures
Both .pt files are written atomically. SIGINT/SIGTERM end the run at the next update boundary
with a checkpoint; a run killed harder resumes from its last periodic checkpoint.

The environments come from an EnvPool: by default one built from `make_env` (embedded); or a
given pool, e.g. K ROS arenas stepped in parallel. A pool that cannot replay its episodes
(a simulation) is checkpointed after every update, a stop signal abandons the update being
collected (its checkpoint is the previous update's), and with no `make_env` the greedy
evaluation runs in the pool's own environments, after which fresh training episodes start.
"""
from __future__ import annotations

import copy
import json
import math
import os
import random
import signal
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple

import numpy as np
import torch

from marl_mrta.env.api import TaskAllocationEnv
from marl_mrta.mappo.buffer import RolloutBuffer
from marl_mrta.mappo.claims import ClaimRules, turns_from_rows, with_claims, with_set_claims
from marl_mrta.mappo.config import MappoConfig, config_from_dict, config_to_dict
from marl_mrta.mappo.env_pool import EnvPool, EpisodeSummary, PoolStep, episode_seed
from marl_mrta.mappo.imitation import SelfImitation
from marl_mrta.mappo.networks import log_prob_and_entropy, sample_actions
from marl_mrta.mappo.policy import (ActorPolicy, PolicyFileError, SetActorPolicy, atomic_torch_save, read_actor_file,
                                   save_actor, save_set_actor, set_actor_from_file)
from marl_mrta.mappo.set_view import SetView
from marl_mrta.mappo.trainer import MappoTrainer

CHECKPOINT_FORMAT = "marl_mrta.mappo.checkpoint/1"
#: Seed stream of greedy evaluations, apart from every training episode's.
EVAL_STREAM = 1_000_003


#: Runs one greedy episode of the given policy per seed and summarises each (evaluation/training.py).
GreedyEvaluation = Callable[[ActorPolicy, Sequence[int]], List[EpisodeSummary]]


class RunError(RuntimeError):
    """A run that cannot start or resume; str(error) is one line naming the file."""


class _UpdateAbandoned(Exception):
    """A stop signal arrived while collecting from environments that cannot be replayed."""


def make_deterministic(seed: int) -> None:
    """Seed python, numpy and torch; one CPU thread and deterministic kernels, so a seeded
    run is repeatable bit for bit (and small networks run faster on one thread)."""
    random.seed(seed)
    np.random.seed(seed % 2**32)
    torch.manual_seed(seed)
    torch.set_num_threads(1)
    torch.use_deterministic_algorithms(True)


def _rng_states() -> Dict[str, Any]:
    np_state = np.random.get_state()
    return {"python": random.getstate(),
            "numpy": [np_state[0], torch.from_numpy(np_state[1].astype(np.int64)), *map(float, np_state[2:])],
            "torch": torch.get_rng_state()}


def _set_rng_states(states: Dict[str, Any]) -> None:
    python = states["python"]
    random.setstate((python[0], tuple(python[1]), python[2]))
    kind, key, pos, has_gauss, cached = states["numpy"]
    np.random.set_state((kind, key.numpy().astype(np.uint32), int(pos), int(has_gauss), float(cached)))
    torch.set_rng_state(states["torch"])


@dataclass
class RunSummary:
    """What a finished (or stopped) run reports."""

    updates: int
    env_steps: int
    episodes: int
    wall_time: float                      # seconds, summed over resumes
    greedy_makespan: float                # last greedy evaluation, s (nan if none)
    time_to_target: Optional[float]       # wall time until greedy makespan ≤ target, s
    steps_to_target: Optional[int]
    stopped_early: bool
    last_metrics: Dict[str, float] = field(default_factory=dict)
    greedy_consistent: bool = True        # the last greedy evaluation finished every task in order
    kept_makespan: Optional[float] = None  # keep_best: the saved actor's (best) consistent makespan, s

    def greedy_result(self) -> str:
        """What the saved actor's greedy schedule does, for the run's last line."""
        if self.kept_makespan is not None:
            return f"greedy makespan {self.kept_makespan:.2f} s (the best logic-consistent evaluation, kept)"
        if not math.isfinite(self.greedy_makespan):
            return "the last greedy evaluation did NOT finish every task"
        text = f"greedy makespan {self.greedy_makespan:.2f} s"
        if not self.greedy_consistent:
            text += ", NOT logic-consistent (a task finished before one of its predecessors)"
        return text


@dataclass
class _Choice:
    """The robots' sampled actions in E environments, and what the buffer keeps of them."""

    obs: torch.Tensor           # (E, N, actor_obs_dim) actor inputs
    mask: torch.Tensor          # (E, N, A) masks the actions were sampled under
    actions: torch.Tensor       # (E, N)
    log_probs: torch.Tensor     # (E, N)
    next_hidden: torch.Tensor   # (E, N, H)
    state: torch.Tensor         # (E, state_dim)
    values: torch.Tensor        # (E, N) the critic's, reward units


class Runner:
    def __init__(self, config: MappoConfig, make_env: Optional[Callable[[], TaskAllocationEnv]], *,
                 evaluate: GreedyEvaluation, scenario: str, seed: int, out_dir: Path,
                 log: Callable[[str], None] = print, target_makespan: Optional[float] = None,
                 stop_at_target: bool = False, tensorboard: bool = True, plots: bool = True,
                 pool: Optional[EnvPool] = None, init_actor: Optional[str] = None):
        """evaluate: runs the greedy policy's episodes (evaluation/training.py: on an environment
        of make_env, or in the pool); target_makespan: a complete, logic-consistent greedy makespan
        at most this counts as "policy found" (time_to_target); stop_at_target ends the run there
        (benchmarks); pool: the environments (default config.n_envs from make_env); make_env
        None: the evaluation ran in the pool, whose training episodes then restart (module doc);
        init_actor: a set actor's file whose weights the run starts from (fine-tuning), "" for
        new weights; default: the settings' init_actor."""
        self.config = config
        self.make_env = make_env
        self.run_greedy = evaluate
        self.scenario = scenario
        self.seed = seed
        self.out_dir = Path(out_dir)
        self.log = log
        self.target_makespan = target_makespan
        self.stop_at_target = stop_at_target
        self.want_tensorboard = tensorboard
        self.want_plots = plots
        make_deterministic(seed)

        if pool is None:
            pool = EnvPool.build(make_env, config.n_envs, seed)
        elif pool.n_envs != config.n_envs:
            raise RunError(f"n_envs: the settings ask for {config.n_envs} environments, the pool has {pool.n_envs}")
        self.pool = pool
        self.n_agents = self.pool.n_agents
        self.claim_rules = ClaimRules(config.decision_order, self.pool.predecessors)
        self.trainer = MappoTrainer(config, self.pool.obs_dim, self.pool.state_dim, self.n_agents, self.pool.n_actions)
        start = config.init_actor if init_actor is None else init_actor
        if start:
            self._start_from(start)
        self.buffer = RolloutBuffer(config.rollout_length, config.n_envs, self.n_agents, self.trainer.actor_obs_dim,
                                    self.pool.state_dim, self.pool.n_actions, config.hidden_size)
        self.action_generator = torch.Generator().manual_seed(seed)
        self.shuffle_generator = torch.Generator().manual_seed(seed + 1)
        self.eval_seeds = [episode_seed(seed, EVAL_STREAM, k) for k in range(config.eval_episodes)]

        self.update = 0
        self.env_steps = 0
        self.episodes = 0
        self.wall_time = 0.0
        self.time_to_target: Optional[float] = None
        self.steps_to_target: Optional[int] = None
        self.history: Dict[str, List[Dict[str, Any]]] = {"episodes": [], "updates": [], "evaluations": []}
        #: keep_best: the best greedy evaluation's consistent makespan and the actor weights that made it.
        self.best_makespan = math.inf
        self.best_actor: Optional[Dict[str, torch.Tensor]] = None
        self.self_imitation: Optional[SelfImitation] = None
        self._replay: Optional[Tuple[TaskAllocationEnv, SetView]] = None   # self-imitation's environment
        if config.self_imitation_epochs and (make_env is None or self.pool.mixed):
            log("self_imitation_epochs: off in this run: the imitation replays one scenario's episodes in an "
                "embedded environment, and this run trains in a simulation or across scenarios")
        elif config.self_imitation_epochs:
            self.self_imitation = SelfImitation(config.self_imitation_epochs, config.self_imitation_lr,
                                                config.decision_order)
        self.current: Optional[PoolStep] = None
        self.hidden = torch.zeros(config.n_envs, self.n_agents, config.hidden_size)
        self.episode_start = torch.ones(config.n_envs, dtype=torch.bool)
        self.stop_requested = False
        self._writer = None

    def _start_from(self, policy: str) -> None:
        """The actor's weights from a set actor's file, checked against the settings' network."""
        try:
            path, data = read_actor_file(policy)
            if "hidden_size" not in data or "heads" not in data or self.config.actor != "set":
                raise PolicyFileError(f"{path}: --init: a set actor's file fine-tunes a run with actor: set "
                                      f"(this run trains actor: {self.config.actor})")
            c = self.config
            shape = (data["hidden_size"], data["heads"], data["layers"])
            if shape != (c.hidden_size, c.set_heads, c.set_layers):
                raise PolicyFileError(f"{path}: --init: the actor has hidden_size, set_heads, set_layers {shape}, the "
                                      f"settings {(c.hidden_size, c.set_heads, c.set_layers)}")
            trained_turns = dict(data.get("settings", {})).get("turn_order", "index")
            if trained_turns != c.turn_order:
                raise PolicyFileError(f"{path}: --init: the actor takes turns by {trained_turns}, the settings by "
                                      f"{c.turn_order} (--set turn_order={trained_turns})")
            self.trainer.actor.load_state_dict(set_actor_from_file(path, data).state_dict())
        except PolicyFileError as error:
            raise RunError(str(error)) from None

    def _claim_rules(self, rows: Sequence[int]) -> ClaimRules:
        """The claim rules of environments `rows`: the pool's scenario's, or, when the environments
        run different scenarios (training across scenarios), each row's own."""
        if not self.pool.mixed:
            return self.claim_rules
        return ClaimRules.per_row(self.config.decision_order, [self.pool.envs[i].scenario.predecessors for i in rows],
                                  self.pool.n_actions - 1)

    # ---------------------------------------------------------------- paths
    @property
    def checkpoint_path(self) -> Path:
        return self.out_dir / "checkpoint.pt"

    @property
    def actor_path(self) -> Path:
        return self.out_dir / "actor.pt"

    # ---------------------------------------------------------------- start / resume
    def start(self) -> None:
        """A fresh run in an out_dir without a checkpoint."""
        if self.checkpoint_path.exists():
            raise RunError(f"{self.checkpoint_path}: a run exists here; resume it or choose another output directory")
        self.current = self.pool.reset()

    @staticmethod
    def read_checkpoint(path: Path) -> Dict[str, Any]:
        try:
            data = torch.load(path, map_location="cpu", weights_only=True)
        except FileNotFoundError:
            raise RunError(f"{path}: no checkpoint to resume") from None
        except Exception as error:
            raise RunError(f"{path}: not a readable checkpoint ({type(error).__name__})") from None
        if not isinstance(data, dict) or data.get("format") != CHECKPOINT_FORMAT:
            raise RunError(f"{path}: format: not a {CHECKPOINT_FORMAT} file")
        return data

    @classmethod
    def resume(cls, out_dir: Path, make_env: Optional[Callable[[], TaskAllocationEnv]], **kwargs) -> "Runner":
        """The run stored in out_dir/checkpoint.pt, ready to continue with its next update."""
        data = cls.read_checkpoint(Path(out_dir) / "checkpoint.pt")
        config = config_from_dict(data["config"], f"{out_dir}/checkpoint.pt")
        # The checkpoint holds the trained weights: nothing to start from.
        runner = cls(config, make_env, scenario=data["scenario"], seed=data["seed"], out_dir=Path(out_dir),
                     init_actor="", **kwargs)
        runner.load(data)
        return runner

    def load(self, data: Dict[str, Any]) -> None:
        self.trainer.load_state_dict(data["trainer"])
        counters = data["counters"]
        self.update, self.env_steps = counters["update"], counters["env_steps"]
        self.episodes, self.wall_time = counters["episodes"], counters["wall_time"]
        self.time_to_target, self.steps_to_target = counters["time_to_target"], counters["steps_to_target"]
        self.history = data["history"]
        best = data.get("best")
        if best is not None:
            self.best_makespan, self.best_actor = best["makespan"], best["actor"]
        if self.self_imitation is not None and "self_imitation" in data:
            self.self_imitation.load(data["self_imitation"])
        self.current = self.pool.restore(data["env_pool"])
        if self.pool.replayable:
            self.hidden = data["hidden"].clone()
            self.episode_start = data["episode_start"].clone()
        # else: the pool started fresh episodes; zero GRU states, every step an episode start
        self.action_generator.set_state(data["rng"]["actions"])
        self.shuffle_generator.set_state(data["rng"]["shuffle"])
        _set_rng_states(data["rng"]["global"])

    def save_checkpoint(self) -> None:
        """Checkpoint and standalone actor, both written atomically."""
        data = {
            "format": CHECKPOINT_FORMAT,
            "config": config_to_dict(self.config),
            "scenario": self.scenario,
            "seed": self.seed,
            "trainer": self.trainer.state_dict(),
            "counters": {"update": self.update, "env_steps": self.env_steps, "episodes": self.episodes,
                         "wall_time": self.wall_time, "time_to_target": self.time_to_target,
                         "steps_to_target": self.steps_to_target},
            "rng": {"actions": self.action_generator.get_state(), "shuffle": self.shuffle_generator.get_state(),
                    "global": _rng_states()},
            "env_pool": self.pool.snapshot(),
            "hidden": self.hidden.clone(),
            "episode_start": self.episode_start.clone(),
            "history": self.history,
        }
        if self.config.keep_best:
            data["best"] = {"makespan": self.best_makespan, "actor": self.best_actor}
        if self.self_imitation is not None:
            data["self_imitation"] = self.self_imitation.state()
        atomic_torch_save(data, self.checkpoint_path)
        actor = self.trainer.actor
        if self.config.keep_best and self.best_actor is not None:
            actor = copy.deepcopy(actor)
            actor.load_state_dict(self.best_actor)
        if self.config.actor == "set":
            save_set_actor(self.actor_path, actor, settings=config_to_dict(self.config), trained_on=self.scenario)
            return
        save_actor(self.actor_path, actor, obs_dim=self.pool.obs_dim, n_agents=self.n_agents,
                   append_agent_id=self.config.append_agent_id, settings=config_to_dict(self.config),
                   scenario=self.scenario, predecessors=self.pool.predecessors)

    # ---------------------------------------------------------------- the loop
    @torch.no_grad()
    def collect(self) -> List[EpisodeSummary]:
        """Fill the buffer with rollout_length steps of every environment."""
        if self.pool.independent:
            return self._collect_independently()
        E = self.config.n_envs
        finished: List[EpisodeSummary] = []
        self.buffer.reset()
        while not self.buffer.full:
            if self.stop_requested and not self.pool.replayable:
                raise _UpdateAbandoned
            step = self.current
            choice = self._choose(step, self.hidden, self.episode_start)
            result = self.pool.step(choice.actions.numpy())
            self.buffer.insert(**self._transition(step, choice, result, self.hidden, self.episode_start))
            self.hidden = choice.next_hidden
            self.episode_start = torch.from_numpy(result.terminated | result.truncated)
            self.current = result
            self.env_steps += E
            finished.extend(result.finished)
        return finished

    def _collect_independently(self) -> List[EpisodeSummary]:
        """collect() for environments that run independently (EnvPool.independent: arenas of one
        simulation): each takes its rollout_length steps in its own thread, never waiting for
        another's step to end (a shared barrier would leave every arena idle until the slowest
        finished). The networks and the action RNG are used under a lock."""
        E, T = self.config.n_envs, self.config.rollout_length
        lock = threading.Lock()
        rows: List[List[Dict[str, torch.Tensor]]] = [[] for _ in range(E)]
        finished: List[List[EpisodeSummary]] = [[] for _ in range(E)]
        ends: List[Any] = [None] * E
        failed = threading.Event()   # one arena's error stops the others at their next step
        start = self.current

        @torch.no_grad()   # grad mode is per thread: the decorator of collect() does not reach here
        def run(i: int) -> bool:
            step = start.row(i)
            hidden, episode_start = self.hidden[i:i + 1].clone(), self.episode_start[i:i + 1].clone()
            for _ in range(T):
                if self.stop_requested or failed.is_set():
                    return False
                with lock:
                    choice = self._choose(step, hidden, episode_start, rows=[i])
                try:
                    result = self.pool.step_one(i, choice.actions[0].numpy())
                except BaseException:
                    failed.set()
                    raise
                with lock:
                    rows[i].append(self._transition(step, choice, result, hidden, episode_start))
                hidden, episode_start = choice.next_hidden, torch.from_numpy(result.terminated | result.truncated)
                step = result
                finished[i].extend(result.finished)
            ends[i] = (hidden, episode_start)
            return True

        with ThreadPoolExecutor(max_workers=E, thread_name_prefix="collect") as threads:
            completed = list(threads.map(run, range(E)))
        if not all(completed):
            raise _UpdateAbandoned
        self.buffer.reset()
        for t in range(T):
            self.buffer.insert(**{key: torch.cat([rows[i][t][key] for i in range(E)]) for key in rows[0][t]})
        self.hidden = torch.cat([end[0] for end in ends])
        self.episode_start = torch.cat([end[1] for end in ends])
        self.current = self.pool.current()
        self.env_steps += E * T
        return [summary for per_env in finished for summary in per_env]

    def _transition(self, step: PoolStep, choice: _Choice, result: PoolStep, hidden: torch.Tensor,
                    episode_start: torch.Tensor) -> Dict[str, torch.Tensor]:
        """What the buffer keeps of one step of the environments (rows) of `step`."""
        c = self.config
        E, N = choice.actions.shape
        rewards = torch.from_numpy(result.rewards).float()
        if c.team_reward:
            # A share of its own reward tells a robot which of its choices the team paid for
            # (with four robots the mean alone hides who took a task another already had).
            team = rewards.mean(dim=1, keepdim=True).expand(E, N)
            rewards = c.own_reward_share * rewards + (1.0 - c.own_reward_share) * team
        final_values = torch.zeros(E, N)
        if result.truncated.any():
            final_values = self.trainer.values(torch.from_numpy(result.final_state).float())
        event = {}
        if self.event_mode:   # who decided at `step`, and the transition's discount γ^(Δt / discount_seconds)
            elapsed = torch.from_numpy(np.asarray(result.elapsed, dtype=np.float64))
            event = dict(acting=torch.from_numpy(step.deciding),
                         discount=(c.gamma ** (elapsed / c.discount_seconds)).float().unsqueeze(-1))
        return dict(obs=choice.obs, state=choice.state, actions=choice.actions, action_mask=choice.mask,
                    log_probs=choice.log_probs, values=choice.values, rewards=rewards * c.reward_scale,
                    episode_start=episode_start, terminated=torch.from_numpy(result.terminated),
                    truncated=torch.from_numpy(result.truncated), final_values=final_values, actor_hidden=hidden,
                    **event)

    def _choose(self, step: PoolStep, hidden: torch.Tensor, episode_start: torch.Tensor,
                rows: Optional[Sequence[int]] = None) -> _Choice:
        """Sample every robot's action in the environments (rows E) of `step`, from the GRU
        states `hidden` (E, N, H): the actor inputs and masks the actions were sampled under
        (what the buffer keeps), actions (E, N), their log-probabilities, the next GRU state, and
        the critic's values of the state. rows: the pool's environments of `step` (default all)."""
        rows = range(self.config.n_envs) if rows is None else rows
        state = torch.from_numpy(step.state).float()
        env_obs, env_mask = torch.from_numpy(step.obs).float(), torch.from_numpy(step.action_mask)
        E, N = env_obs.shape[:2]
        trainer = self.trainer
        # Event mode: robots that do not decide keep their recurrent state (their rows' actions
        # are None, forced by their masks, and not trained on).
        deciding = torch.from_numpy(step.deciding) if self.event_mode else None
        if not trainer.sequential:
            obs = trainer.actor_obs(env_obs)
            out = trainer.actor(obs.reshape(1, E * N, -1), hidden.reshape(E * N, -1),
                                episode_start.repeat_interleave(N).unsqueeze(0), env_mask.reshape(1, E * N, -1))
            logits = out.logits[0]
            actions = sample_actions(logits, self.action_generator)
            log_probs, _ = log_prob_and_entropy(logits, actions)
            next_hidden = out.hidden.reshape(E, N, -1)
            if deciding is not None:
                next_hidden = torch.where(deciding.unsqueeze(-1), next_hidden, hidden * (~episode_start).view(E, 1, 1))
            return _Choice(obs, env_mask, actions.reshape(E, N), log_probs.reshape(E, N), next_hidden,
                           state, trainer.values(state))
        # Robots in turn, each seeing the tasks claimed before it (mappo/claims.py); the set
        # actor's rows say whose turn comes when (turn_order), per environment.
        identity = torch.eye(N)
        obs = torch.zeros(E, N, trainer.actor_obs_dim)
        mask = torch.zeros_like(env_mask)
        log_probs = torch.zeros(E, N)
        next_hidden = torch.zeros_like(hidden)
        at = torch.arange(E)

        rules = self._claim_rules(rows)
        order = turns_from_rows(env_obs, env_mask.shape[-1] - 1) if self.config.actor == "set" else None

        def decide(robot: torch.Tensor, claimed: torch.Tensor, mask_i: torch.Tensor) -> torch.Tensor:
            if deciding is not None:   # robots that do not decide: None, state kept, nothing claimed
                idle = ~deciding[at, robot]
                if bool(idle.all()):
                    obs[at, robot] = env_obs[at, robot] if self.config.actor == "set" else obs[at, robot]
                    mask[at, robot] = mask_i
                    next_hidden[at, robot] = hidden[at, robot] * (~episode_start).unsqueeze(-1).to(hidden.dtype)
                    return torch.full_like(robot, env_mask.shape[-1] - 1)
            if self.config.actor == "set":
                obs_i = with_set_claims(env_obs[at, robot], claimed, rules.precedence)
            else:
                obs_i = with_claims(env_obs[at, robot], claimed > 0)
            if self.config.append_agent_id:
                obs_i = torch.cat([obs_i, identity[robot]], dim=-1)
            out = trainer.actor(obs_i.unsqueeze(0), hidden[at, robot], episode_start.unsqueeze(0), mask_i.unsqueeze(0))
            logits = out.logits[0]
            action_i = sample_actions(logits, self.action_generator)
            log_prob_i, _ = log_prob_and_entropy(logits, action_i)
            obs[at, robot], mask[at, robot] = obs_i, mask_i
            log_probs[at, robot], next_hidden[at, robot] = log_prob_i, out.hidden
            if deciding is not None:
                idle = ~deciding[at, robot]
                kept = hidden[at, robot] * (~episode_start).unsqueeze(-1).to(hidden.dtype)
                next_hidden[at, robot] = torch.where(idle.unsqueeze(-1), kept, out.hidden)
                action_i = torch.where(idle, torch.full_like(action_i, env_mask.shape[-1] - 1), action_i)
            return action_i

        claimed0 = None
        if deciding is not None:   # the tasks of busy robots are claimed before the first turn
            busy = torch.from_numpy(step.busy)
            robots = torch.arange(N).expand(E, N)
            marks = torch.where((busy >= 0) & ~deciding, robots + 1, torch.zeros_like(robots))
            claimed0 = torch.zeros(E, rules.n_tasks + 1, dtype=torch.long)
            claimed0.scatter_(1, torch.where(busy >= 0, busy, torch.full_like(busy, rules.n_tasks)), marks)
            claimed0 = claimed0[:, :rules.n_tasks]
        actions = rules.decide_in_turn(env_mask, decide, order, claimed0)
        return _Choice(obs, mask, actions, log_probs, next_hidden, state, trainer.values(state))

    @torch.no_grad()
    def compute(self) -> None:
        last_values = self.trainer.values(torch.from_numpy(self.current.state).float())
        self.buffer.compute_returns(last_values, self.config.gamma, self.config.gae_lambda,
                                    per_step_discounts=self.event_mode)

    @property
    def event_mode(self) -> bool:
        return self.config.decision_mode == "event"

    def train_one_update(self) -> Dict[str, float]:
        """collect → compute → train: one PPO update (the unit of checkpoints and resume)."""
        started = time.perf_counter()
        steps_before = self.env_steps
        try:
            finished = self.collect()
        except _UpdateAbandoned:
            self.env_steps = steps_before
            raise
        collected = time.perf_counter()
        self.compute()
        torch.set_num_threads(self.config.train_threads)   # the update's batches are large; collection's are not
        try:
            metrics = self.trainer.train(self.buffer, self.env_steps, self.shuffle_generator,
                                         train_actor=self.update >= self.config.critic_warmup_updates)
        finally:
            torch.set_num_threads(1)
        if self.update >= self.config.critic_warmup_updates:
            self._imitate_best(finished)
        done = time.perf_counter()
        self.update += 1
        self.episodes += len(finished)
        self.wall_time += done - started
        metrics.update(update=self.update, env_steps=self.env_steps, episodes=self.episodes,
                       wall_time=self.wall_time, collect_seconds=collected - started, train_seconds=done - collected)
        self.history["episodes"].extend(r.as_dict() for r in finished)
        self.history["updates"].append(metrics)
        return metrics

    def offer_plan(self, joint_actions: Sequence[Sequence[Optional[int]]]) -> Optional[int]:
        """A planner's schedule for self-imitation (config teacher; evaluation/training.py), offered
        as an episode of seed 0 when the in-turn decision can take each of its actions. Returns the
        first step it cannot take (nothing offered), else None."""
        if self.self_imitation is None:   # off in this run (logged at the start)
            return None
        return self.self_imitation.offer_plan(*self.replay_env(), joint_actions,
                                              source=f"the {self.config.teacher} teacher's schedule")

    def _imitate_best(self, finished: Sequence[EpisodeSummary]) -> None:
        """Self-imitation (config.self_imitation_epochs): the best sampled episode so far, taught
        to the actor while it beats every greedy evaluation."""
        if self.self_imitation is None:
            return
        for episode in finished:
            if episode.terminated and episode.logic_consistent:
                self.self_imitation.offer(episode.makespan, episode.seed, episode.joint_actions)
        greedy = [e["consistent_makespan"] for e in self.history["evaluations"]]
        taught = self.self_imitation.teach(self.trainer.actor, *self.replay_env(), below=min(greedy, default=math.inf),
                                           seed=self.seed + self.update)
        if taught is not None:
            self.log(f"update {self.update + 1}: imitating {taught['source']} of {taught['makespan']:.2f} s "
                     f"({taught['epochs']} epochs, greedy accuracy {taught['accuracy']:.2f})")

    def replay_env(self) -> Tuple[TaskAllocationEnv, SetView]:
        """The embedded environment, and its set view, in which self-imitation replays episodes;
        built once, on first use."""
        if self._replay is None:
            env = self.make_env()
            self._replay = (env, SetView(env.scenario, self.config.turn_order))
        return self._replay

    def greedy_policy(self) -> ActorPolicy:
        if self.config.actor == "set":   # bound to each evaluation's scenario there (for_scenario)
            return SetActorPolicy(self.trainer.actor, settings=config_to_dict(self.config))
        return ActorPolicy(self.trainer.actor, obs_dim=self.pool.obs_dim, n_agents=self.n_agents,
                           append_agent_id=self.config.append_agent_id, settings=config_to_dict(self.config),
                           predecessors=self.pool.predecessors)

    def evaluate(self) -> Dict[str, float]:
        """Greedy policy on fixed evaluation seeds (separate env, no training RNG used)."""
        started = time.perf_counter()
        records = self.run_greedy(self.greedy_policy(), self.eval_seeds)
        if self.make_env is None:
            self.current = self.pool.restart()
            self.hidden.zero_()
            self.episode_start.fill_(True)
        self.trainer.actor.train()
        self.wall_time += time.perf_counter() - started
        makespans = [r.makespan if r.terminated else math.inf for r in records]
        consistent = float(np.mean([r.makespan if r.terminated and r.logic_consistent else math.inf for r in records]))
        result = {
            "update": self.update, "env_steps": self.env_steps, "wall_time": self.wall_time,
            "makespan": float(np.mean(makespans)), "consistent_makespan": consistent,
            "completed": float(np.mean([r.terminated for r in records])),
            "reward_per_robot": float(np.mean([np.mean(r.reward_per_robot) for r in records])),
            "collisions": float(np.mean([r.collisions for r in records])),
        }
        self.history["evaluations"].append(result)
        if self.config.keep_best and consistent < self.best_makespan:
            self.best_makespan = consistent
            self.best_actor = {k: v.detach().clone() for k, v in self.trainer.actor.state_dict().items()}
        if (self.target_makespan is not None and self.time_to_target is None
                and consistent <= self.target_makespan):   # a schedule out of order is no policy found
            self.time_to_target, self.steps_to_target = self.wall_time, self.env_steps
        return result

    # ---------------------------------------------------------------- logging
    def _tensorboard(self):
        if self._writer is None and self.want_tensorboard:
            from torch.utils.tensorboard import SummaryWriter
            self._writer = SummaryWriter(str(self.out_dir / "tb"), purge_step=self.env_steps or None)
        return self._writer

    def _write_scalars(self, metrics: Dict[str, float], finished: Sequence[Dict[str, Any]],
                       evaluation: Optional[Dict[str, float]]) -> None:
        writer = self._tensorboard()
        if writer is None:
            return
        step = self.env_steps
        for key in ("loss", "policy_loss", "value_loss", "entropy", "approx_kl", "clipfrac",
                    "explained_variance", "grad_norm", "critic_grad_norm", "learning_rate"):
            writer.add_scalar(f"train/{key}", metrics[key], step)
        if finished:
            writer.add_scalar("episode/makespan", np.nanmean([r["makespan"] for r in finished]), step)
            writer.add_scalar("episode/reward_per_robot", np.mean([np.mean(r["reward_per_robot"]) for r in finished]), step)
            writer.add_scalar("episode/collisions", np.mean([r["collisions"] for r in finished]), step)
            writer.add_scalar("episode/length", np.mean([r["length"] for r in finished]), step)
            for name in finished[0]["components"]:
                writer.add_scalar(f"reward_components/{name}",
                                  np.mean([np.mean(r["components"][name]) for r in finished]), step)
        if evaluation is not None:
            writer.add_scalar("eval/makespan", evaluation["makespan"], step)
            writer.add_scalar("eval/completed", evaluation["completed"], step)

    def _progress_line(self, metrics: Dict[str, float], session_start: float, session_steps: int,
                       evaluation: Optional[Dict[str, float]]) -> str:
        recent = [r for r in self.history["episodes"][-100:] if r["terminated"]]
        makespan = f"{np.mean([r['makespan'] for r in recent]):.1f} s" if recent else "- (none completed)"
        elapsed = time.perf_counter() - session_start
        rate = (self.env_steps - session_steps) / max(elapsed, 1e-9)
        remaining = max(0, self.config.n_updates * self.config.batch_size - self.env_steps)
        eta = time.strftime("%H:%M:%S", time.gmtime(remaining / max(rate, 1e-9)))
        # No update yet when the wall-time budget ended during the first batch (a loaded machine).
        learning = (f"loss {metrics['loss']:.3f} | entropy {metrics['entropy']:.2f}" if metrics
                    else "loss - | entropy -")
        greedy = f" | greedy {evaluation['makespan']:.1f} s" if evaluation is not None else ""
        return (f"update {self.update}/{self.config.n_updates} | episodes {self.episodes} | "
                f"steps {self.env_steps} | {rate:.3g} steps/s | makespan {makespan}{greedy} | "
                f"{learning} | ETA {eta}")

    # ---------------------------------------------------------------- whole run
    def _handle_stop_signal(self, signum, frame) -> None:
        if self.stop_requested:
            raise KeyboardInterrupt
        self.stop_requested = True
        self.log(f"signal {signum}: stopping after this update (checkpoint follows)")

    def run(self) -> RunSummary:
        """Train until the budget is spent (or a stop signal / the target), then checkpoint,
        write the actor, history and plots."""
        self.out_dir.mkdir(parents=True, exist_ok=True)
        c = self.config
        previous = {}
        if threading.current_thread() is threading.main_thread():
            for sig in (signal.SIGINT, signal.SIGTERM):
                previous[sig] = signal.signal(sig, self._handle_stop_signal)
        session_start, session_steps = time.perf_counter(), self.env_steps
        cores = os.cpu_count() or 1
        if c.train_threads > cores:
            self.log(f"train_threads {c.train_threads} is more than this machine's {cores} cores: the updates share "
                     "them and get slower, not faster")
        metrics: Dict[str, float] = {}
        reached = False
        abandoned = False
        try:
            while self.update < c.n_updates and not self.stop_requested and not reached and not self.out_of_time:
                n_episodes = len(self.history["episodes"])
                try:
                    metrics = self.train_one_update()
                except _UpdateAbandoned:
                    abandoned = True
                    self.log(f"update {self.update + 1} abandoned; the checkpoint of update {self.update} stands")
                    break
                evaluation = None
                if (c.eval_every and self.update % c.eval_every == 0) or self.update == c.n_updates:
                    evaluation = self.evaluate()
                    reached = self.stop_at_target and self.time_to_target is not None
                self._write_scalars(metrics, self.history["episodes"][n_episodes:], evaluation)
                if self.update % c.log_every == 0 or evaluation is not None:
                    self.log(self._progress_line(metrics, session_start, session_steps, evaluation))
                if self.update % c.checkpoint_every == 0 or not self.pool.replayable:
                    self.save_checkpoint()
        finally:
            for sig, handler in previous.items():
                signal.signal(sig, handler)
        if self.out_of_time and not abandoned and not self.stop_requested and \
                (not self.history["evaluations"] or self.history["evaluations"][-1]["update"] != self.update):
            self.log(self._progress_line(metrics, session_start, session_steps, self.evaluate()))
        if not abandoned:
            self.save_checkpoint()
        self.finish()
        last = self.history["evaluations"][-1] if self.history["evaluations"] else None
        kept = self.best_makespan if c.keep_best and self.best_actor is not None else None
        return RunSummary(updates=self.update, env_steps=self.env_steps, episodes=self.episodes,
                          wall_time=self.wall_time, greedy_makespan=last["makespan"] if last else float("nan"),
                          time_to_target=self.time_to_target, steps_to_target=self.steps_to_target,
                          stopped_early=self.update < c.n_updates, last_metrics=metrics,
                          greedy_consistent=last is None or math.isfinite(last["consistent_makespan"]),
                          kept_makespan=kept)

    @property
    def out_of_time(self) -> bool:
        """max_wall_seconds of training wall time are spent."""
        return 0.0 < self.config.max_wall_seconds <= self.wall_time

    def finish(self) -> None:
        """history.json and the plots; closes TensorBoard."""
        (self.out_dir / "history.json").write_text(json.dumps(self.history, allow_nan=True))
        if self._writer is not None:
            self._writer.close()
            self._writer = None
        if self.want_plots:
            from marl_mrta.mappo.plots import write_plots
            write_plots(self.history, self.out_dir / "plots", self.n_agents, self.target_makespan)
