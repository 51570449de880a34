"""The MAPPO runner on the real embedded environment (lab_2r): checkpoint → resume gives a
bit-identical next update; a killed `train` resumes from its checkpoint; the standalone actor
acts; bad input to `train` is one line."""
import dataclasses
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import torch

from marl_mrta.evaluation.training import on_new_env
from marl_mrta.mappo.training_env import embedded_factory
from marl_mrta.mappo.config import config_from_dict, load_config, resolve_preset
from marl_mrta.mappo.policy import PolicyFileError, load_policy
from marl_mrta.mappo.runner import Runner, RunError

ROOT = Path(__file__).resolve().parents[2]
SCENARIO = str(ROOT / "scenarios" / "lab_2r.xml")
TRAIN = [sys.executable, str(ROOT / "scripts" / "train")]
# Small enough for seconds, large enough that chunks cross episode ends and updates have
# several minibatches and epochs.
TINY = dict(n_envs=2, batch_size=24, minibatch_size=12, chunk_length=4, epochs=2, total_env_steps=240,
            learning_rate=1e-3, eval_every=0, eval_episodes=2, action_mask="logic",
            reward_overrides={"nav": {"best": 0.0}})


def _runner(tmp_path, **overrides):
    config = config_from_dict({**TINY, **overrides})
    make_env = embedded_factory(SCENARIO, config)
    return Runner(config, make_env, evaluate=on_new_env(make_env), scenario=SCENARIO, seed=7,
                  out_dir=tmp_path / "run", log=lambda line: None, tensorboard=False, plots=False)


def test_a_greedy_schedule_out_of_order_is_no_policy_found_and_the_summary_says_so(tmp_path):
    """time_to_target counts only complete, logic-consistent greedy schedules, and the run's last
    line says when the saved actor's schedule is out of order. The double `out_of_order` reports
    the real greedy episodes with a task finished before its predecessor."""
    config = config_from_dict({**TINY, "eval_every": 5, "total_env_steps": 120})   # one evaluation, complete
    make_env = embedded_factory(SCENARIO, config)
    real = on_new_env(make_env)

    def out_of_order(actor, seeds):
        return [dataclasses.replace(record, logic_consistent=False) for record in real(actor, seeds)]

    results = {}
    for name, evaluate in (("real", real), ("out_of_order", out_of_order)):
        runner = Runner(config, make_env, evaluate=evaluate, scenario=SCENARIO, seed=7, out_dir=tmp_path / name,
                        log=lambda line: None, tensorboard=False, plots=False, target_makespan=1000.0)
        runner.start()
        results[name] = runner.run()
    assert results["real"].time_to_target is not None and results["real"].greedy_consistent
    assert "NOT logic-consistent" not in results["real"].greedy_result()
    assert results["out_of_order"].time_to_target is None and not results["out_of_order"].greedy_consistent
    assert results["out_of_order"].greedy_makespan == results["real"].greedy_makespan   # the same episodes
    assert "NOT logic-consistent" in results["out_of_order"].greedy_result()
    unfinished = dataclasses.replace(results["real"], greedy_makespan=math.inf, greedy_consistent=False)
    assert "did NOT finish every task" in unfinished.greedy_result()


def _flat_state(runner):
    state = runner.trainer.state_dict()
    tensors = {}
    for part in ("actor", "critic", "value_norm"):
        tensors.update({f"{part}.{k}": v for k, v in state[part].items()})
    for part in ("actor_optimizer", "critic_optimizer"):
        for index, slots in state[part]["state"].items():
            tensors.update({f"{part}.{index}.{k}": v for k, v in slots.items() if torch.is_tensor(v)})
    return tensors


def test_checkpoint_then_resume_gives_bit_identical_next_update(tmp_path):
    first = _runner(tmp_path)
    first.start()
    first.train_one_update()
    first.train_one_update()
    first.save_checkpoint()
    assert not list((tmp_path / "run").glob("*.tmp"))            # written via tmp + os.replace
    expected_metrics = first.train_one_update()
    expected_state = _flat_state(first)
    expected_actions = first.buffer.actions.clone()
    # Collection honoured the environment's logic masks (B tasks stay masked until their A is done).
    allowed = first.buffer.action_mask.gather(-1, first.buffer.actions.unsqueeze(-1))
    assert allowed.all() and not first.buffer.action_mask.all()
    assert first.buffer.episode_start[1:].any()                  # the batch crossed episode ends

    make_env = embedded_factory(SCENARIO, first.config)
    resumed = Runner.resume(tmp_path / "run", make_env, evaluate=on_new_env(make_env), log=lambda line: None,
                            tensorboard=False, plots=False)
    assert resumed.update == 2
    metrics = resumed.train_one_update()
    assert torch.equal(resumed.buffer.actions, expected_actions)
    state = _flat_state(resumed)
    assert state.keys() == expected_state.keys()
    for name, tensor in expected_state.items():
        assert torch.equal(state[name], tensor), name
    for key in ("loss", "policy_loss", "value_loss", "entropy", "approx_kl", "clipfrac", "explained_variance",
                "grad_norm"):
        assert math.isfinite(metrics[key]), key
        assert metrics[key] == expected_metrics[key], key
    # The update did change the networks: equality above is not vacuous.
    fresh = _runner(tmp_path / "other")
    assert not torch.equal(_flat_state(fresh)["actor.head.weight"], state["actor.head.weight"])


