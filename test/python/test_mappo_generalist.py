"""The shipped generalist (policies/generalist.pt): the name stands for the file wherever an actor
file is taken, it schedules scenarios it never saw, and `train --init generalist` fine-tunes it
(preset finetune, a wall-time budget) to the proven optimum of lab_2r."""
import json

import pytest

from marl_mrta.apps.bench_generalise import summary_of, zero_shot
from marl_mrta.apps.evaluate import main as evaluate_main
from marl_mrta.apps.train import main as train_main, parse_overrides
from marl_mrta.baselines.reference import scenario_reference
from marl_mrta.common.paths import package_root
from marl_mrta.env.settings import load_task_settings
from marl_mrta.mappo.config import config_to_dict, load_config, resolve_preset
from marl_mrta.mappo.policy import SetActorPolicy, actor_file_path, load_policy, read_actor_file
from marl_mrta.mappo.runner import Runner
from marl_mrta.model.generator import ScenarioRequest, generate_scenario
from marl_mrta.model.scenario import load_scenario

SCENARIOS = package_root() / "scenarios"


def optimum(name):
    task = load_task_settings()
    plan, _ = scenario_reference(load_scenario(SCENARIOS / f"{name}.xml"), task.min_step, goal_timeout=task.goal_timeout)
    assert plan.proven_optimal
    return plan.makespan


def trained_with(run):
    """The settings a training run stored in its checkpoint."""
    return Runner.read_checkpoint(run / "checkpoint.pt")["config"]


def preset_with(preset, *settings):
    """A preset's settings with train's `--set` items on top."""
    return config_to_dict(load_config(resolve_preset(preset), parse_overrides(list(settings))))


def test_the_name_generalist_stands_for_the_shipped_set_actor():
    path = actor_file_path("generalist")
    assert path == package_root() / "policies" / "generalist.pt" and path.is_file()
    assert actor_file_path("results/actor.pt").name == "actor.pt"      # any other reference is a path
    _, data = read_actor_file("generalist")
    assert isinstance(load_policy("generalist"), SetActorPolicy)
    config = load_config(resolve_preset("finetune"))       # the preset fine-tunes exactly this network
    assert (data["hidden_size"], data["heads"], data["layers"]) == (config.hidden_size, config.set_heads, config.set_layers)
    assert config.init_actor == "generalist" and config.max_wall_seconds == 60.0


@pytest.mark.parametrize("name", ["lab_2r", "lab_4r"])
def test_zero_shot_on_the_lab_is_the_optimum(name):
    """Without training on the scenario (the lab scenarios are among the generalist's training
    scenarios), its greedy schedule is the proven optimum. lab_3r: 1.024 (docs/guide/training.md)."""
    shot = zero_shot(load_policy("generalist"), load_scenario(SCENARIOS / f"{name}.xml"), "finished")
    assert shot["makespan"] == pytest.approx(optimum(name), abs=1e-6)


def test_zero_shot_on_generated_scenarios_it_never_saw(tmp_path):
    """Scenarios of a seed no training used, 2-4 robots, 4-12 tasks, every layout: every greedy
    episode finishes every task in precedence order."""
    policy = load_policy("generalist")
    makespans = []
    for k, (robots, tasks, layout) in enumerate([(2, 6, "rooms"), (3, 10, "corridors"), (4, 12, "pillars"),
                                                 (3, 8, "lab")]):
        request = ScenarioRequest(n_robots=robots, n_tasks=tasks, layout=layout, name=f"unseen_{k}")
        makespans.append(zero_shot(policy, generate_scenario(request, 90_000 + k, tmp_path), "finished")["makespan"])
    assert summary_of(makespans)["failed"] == 0, makespans


def test_evaluate_and_train_take_the_name(tmp_path, capsys):
    out = tmp_path / "e.json"
    assert evaluate_main(["--method", "policy", "--policy", "generalist", "--scenario", str(SCENARIOS / "lab_4r.xml"),
                          "--mask", "finished", "--episodes", "1", "--no-exact", "--quiet", "--out", str(out)]) == 0
    summary = json.loads(out.read_text())["results"][0]["summary"]
    assert summary["method"] == "policy" and summary["n_robots"] == 4
    assert evaluate_main(["--method", "policy", "--policy", "generalists", "--episodes", "1", "--no-exact", "--quiet",
                          "--out", str(out)]) == 2
    assert "generalists: no such file" in capsys.readouterr().err


