"""The one episode loop: a Policy (env/api.py) through an environment, for training's greedy
evaluations, the evaluation command, decentralised execution and the benchmarks alike."""
from __future__ import annotations

from typing import Callable, List, Optional

from marl_mrta.env.api import Policy, StepOutput, TaskAllocationEnv
from marl_mrta.model.schedule import EpisodeRecord

ProgressFn = Callable[[int, int], None]
#: Decision steps after which an episode that has not ended is an error (a policy that never
#: ends an episode, e.g. all-None forever with the episode timeout out of reach).
MAX_STEPS = 10_000


def run_episode(env: TaskAllocationEnv, policy: Policy, seed: int, episode: Optional[int] = None,
                max_steps: int = MAX_STEPS, on_step: Optional[Callable[[StepOutput], None]] = None) -> EpisodeRecord:
    """One episode reset with `seed`; on_step(output) sees every step's output. Returns the
    schedule record; RuntimeError when it has not ended after max_steps decisions."""
    output = env.reset(seed=seed)
    policy.begin_episode(output, episode)
    step, act = env.step, policy.act
    for _ in range(max_steps):
        output = step(act(output))
        if on_step is not None:
            on_step(output)
        if output.done or output.truncated:
            return output.info.episode
    raise RuntimeError(f"episode {episode} did not end within {max_steps} steps")


def run_episodes(env: TaskAllocationEnv, policy: Policy, episodes: int, seed: int,
                 progress: Optional[ProgressFn] = None, max_steps: int = MAX_STEPS,
                 stop_on_abort: bool = False) -> List[EpisodeRecord]:
    """Episode k is reset with seed + k, so runs are reproducible and methods see the same noise draws.
    stop_on_abort: an aborted episode (a safety stop on real robots) is the run's last."""
    records: List[EpisodeRecord] = []
    for k in range(episodes):
        records.append(run_episode(env, policy, seed + k, k, max_steps))
        if progress is not None:
            progress(k + 1, episodes)
        if stop_on_abort and records[-1].abort_reason:
            break
    return records
