"""What the ros backend of the trainer relies on, on real embedded environments (lab_2r):
the training reward recomputed from a step's info equals the reward an environment built with
it gives; a parallel pool steps exactly like a sequential one; a pool that cannot replay
restarts its episodes on resume and evaluates in its own environments; a stop signal while
collecting from such a pool keeps the previous update's checkpoint; such a pool's arenas collect
without waiting for each other's steps, each into its own buffer column, and one arena's error
stops the others; `train --set`/`--arenas`."""
import dataclasses
import os
import subprocess
import sys

import numpy as np
import pytest

from marl_mrta.env.factory import make_env
from marl_mrta.apps.train import main as train_main, parse_overrides
from marl_mrta.evaluation.training import in_pool
from marl_mrta.common.config import ConfigError
from marl_mrta.mappo.config import config_from_dict
from marl_mrta.mappo.env_pool import EnvPool, episode_seed
from marl_mrta.mappo.runner import Runner
from marl_mrta.mappo.training_env import TrainingRewardEnv, embedded_factory, training_reward
from marl_mrta.model.scenario import load_scenario

from test_mappo_runner import SCENARIO, TINY

OVERRIDES = {"nav": {"best": 0.0}, "idle": {"per_second": -0.3}}


def _random_episode(env, rng, seed):
    out = env.reset(seed=seed)
    outputs = []
    while True:
        actions = [int(rng.choice(np.flatnonzero(row))) for row in out.action_mask]
        out = env.step(actions)
        outputs.append(out)
        if out.done or out.truncated:
            return outputs


def test_training_reward_equals_an_environment_built_with_it():
    scenario = load_scenario(SCENARIO)
    plain = make_env(scenario, mask="logic")                       # scores with config/reward.yaml
    with_overrides = make_env(dataclasses.replace(scenario, reward_overrides=OVERRIDES), mask="logic")
    rescored = TrainingRewardEnv(plain, training_reward(scenario, OVERRIDES), scenario.n_tasks)
    changed = 0
    for seed in range(6):
        expected = _random_episode(with_overrides, np.random.default_rng(seed), seed)
        got = _random_episode(rescored, np.random.default_rng(seed), seed)
        assert len(got) == len(expected)
        for a, b in zip(got, expected):
            np.testing.assert_allclose(a.rewards, b.rewards, rtol=0, atol=1e-5)
            for name in b.reward_components:
                np.testing.assert_allclose(a.reward_components[name], b.reward_components[name], atol=1e-5)
        changed += sum(not np.allclose(o.rewards, p.rewards) for o, p in
                       zip(_random_episode(plain, np.random.default_rng(seed), seed), expected))
    assert changed > 0   # the overrides do change rewards: the comparison means something


def _pool(parallel, replayable=True, n=3, seed=5):
    config = config_from_dict(dict(TINY))
    build = embedded_factory(SCENARIO, config)
    return EnvPool([build() for _ in range(n)], seed, parallel=parallel, replayable=replayable)


def test_parallel_pool_steps_like_a_sequential_one():
    pools = [_pool(False), _pool(True)]
    steps = [pool.reset() for pool in pools]
    rng = np.random.default_rng(0)
    ended = 0
    for _ in range(40):
        actions = np.array([[int(rng.choice(np.flatnonzero(row))) for row in env_mask]
                            for env_mask in steps[0].action_mask])
        steps = [pool.step(actions) for pool in pools]
        np.testing.assert_array_equal(steps[0].obs, steps[1].obs)
        np.testing.assert_array_equal(steps[0].rewards, steps[1].rewards)
        np.testing.assert_array_equal(steps[0].terminated | steps[0].truncated, steps[1].terminated | steps[1].truncated)
        assert [e.makespan for e in steps[0].finished] == [e.makespan for e in steps[1].finished]
        ended += len(steps[0].finished)
    assert ended > 0
    assert pools[0].episode_index == pools[1].episode_index


def test_pool_that_cannot_replay_restarts_its_episodes_on_restore():
    pool = _pool(True, replayable=False, n=2)
    pool.reset()
    pool.step(np.array([[0, 2], [0, 2]]))
    snapshot = pool.snapshot()
    assert snapshot["episode_actions"][0] == [[0, 2]]
    fresh = _pool(True, replayable=False, n=2)
    step = fresh.restore(snapshot)
    assert fresh.episode_index == [k + 1 for k in snapshot["episode_index"]]
    assert fresh.episode_actions == [[], []]
    # The new episodes start where a reset with their seeds starts.
    env = embedded_factory(SCENARIO, config_from_dict(dict(TINY)))()
    expected = env.reset(seed=episode_seed(5, 1, fresh.episode_index[1]))
    np.testing.assert_array_equal(step.obs[1], expected.obs)


class _StopAfter:
    """An environment that asks the runner to stop (as a signal would) at its `steps`-th
    training step after the first greedy evaluation, i.e. while update 3 collects."""

    def __init__(self, env, runner_box, steps):
        self.env, self.box, self.left = env, runner_box, steps
        self.n_agents, self.n_actions, self.obs_dim, self.state_dim = env.n_agents, env.n_actions, env.obs_dim, env.state_dim
        self.scenario = env.scenario

    def reset(self, seed=None):
        return self.env.reset(seed=seed)

    def step(self, actions):
        if self.box[0].history["evaluations"]:
            self.left -= 1
            if self.left == 0:
                self.box[0].stop_requested = True
        return self.env.step(actions)