def test_updates_take_train_threads_and_repeat_bit_for_bit(tmp_path):
    """train_threads: 2: each PPO update runs on two torch threads, collection and evaluation
    on one again after it; two runs of the same seed end with the same weights, bit for bit."""
    states = []
    for k in range(2):
        runner = _runner(tmp_path / str(k), train_threads=2, hidden_size=128)
        seen = []
        train = runner.trainer.train

        def spy(*args, **kwargs):
            seen.append(torch.get_num_threads())
            return train(*args, **kwargs)

        runner.trainer.train = spy
        runner.start()
        runner.train_one_update()
        runner.train_one_update()
        assert seen == [2, 2] and torch.get_num_threads() == 1
        states.append(_flat_state(runner))
    for name, tensor in states[0].items():
        assert torch.equal(states[1][name], tensor), name


def test_more_train_threads_than_cores_are_named_in_the_log(tmp_path, monkeypatch):
    monkeypatch.setattr(os, "cpu_count", lambda: 1)
    lines = []
    config = config_from_dict({**TINY, "train_threads": 2, "total_env_steps": 24})
    make_env = embedded_factory(SCENARIO, config)
    runner = Runner(config, make_env, evaluate=on_new_env(make_env), scenario=SCENARIO, seed=7,
                    out_dir=tmp_path / "run", log=lines.append, tensorboard=False, plots=False)
    runner.start()
    runner.run()
    assert any("train_threads 2 is more than this machine's 1 cores" in line for line in lines), lines


def test_fresh_run_refuses_an_existing_run_directory(tmp_path):
    runner = _runner(tmp_path)
    runner.start()
    runner.save_checkpoint()
    with pytest.raises(RunError, match="checkpoint.pt: a run exists here"):
        _runner(tmp_path).start()


def test_standalone_actor_file_acts_with_masks(tmp_path):
    runner = _runner(tmp_path)
    runner.start()
    runner.train_one_update()
    runner.save_checkpoint()
    policy = load_policy(tmp_path / "run" / "actor.pt")
    assert policy.action_mask == "logic"
    env = runner.make_env()
    out = env.reset(seed=3)
    hidden = policy.initial_hidden(env.n_agents)
    for _ in range(3):
        actions, hidden = policy.act(out.obs, out.action_mask, hidden)
        assert out.action_mask[np.arange(env.n_agents), actions].all()
        # One robot's node acting alone on its own observation chooses the same task.
        alone, _ = policy.act(out.obs[1:], out.action_mask[1:], hidden[1:], agent_ids=[1])
        assert alone[0] == actions[1]
        out = env.step(actions)
        if out.done or out.truncated:
            break
    bad = tmp_path / "not_an_actor.pt"
    bad.write_bytes(b"hello")
    with pytest.raises(PolicyFileError, match="not_an_actor.pt: not a readable actor file"):
        load_policy(bad)


def _write_preset(tmp_path, **overrides):
    path = tmp_path / "preset.yaml"
    path.write_text("".join(f"{k}: {v}\n" for k, v in {**TINY, **overrides}.items()))
    return path


@pytest.mark.slow
def test_killed_train_resumes_from_its_last_checkpoint(tmp_path):
    preset = _write_preset(tmp_path, total_env_steps=24 * 60, checkpoint_every=2)
    out = tmp_path / "run"
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    process = subprocess.Popen(TRAIN + ["--scenario", SCENARIO, "--preset", str(preset), "--seed", "3",
                                        "--out", str(out)], env=env, cwd=tmp_path,
                               stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    checkpoint = out / "checkpoint.pt"
    deadline = time.monotonic() + 120
    while not checkpoint.exists() and process.poll() is None and time.monotonic() < deadline:
        time.sleep(0.05)
    process.send_signal(signal.SIGKILL)
    process.wait()
    stored = Runner.read_checkpoint(checkpoint)["counters"]["update"]
    assert 2 <= stored < 60

    resumed = subprocess.run(TRAIN + ["--out", str(out), "--resume"], env=env, cwd=tmp_path,
                             capture_output=True, text=True, timeout=300)
    assert resumed.returncode == 0, resumed.stderr
    assert f"resuming {out} at update {stored}/60" in resumed.stdout
    final = Runner.read_checkpoint(checkpoint)
    assert final["counters"]["update"] == 60
    assert len(final["history"]["updates"]) == 60               # nothing lost, nothing repeated
    assert (out / "plots" / "losses.png").exists() and (out / "actor.pt").exists()


def _train(arguments, cwd):
    return subprocess.run(TRAIN + arguments, env=dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path)), cwd=cwd,
                          capture_output=True, text=True, timeout=120)


@pytest.mark.slow
def test_bad_input_to_train_is_one_line(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("gama: 0.9\n")
    out = str(tmp_path / "out")
    cases = [
        (["--preset", str(bad), "--out", out], f"{bad}: gama: unknown setting (did you mean gamma?)"),
        (["--scenario", str(tmp_path / "missing.xml"), "--out", out], "missing.xml"),
        (["--resume", "--out", str(tmp_path / "nothing")], f"{tmp_path}/nothing/checkpoint.pt: no checkpoint to resume"),
    ]
    for arguments, message in cases:
        result = _train(arguments, tmp_path)
        assert result.returncode == 2, arguments
        lines = result.stderr.strip().splitlines()
        assert len(lines) == 1 and message in lines[0], result.stderr
        assert "Traceback" not in result.stderr


def test_resume_rejects_contradicting_settings(tmp_path):
    runner = _runner(tmp_path)
    runner.start()
    runner.save_checkpoint()
    result = _train(["--out", str(tmp_path / "run"), "--resume", "--seed", "8"], tmp_path)
    assert result.returncode == 2
    assert "--seed: 8 differs from the run's seed 7" in result.stderr


def test_presets_build_environments():
    for preset in ("paper", "tuned"):
        config = load_config(resolve_preset(preset))
        env = embedded_factory(SCENARIO, config)()
        assert env.settings.mask == config.action_mask