def test_evaluate_acts_under_the_mask_the_actor_was_trained_with(tmp_path, capsys):
    """Without --mask the generalist acts under its training mask (finished) and completes lab_3r;
    under config/task.yaml's none it would stall (each robot one task, then None until the
    timeout), so asking for another mask is a one-line error."""
    out = tmp_path / "e.json"
    assert evaluate_main(["--method", "policy", "--policy", "generalist", "--scenario", str(SCENARIOS / "lab_3r.xml"),
                          "--episodes", "1", "--no-exact", "--quiet", "--out", str(out)]) == 0
    document = json.loads(out.read_text())
    assert document["mask"] == "finished"
    assert document["results"][0]["summary"]["complete_pct"] == 100.0
    assert evaluate_main(["--method", "policy", "--policy", "generalist", "--mask", "none", "--episodes", "1",
                          "--no-exact", "--quiet", "--out", str(tmp_path / "none.json")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1] == ("evaluate: mask: none differs from the mask the actor generalist was trained with (finished); "
                       "give mask finished (other methods under none in a run of their own)")
    assert not (tmp_path / "none.json").exists()


@pytest.mark.parametrize("name", ["lab_2r", "lab_3r"])
@pytest.mark.slow
def test_fine_tuning_the_generalist_reaches_the_optimum_on_the_lab(name, tmp_path):
    """train --init generalist (the finetune preset, here 10 s of wall time): a new run from the
    shipped weights whose kept actor schedules the scenario at its proven optimum. lab_3r's
    optimum is not one robots deciding in turn under the precedence mask can take (the
    generalist's sequential_logic: 1.042 at best), so this also checks that fine-tuning decides
    with claims alone (decision_order sequential) and is taught the GA's plan."""
    run = tmp_path / "run"
    assert train_main(["--scenario", str(SCENARIOS / f"{name}.xml"), "--init", "generalist", "--seed", "0",
                       "--set", "max_wall_seconds=10", "--out", str(run)]) == 0
    settings = trained_with(run)
    assert settings == preset_with("finetune", "max_wall_seconds=10") and settings["init_actor"] == "generalist"
    history = json.loads((run / "history.json").read_text())
    assert history["evaluations"] and history["evaluations"][-1]["wall_time"] >= 10.0
    shot = zero_shot(load_policy(run / "actor.pt"), load_scenario(SCENARIOS / f"{name}.xml"), "finished")
    assert shot["makespan"] == pytest.approx(optimum(name), abs=1e-6)


@pytest.mark.slow
def test_train_without_a_preset_fine_tunes_the_generalist(tmp_path):
    """train's default on the embedded backend is the finetune preset from the shipped generalist
    (a set actor that acts under the finished mask); --init none keeps the tuned preset's MLP actor."""
    run = tmp_path / "default"
    assert train_main(["--scenario", str(SCENARIOS / "lab_4r.xml"), "--set", "max_wall_seconds=3",
                       "--out", str(run)]) == 0
    settings = trained_with(run)
    assert settings == preset_with("finetune", "max_wall_seconds=3") and settings["init_actor"] == "generalist"
    assert isinstance(load_policy(run / "actor.pt"), SetActorPolicy)
    assert load_policy(run / "actor.pt").action_mask == "finished"
    fresh = tmp_path / "fresh"
    assert train_main(["--scenario", str(SCENARIOS / "lab_2r.xml"), "--init", "none", "--set", "total_env_steps=400",
                       "--out", str(fresh)]) == 0
    assert trained_with(fresh) == preset_with("tuned", "total_env_steps=400")
    assert not isinstance(load_policy(fresh / "actor.pt"), SetActorPolicy)


def test_bad_sizes_and_policies_end_the_commands_with_one_line(tmp_path, capsys):
    from marl_mrta.apps.bench_generalise import main as bench_main
    from marl_mrta.apps.train_generalist import main as generalist_main
    for sizes, message in [(["--robots", "5", "3"], "--robots: 5 3 is not a range within 2..16"),
                           (["--tasks", "2", "8"], "--tasks: 2 8 is not a range within 4..32")]:
        assert generalist_main(["--out", str(tmp_path / "g")] + sizes) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and message in err, err
    (tmp_path / "junk.pt").write_text("not an actor")
    assert bench_main(["--policy", str(tmp_path / "junk.pt"), "--out", str(tmp_path), "--scenarios", "1"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "junk.pt: not a readable actor file" in err, err
    assert not (tmp_path / "bench_generalise.json").exists()
    floor = tmp_path / "no_floor.yaml"
    for command in (bench_main, generalist_main):
        assert command(["--out", str(tmp_path / "f"), "--scenarios", "1", "--layout", str(floor)]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and f"layout: {floor}: cannot read" in err, err
