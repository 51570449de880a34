"""N instances of a task-allocation environment stepped together, with automatic reset.

Every episode is reset with its own seed, derived from (run seed, environment index, episode
number), and the joint actions of the running episodes are recorded. A checkpoint therefore
needs only the episode numbers and those actions: `restore()` resets each environment with
the same seed and replays the actions, which rebuilds the environments exactly (environments
are deterministic given reset seed and actions) without pickling them.

Environments whose step is a blocking call that waits for a simulation (the ros backend:
one arena per environment) are stepped in parallel threads (`parallel=True`), and, since a
simulation is not repeatable bit for bit, are not replayed on restore (`replayable=False`):
the episodes running at the checkpoint are abandoned and fresh ones start. Such environments
may also be stepped one at a time (`step_one`), each by its own thread, so that none waits
for another's step to end.
"""
from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any, Callable, Dict, List, Optional, Sequence

import numpy as np

from marl_mrta.env.api import REWARD_COMPONENTS, StepOutput, TaskAllocationEnv


def episode_seed(run_seed: int, env_index: int, episode: int) -> int:
    """Reset seed of one episode; independent streams per environment and episode."""
    return int(np.random.SeedSequence([run_seed, env_index, episode]).generate_state(1)[0])


@dataclass
class EpisodeSummary:
    """One finished episode, as the logs and plots need it."""

    env_index: int
    length: int                               # decision steps
    reward_per_robot: List[float]             # sum of weighted rewards, per robot
    components: Dict[str, List[float]]        # sum of each unweighted component, per robot
    terminated: bool                          # all tasks reached (False: timeout / abort)
    makespan: float                           # episode duration, s
    collisions: float                         # collision events
    logic_consistent: bool                    # complete, every task in precedence order
    robot_tasks: List[List[str]]              # per robot, the task ids it finished, in order
    #: The episode's reset seed and joint actions, to replay it (self-imitation); not in as_dict().
    seed: Optional[int] = None
    joint_actions: Optional[List[List[int]]] = field(default=None, repr=False)

    def as_dict(self) -> Dict[str, Any]:
        return {k: v for k, v in self.__dict__.items() if k not in ("seed", "joint_actions")}


@dataclass
class PoolStep:
    """Result of stepping every environment once. Rows are environments."""

    obs: np.ndarray              # (E, N, obs_dim) observation to act on next (after auto-reset)
    state: np.ndarray            # (E, state_dim) global state to act on next
    action_mask: np.ndarray      # (E, N, A) bool
    rewards: np.ndarray          # (E, N) weighted rewards of the step just taken
    terminated: np.ndarray       # (E,) bool: episode ended with all tasks reached
    truncated: np.ndarray        # (E,) bool: episode ended by timeout or abort
    final_state: np.ndarray      # (E, state_dim) last state of an ended episode (else = state)
    finished: List[EpisodeSummary] = field(default_factory=list)
    # Event mode (all robots, every step, in synchronous mode):
    deciding: Optional[np.ndarray] = None   # (E, N) bool: the robots that decide next
    busy: Optional[np.ndarray] = None       # (E, N) int64: each robot's task (driving, holding, serving), -1 none
    elapsed: Optional[np.ndarray] = None    # (E,) s: how long the step just taken lasted (0 after a reset)

    def row(self, i: int) -> "PoolStep":
        """Environment i alone (rows of the result: 1; no finished episodes)."""
        rows = slice(i, i + 1)
        return PoolStep(obs=self.obs[rows], state=self.state[rows], action_mask=self.action_mask[rows],
                        rewards=self.rewards[rows], terminated=self.terminated[rows], truncated=self.truncated[rows],
                        final_state=self.final_state[rows], deciding=self.deciding[rows], busy=self.busy[rows],
                        elapsed=self.elapsed[rows])


class EpisodeTally:
    """Sums of one running episode: add() every step's output, summary() at its end."""

    def __init__(self, n_agents: int):
        self.length = 0
        self.rewards = np.zeros(n_agents, dtype=np.float64)
        self.components = {name: np.zeros(n_agents, dtype=np.float64) for name in REWARD_COMPONENTS}

    def add(self, out: StepOutput) -> None:
        self.length += 1
        self.rewards += out.rewards
        for name, values in out.reward_components.items():
            self.components.setdefault(name, np.zeros_like(self.rewards))
            self.components[name] += values

    def summary(self, env_index: int, final: StepOutput, seed: Optional[int] = None,
                joint_actions: Optional[List[List[int]]] = None) -> EpisodeSummary:
        """The ended episode, with the figures of the schedule record its last step carries."""
        record = final.info.episode
        return EpisodeSummary(seed=seed, joint_actions=joint_actions, env_index=env_index, length=self.length,
                              reward_per_robot=self.rewards.tolist(),
                              components={k: v.tolist() for k, v in self.components.items()},
                              terminated=bool(final.done), makespan=float(record.makespan),
                              collisions=float(sum(record.collisions)),
                              logic_consistent=bool(record.logic_consistent),
                              robot_tasks=[[record.task_ids[t] for t in tasks] for tasks in record.robot_task_lists()])