def test_runner_on_a_pool_that_cannot_replay(tmp_path):
    config = config_from_dict({**TINY, "total_env_steps": 24 * 4, "eval_every": 2})
    build = embedded_factory(SCENARIO, config)
    box = []
    envs = [_StopAfter(build(), box, 5), build()]
    pool = EnvPool(envs, 7, parallel=True, replayable=False)
    runner = Runner(config, None, evaluate=in_pool(pool), scenario=SCENARIO, seed=7, out_dir=tmp_path / "run", log=lambda line: None,
                    tensorboard=False, plots=False, pool=pool)
    box.append(runner)
    runner.start()
    summary = runner.run()
    # Updates 1 and 2 ran (checkpointed after each), the third was abandoned: its checkpoint is update 2's.
    assert summary.updates == 2 and summary.env_steps == 48
    data = Runner.read_checkpoint(tmp_path / "run" / "checkpoint.pt")
    assert data["counters"]["update"] == 2 and data["counters"]["env_steps"] == 48
    # The evaluation after update 2 ran in the pool's environments, then fresh episodes started.
    assert len(data["history"]["evaluations"]) == 1
    assert data["env_pool"]["episode_actions"] == [[], []]
    assert all(len(e["robot_tasks"]) == 2 for e in data["history"]["episodes"])

    pool = EnvPool([build(), build()], 7, parallel=True, replayable=False)
    resumed = Runner.resume(tmp_path / "run", None, evaluate=in_pool(pool), log=lambda line: None, tensorboard=False,
                            plots=False, pool=pool)
    assert resumed.update == 2 and bool(resumed.episode_start.all()) and float(resumed.hidden.abs().sum()) == 0.0
    final = resumed.run()
    assert final.updates == 4 and final.env_steps == 96
    history = Runner.read_checkpoint(tmp_path / "run" / "checkpoint.pt")["history"]
    assert [u["update"] for u in history["updates"]] == [1, 2, 3, 4]


def test_pool_size_must_match_the_settings(tmp_path):
    config = config_from_dict(dict(TINY))
    build = embedded_factory(SCENARIO, config)
    with pytest.raises(Exception, match="n_envs: the settings ask for 2 environments, the pool has 3"):
        pool = EnvPool([build() for _ in range(3)], 0)
        Runner(config, None, evaluate=in_pool(pool), scenario=SCENARIO, seed=0, out_dir=tmp_path, pool=pool)


def test_set_overrides_and_arenas_errors(tmp_path, capsys):
    assert parse_overrides(["batch_size=40", "learning_rate=2e-3", "reward_overrides={nav: {best: 0}}"]) == {
        "batch_size": 40, "learning_rate": 2e-3, "reward_overrides": {"nav": {"best": 0}}}
    with pytest.raises(ConfigError, match="not KEY=VALUE"):
        parse_overrides(["batch_size"])
    assert train_main(["--out", str(tmp_path / "a"), "--set", "batch_sise=40"]) == 2
    assert "batch_sise: unknown setting (did you mean batch_size?)" in capsys.readouterr().err
    assert train_main(["--out", str(tmp_path / "b"), "--arenas", "2"]) == 2
    err = capsys.readouterr().err
    assert err.strip() == "train: --arenas: only with --backend ros"


def test_ros_backend_without_a_graph_is_one_line(tmp_path):
    """No master (an unused port): one line naming it and what to start, exit 1, no traceback."""
    # The sourced workspace's PYTHONPATH: its marl_mrta has the generated services too.
    env = dict(os.environ, ROS_MASTER_URI="http://localhost:1")
    run = subprocess.run([sys.executable, "-c", "import sys; from marl_mrta.apps.train import main; "
                          "sys.exit(main(['--backend', 'ros', '--arenas', '2', '--out', sys.argv[1]]))",
                          str(tmp_path / "run")], env=env, capture_output=True, text=True, timeout=600)
    assert run.returncode == 1, run.stderr
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in run.stderr
    assert lines[0].startswith("train: no ROS master at http://localhost:1")
    assert "tasks.launch arenas:=2 mask:=logic" in lines[0]


class _WaitsForOther:
    """Environment 0 of a pair: its second step returns only once environment 1 (`other`) has taken
    `steps` more steps, which can happen only if the two are not stepped in lock-step. It tells
    `other` when it has begun to wait."""

    def __init__(self, env, other, steps):
        self.env, self.other, self.steps, self.calls = env, other, steps, 0
        self.n_agents, self.n_actions, self.obs_dim, self.state_dim = env.n_agents, env.n_actions, env.obs_dim, env.state_dim
        self.scenario = env.scenario

    def reset(self, seed=None):
        return self.env.reset(seed=seed)

    def step(self, actions):
        self.calls += 1
        if self.calls == 2:
            self.other.waited_for.set()
            with self.other.advanced:
                target = self.other.calls + self.steps
                assert self.other.advanced.wait_for(lambda: self.other.calls >= target, timeout=60.0), \
                    "environment 1 did not step while environment 0's step was running"
        return self.env.step(actions)


