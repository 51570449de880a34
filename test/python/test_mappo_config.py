"""Strict MAPPO settings: the shipped presets load, every bad file gives one line naming
file, key and problem."""
import pytest

from marl_mrta.mappo.config import preset_dir, ConfigError, MappoConfig, load_config, resolve_preset


def test_shipped_presets_load_and_paper_matches_table_7():
    paper = load_config(resolve_preset("paper"))
    assert (paper.gamma, paper.gae_lambda, paper.clip_coef, paper.entropy_coef, paper.value_coef) == (0.98, 0.95, 0.2, 0.01, 5.0)
    assert (paper.learning_rate, paper.lr_decay, paper.lr_decay_steps) == (1e-5, 0.95, 10_000)
    assert (paper.batch_size, paper.minibatch_size, paper.epochs) == (1000, 256, 10)
    assert (paper.total_env_steps, paper.n_envs) == (70_000, 8)
    assert paper.n_minibatches == 4 and paper.rollout_length == 125
    tuned = load_config(resolve_preset("tuned"))
    assert tuned != paper
    assert resolve_preset("tuned") == preset_dir() / "tuned.yaml"


BAD_FILES = [
    ("gama: 0.9\n", "gama: unknown setting"),
    ("gamma: 1.5\n", "gamma: must be <= 1.0, got 1.5"),
    ("gamma: fast\n", "gamma: expected a number, got 'fast'"),
    ("epochs: 2.5\n", "epochs: expected an integer, got 2.5"),
    ("epochs: 0\n", "epochs: must be >= 1, got 0"),
    ("learning_rate: 0\n", "learning_rate: must be > 0.0, got 0.0"),
    ("value_norm: maybe\n", "value_norm: expected true or false, got 'maybe'"),
    ("n_envs: 3\nbatch_size: 100\n", "batch_size: 100 is not divisible by n_envs = 3"),
    ("n_envs: 4\nbatch_size: 100\nchunk_length: 7\n", "chunk_length: 7 does not divide batch_size / n_envs = 25"),
    ("reward_overrides:\n  nav: {bestest: 0}\n", "reward_overrides: nav.bestest: unknown key"),
    ("reward_overrides:\n  navigation: {best: 0}\n", "reward_overrides: navigation: unknown reward section"),
    ("reward_overrides:\n  nav: {best: high}\n", "reward_overrides: nav.best: expected a finite number, got 'high'"),
    ("action_mask: some\n", "action_mask: 'some' is not one of none, finished, logic"),
    ("- gamma\n", "expected a mapping of setting names to values, got list"),
    ("gamma: [0.9\n", "line 2"),
]


@pytest.mark.parametrize("text, problem", BAD_FILES)
def test_bad_settings_give_one_line_naming_file_and_key(tmp_path, text, problem):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(ConfigError) as error:
        load_config(path)
    message = str(error.value)
    assert "\n" not in message
    assert message.startswith(f"{path}:")
    assert problem in message


def test_missing_file_is_one_line(tmp_path):
    with pytest.raises(ConfigError, match=r"nope\.yaml: cannot read"):
        load_config(tmp_path / "nope.yaml")


def test_empty_file_keeps_defaults(tmp_path):
    path = tmp_path / "empty.yaml"
    path.write_text("# nothing set\n")
    assert load_config(path) == MappoConfig()