class EnvPool:
    """The N environments of a run; `run_seed` fixes every episode of every environment."""

    def __init__(self, envs: Sequence[TaskAllocationEnv], run_seed: int, *, parallel: bool = False,
                 replayable: bool = True, mixed: bool = False):
        """parallel: step (and reset) the environments in one thread each; replayable: the
        environments are deterministic given reset seed and actions (module doc); mixed: the
        environments run different scenarios, each its `scenario` of the moment (training across
        scenarios: mappo/set_view.py), so `predecessors` (the first one's) speaks for none of them."""
        self.envs = list(envs)
        first = self.envs[0]
        n_envs = len(self.envs)
        self.n_envs = n_envs
        self.replayable = replayable
        self.mixed = mixed
        self._threads = ThreadPoolExecutor(max_workers=n_envs, thread_name_prefix="env") if parallel else None
        self.n_agents, self.n_actions = first.n_agents, first.n_actions
        self.obs_dim, self.state_dim = first.obs_dim, first.state_dim
        #: Per task, the indices of its predecessors (the claim rules of a sequential decision order).
        self.predecessors: List[List[int]] = [[int(p) for p in preds] for preds in first.scenario.predecessors]
        self.run_seed = run_seed
        self.episode_index = [0] * n_envs
        self.episode_actions: List[List[List[int]]] = [[] for _ in range(n_envs)]
        self._tallies = [EpisodeTally(self.n_agents) for _ in range(n_envs)]
        self._latest: List[Optional[StepOutput]] = [None] * n_envs

    @property
    def independent(self) -> bool:
        """Stepped in threads and not replayable (arenas of a simulation): each environment may run
        on its own (step_one) without changing what a run means."""
        return self._threads is not None and not self.replayable

    def _reset(self, i: int) -> StepOutput:
        out = self.envs[i].reset(seed=episode_seed(self.run_seed, i, self.episode_index[i]))
        self.episode_actions[i] = []
        self._tallies[i] = EpisodeTally(self.n_agents)
        self._latest[i] = out
        return out

    @classmethod
    def build(cls, make_env: Callable[[], TaskAllocationEnv], n_envs: int, run_seed: int) -> "EnvPool":
        """n_envs environments from one factory, stepped one after the other (embedded)."""
        return cls([make_env() for _ in range(n_envs)], run_seed)

    def map(self, function: Callable[[int], Any]) -> List[Any]:
        """function(i) for every environment, in threads when parallel; results in order."""
        if self._threads is None:
            return [function(i) for i in range(self.n_envs)]
        return list(self._threads.map(function, range(self.n_envs)))

    def current(self) -> PoolStep:
        """What every environment acts on next (no step taken: rewards zero, nothing ended)."""
        return self._current(np.zeros((self.n_envs, self.n_agents), np.float32),
                             np.zeros(self.n_envs, bool), np.zeros(self.n_envs, bool), [])

    @staticmethod
    def deciding_of(out: StepOutput, n_agents: int) -> np.ndarray:
        return np.ones(n_agents, bool) if out.deciding is None else np.asarray(out.deciding, bool)

    @staticmethod
    def busy_of(out: StepOutput, n_agents: int) -> np.ndarray:
        tasks = out.info.robot_tasks or [None] * n_agents
        return np.array([-1 if t is None else int(t) for t in tasks], dtype=np.int64)

    def reset(self) -> PoolStep:
        """Start the first episode of every environment."""
        self.map(self._reset)
        return self.current()

    def restart(self) -> PoolStep:
        """Abandon the running episodes (unrecorded) and start the next one in every environment."""
        self.episode_index = [k + 1 for k in self.episode_index]
        return self.reset()

    def _current(self, rewards, terminated, truncated, finished, final_state=None, elapsed=None) -> PoolStep:
        latest = self._latest
        state = np.stack([o.state for o in latest])
        n = self.n_agents
        return PoolStep(
            obs=np.stack([o.obs for o in latest]),
            state=state,
            action_mask=np.stack([o.action_mask for o in latest]).astype(bool),
            rewards=rewards, terminated=terminated, truncated=truncated,
            final_state=state.copy() if final_state is None else final_state,
            finished=finished,
            deciding=np.stack([self.deciding_of(o, n) for o in latest]),
            busy=np.stack([self.busy_of(o, n) for o in latest]),
            elapsed=np.zeros(self.n_envs, np.float64) if elapsed is None else elapsed,
        )

    def step(self, actions: np.ndarray) -> PoolStep:
        """Apply joint actions (E, N); ended episodes are recorded and their env reset."""
        rewards = np.zeros((self.n_envs, self.n_agents), np.float32)
        terminated = np.zeros(self.n_envs, bool)
        truncated = np.zeros(self.n_envs, bool)
        final_state = np.zeros((self.n_envs, self.state_dim), np.float32)
        elapsed = np.zeros(self.n_envs, np.float64)
        finished: List[EpisodeSummary] = []
        joints = [[int(a) for a in actions[i]] for i in range(self.n_envs)]
        outputs = self.map(lambda i: self.envs[i].step(joints[i]))
        for i, out in enumerate(outputs):
            summary = self._took(i, joints[i], out)
            rewards[i] = out.rewards
            final_state[i] = out.state
            elapsed[i] = out.info.step_duration
            if summary is not None:
                terminated[i], truncated[i] = bool(out.done), not out.done
                finished.append(summary)
        ended = [i for i in range(self.n_envs) if terminated[i] or truncated[i]]
        if self._threads is None or len(ended) < 2:
            for i in ended:
                self._reset(i)
        else:
            list(self._threads.map(self._reset, ended))
        return self._current(rewards, terminated, truncated, finished, final_state, elapsed)

    def step_one(self, i: int, actions: np.ndarray) -> PoolStep:
        """Environment i alone, joint actions (N,): step() for one row (rows of the result: 1).
        For environments that run independently of each other (module doc)."""
        joint = [int(a) for a in actions]
        out = self.envs[i].step(joint)
        summary = self._took(i, joint, out)
        if summary is not None:
            self._reset(i)
        latest = self._latest[i]
        ended = summary is not None
        return PoolStep(obs=latest.obs[None], state=latest.state[None],
                        action_mask=np.asarray(latest.action_mask, bool)[None],
                        rewards=np.asarray(out.rewards, np.float32)[None],
                        terminated=np.array([ended and bool(out.done)]),
                        truncated=np.array([ended and not out.done]),
                        final_state=np.asarray(out.state, np.float32)[None],
                        finished=[summary] if ended else [],
                        deciding=self.deciding_of(latest, self.n_agents)[None],
                        busy=self.busy_of(latest, self.n_agents)[None],
                        elapsed=np.array([out.info.step_duration], np.float64))

    def _took(self, i: int, joint: List[int], out: StepOutput) -> Optional[EpisodeSummary]:
        """Books environment i's step; an episode it ended is recorded (returned), not yet reset."""
        self.episode_actions[i].append(joint)
        self._tallies[i].add(out)
        if not (out.done or out.truncated):
            self._latest[i] = out
            return None
        seed = episode_seed(self.run_seed, i, self.episode_index[i])
        self.episode_index[i] += 1
        return self._tallies[i].summary(i, out, seed, self.episode_actions[i])

    def snapshot(self) -> Dict[str, Any]:
        """What restore() needs to rebuild the running episodes."""
        return {"episode_index": list(self.episode_index),
                "episode_actions": [list(map(list, acts)) for acts in self.episode_actions]}

    def restore(self, snapshot: Dict[str, Any]) -> PoolStep:
        """Rebuild the running episodes: reset with their seeds, replay their actions. Not
        replayable: abandon them and start the next episode of every environment."""
        self.episode_index = list(snapshot["episode_index"])
        if not self.replayable:
            return self.restart()
        for i, env in enumerate(self.envs):
            self._reset(i)
            for joint in snapshot["episode_actions"][i]:
                out = env.step(list(joint))
                if out.done or out.truncated:
                    raise RuntimeError(f"environment {i}: replaying the checkpoint's actions ended the "
                                       "episode early; the environment is not deterministic given its seed")
                self.episode_actions[i].append(list(joint))
                self._tallies[i].add(out)
                self._latest[i] = out
        return self.current()

    def close(self) -> None:
        if self._threads is not None:
            self._threads.shutdown(wait=False)