class _Counted:
    """Environment 1 of the pair: counts its steps and tells whoever waits on them. Its fifth step
    waits until environment 0 waits for it, so that it cannot use up its rollout before (a thread
    scheduled late on a busy machine would otherwise find too few steps left to wait for)."""

    HEAD_START = 4

    def __init__(self, env):
        import threading
        self.env, self.calls, self.advanced = env, 0, threading.Condition()
        self.waited_for = threading.Event()
        self.n_agents, self.n_actions, self.obs_dim, self.state_dim = env.n_agents, env.n_actions, env.obs_dim, env.state_dim
        self.scenario = env.scenario

    def reset(self, seed=None):
        return self.env.reset(seed=seed)

    def step(self, actions):
        if self.calls == self.HEAD_START:
            assert self.waited_for.wait(timeout=60.0), "environment 0 never took its second step"
        out = self.env.step(actions)
        with self.advanced:
            self.calls += 1
            self.advanced.notify_all()
        return out


def test_arenas_of_a_simulation_do_not_wait_for_each_others_steps(tmp_path):
    config = config_from_dict({**TINY, "total_env_steps": 24})
    build = embedded_factory(SCENARIO, config)
    fast = _Counted(build())
    slow = _WaitsForOther(build(), fast, 3)
    pool = EnvPool([slow, fast], 7, parallel=True, replayable=False)
    assert pool.independent
    runner = Runner(config, None, evaluate=in_pool(pool), scenario=SCENARIO, seed=7, out_dir=tmp_path / "run", log=lambda line: None,
                    tensorboard=False, plots=False, pool=pool)
    runner.start()
    assert runner.run().env_steps == 24
    assert slow.calls >= 2   # the waiting step was taken (and did not time out)


def test_each_arena_column_of_the_buffer_is_that_arenas_own_trajectory(tmp_path):
    config = config_from_dict({**TINY, "batch_size": 40, "chunk_length": 4})
    build = embedded_factory(SCENARIO, config)
    pool = EnvPool([build(), build()], 11, parallel=True, replayable=False)
    runner = Runner(config, None, evaluate=in_pool(pool), scenario=SCENARIO, seed=11, out_dir=tmp_path / "run", log=lambda line: None,
                    tensorboard=False, plots=False, pool=pool)
    runner.start()
    finished = runner.collect()
    buffer = runner.buffer
    assert buffer.full and runner.env_steps == 40
    ended = 0
    for i in range(2):
        # Replaying column i's actions from the seeds of arena i's episodes gives its states.
        env, episode = build(), 0
        out = env.reset(seed=episode_seed(11, i, episode))
        for t in range(buffer.rollout_length):
            np.testing.assert_allclose(buffer.state[t, i].numpy(), out.state, rtol=0, atol=1e-6)
            assert bool(buffer.episode_start[t, i]) == (t == 0 or bool(buffer.terminated[t - 1, i] | buffer.truncated[t - 1, i]))
            out = env.step([int(a) for a in buffer.actions[t, i]])
            assert bool(buffer.terminated[t, i]) == out.done
            if out.done or out.truncated:
                ended += 1
                episode += 1
                out = env.reset(seed=episode_seed(11, i, episode))
        assert pool.episode_index[i] == episode
    assert ended == len(finished) > 0
    np.testing.assert_array_equal(runner.current.state[1], out.state)


class _Fails(_Counted):
    """An environment whose third step raises, as a lost task manager does."""

    def __init__(self, env):
        import threading
        super().__init__(env)
        self.raised = threading.Event()

    def step(self, actions):
        if self.calls == 2:
            self.raised.set()
            raise RuntimeError("arena_1/rl_task_allocation_manager/step: manager lost")
        return super().step(actions)


class _WaitsForFailure(_Counted):
    """Its second step ends only once the other arena has failed."""

    def __init__(self, env, failing):
        super().__init__(env)
        self.failing = failing

    def step(self, actions):
        if self.calls == 1:
            assert self.failing.raised.wait(timeout=60.0), "the failing arena never took its third step"
        return super().step(actions)


def test_an_arena_that_fails_stops_the_other_at_its_next_step(tmp_path):
    config = config_from_dict({**TINY, "batch_size": 200, "chunk_length": 4, "total_env_steps": 200})
    build = embedded_factory(SCENARIO, config)
    failing = _Fails(build())
    healthy = _WaitsForFailure(build(), failing)
    pool = EnvPool([healthy, failing], 7, parallel=True, replayable=False)
    runner = Runner(config, None, evaluate=in_pool(pool), scenario=SCENARIO, seed=7, out_dir=tmp_path / "run", log=lambda line: None,
                    tensorboard=False, plots=False, pool=pool)
    runner.start()
    with pytest.raises(RuntimeError, match="manager lost"):
        runner.collect()
    assert healthy.calls < 100   # stopped soon after, not after its 100 steps of the batch
