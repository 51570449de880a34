"""Every MAPPO setting in one dataclass, loaded strictly from config/mappo/*.yaml.

Names follow the paper and CleanRL (gamma, gae_lambda, clip_coef, ...). A preset file sets
any subset of the fields; a key that is not a field, or a value of the wrong type or out of
range, is a ConfigError whose message is one line naming the file, the key and the problem.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Dict, Optional, Tuple, Union

from marl_mrta.common.config import ConfigError, ConfigSection, read_yaml
from marl_mrta.common.paths import package_root
from marl_mrta.env.observation import TURN_ORDERS
from marl_mrta.env.settings import DECISION_MODES, MASK_MODES
from marl_mrta.model.reward import check_reward_overrides

# How the robots of a step decide (claims.py). Here, so that reading settings needs no torch
# (launch/train.launch derives the task managers' mask from a preset under roslaunch's Python).
DECISION_ORDERS = ("simultaneous", "sequential", "sequential_logic")
#: The actor's network: an MLP on the scenario-sized row (the paper's), or attention over the
#: robots and tasks as sets (mappo/set_networks.py), which acts on scenarios of any size.
ACTORS = ("mlp", "set")
#: Planners whose schedule a run may start its self-imitation with (evaluation/training.py).
TEACHERS = ("none", "ga", "reference")


def preset_dir() -> Path:
    """Directory of the shipped presets (`--preset tuned` means config/mappo/tuned.yaml)."""
    return package_root() / "config" / "mappo"


def setting(default: Any, doc: str, low: Optional[float] = None, high: Optional[float] = None,
            choices: Optional[Tuple[str, ...]] = None, low_open: bool = False):
    """A dataclass field with its one-line doc and its allowed range (inclusive unless low_open)."""
    metadata = {"doc": doc, "low": low, "high": high, "choices": choices, "low_open": low_open}
    if isinstance(default, dict):
        return field(default_factory=lambda: dict(default), metadata=metadata)
    return field(default=default, metadata=metadata)


@dataclass(frozen=True)
class MappoConfig:
    """MAPPO settings. Defaults are the paper's (Table 7, no action masks, its reward); the
    `tuned` preset changes what docs/guide/training.md measures."""

    # Data collection
    n_envs: int = setting(8, "environment instances stepped together (the paper's 8 threads)", low=1)
    total_env_steps: int = setting(70_000, "training budget in decision steps summed over all environments", low=1)
    max_wall_seconds: float = setting(0.0, "also stop once training (with its evaluations) has taken this many seconds "
                                      "of wall time, then evaluate once more (0 = no limit)", low=0.0)
    batch_size: int = setting(1000, "decision steps collected per update, over all environments", low=1)
    minibatch_size: int = setting(256, "decision steps per minibatch (rounded to whole chunks)", low=1)
    chunk_length: int = setting(25, "GRU training sequence length in decision steps; divides batch_size / n_envs", low=1)

    # Environment the run trains on (evaluation should use the same; both are kept in actor.pt)
    action_mask: str = setting("none", "environment action masks: none (the paper) | finished | logic",
                               choices=MASK_MODES)
    decision_order: str = setting("simultaneous", "robots choose at once (the paper) | sequential: in index order, "
                                  "each seeing and unable to take the tasks claimed before it | sequential_logic: "
                                  "also only tasks whose predecessors are finished or claimed (mappo/claims.py)",
                                  choices=DECISION_ORDERS)
    turn_order: str = setting("index", "who chooses first when deciding in sequence: index (robot 0) | nearest_ready: "
                              "the robot with the shortest leg to a ready task (actor: set; env/observation.py)",
                              choices=TURN_ORDERS)
    decision_mode: str = setting("synchronous", "the decision process trained in: synchronous (the paper's steps) | "
                                 "event: a robot decides when it comes free (env/event_env.py); train --decision-mode",
                                 choices=DECISION_MODES)
    noise_profile: str = setting("ideal", "embedded executor noise profile, a name in config/noise_profiles.yaml")
    hold_successors: bool = setting(False, "train under the step rules' hold (real.launch's default): a robot early at "
                                    "a successor waits for its predecessors instead of doing it out of order, so the "
                                    "actor may send it ahead (model/rules.py; the ros backend's managers must agree)")
    reward_overrides: Dict[str, Dict[str, float]] = setting(
        {}, "reward values replaced for training, as in a scenario's <reward>: {section: {key: value}} over config/reward.yaml")
    match_time_costs: bool = setting(False, "set each scenario's nav.slope so that a second of driving costs what a "
                                     "second of waiting does (w_time·slope/t_avg = w_idle·|idle.per_second|): the "
                                     "team's return then falls with the makespan whatever the scenario's t_avg")

    # Returns and advantages
    gamma: float = setting(0.98, "discount factor γ: per decision step (synchronous), per discount_seconds of elapsed "
                           "time (event mode: γ^(Δt / discount_seconds) over a transition of Δt)", low=0.0, high=1.0)
    discount_seconds: float = setting(10.0, "event mode: the elapsed time over which γ discounts once (about one step "
                                      "of the paper's lab)", low=0.0, low_open=True)
    gae_lambda: float = setting(0.95, "GAE λ (not given by the paper; the usual value)", low=0.0, high=1.0)
    team_reward: bool = setting(True, "train every robot on the mean of all robots' rewards (the paper's team reward) instead of its own")
    own_reward_share: float = setting(0.0, "with team_reward: share of a robot's own reward beside the team mean "
                                      "(0 = the paper's team reward)", low=0.0, high=1.0)
    reward_scale: float = setting(1.0, "rewards are multiplied by this before returns are computed", low=0.0, low_open=True)

    # PPO update
    epochs: int = setting(10, "passes over each batch", low=1)
    clip_coef: float = setting(0.2, "PPO surrogate clipping ε", low=0.0, low_open=True)
    value_clip_coef: float = setting(0.2, "clipping of the value change per update (0 = no value clipping)", low=0.0)
    entropy_coef: float = setting(0.01, "entropy bonus c_e", low=0.0)
    value_coef: float = setting(5.0, "value loss weight c_v", low=0.0)
    max_grad_norm: float = setting(10.0, "global gradient-norm clip of actor and critic (each)", low=0.0, low_open=True)
    learning_rate: float = setting(1e-5, "Adam step size of actor and critic", low=0.0, low_open=True)
    lr_decay: float = setting(0.95, "learning rate multiplied by this every lr_decay_steps decision steps", low=0.0, high=1.0, low_open=True)
    lr_decay_steps: int = setting(10_000, "decision steps between learning-rate decays", low=1)
    adam_eps: float = setting(1e-5, "Adam ε", low=0.0, low_open=True)
    normalize_advantages: bool = setting(True, "standardise advantages per minibatch")
    value_norm: bool = setting(True, "learn the critic on running-normalised returns (ValueNorm)")
    critic_warmup_updates: int = setting(0, "updates at the start of a run that train the critic alone (a run "
                                         "starting from a trained actor, train --init, first learns its values)", low=0)
    self_imitation_epochs: int = setting(0, "when a sampled training episode (complete, logic-consistent) is shorter than "
                                         "every greedy evaluation so far, the actor imitates it for at most this many "
                                         "epochs, until its greedy choice takes every action of it (mappo/imitation.py "
                                         "SelfImitation; actor: set, one embedded scenario; 0 = off)", low=0)
    self_imitation_lr: float = setting(1e-3, "Adam step size of that imitation", low=0.0, low_open=True)
    teacher: str = setting("none", "a fresh run first offers this planner's schedule to self-imitation, as if sampled: "
                           "none | ga (the genetic algorithm of config/task_baselines.yaml) | reference (evaluate's "
                           "best known plan, A* or CP-SAT, with the GA's plan among its candidates, so never longer); "
                           "the planning time counts as training wall time", choices=TEACHERS)
    teacher_seconds: float = setting(0.0, "teacher reference: its solvers held to about this many seconds in all "
                                     "(half the A*'s wall-time limit, half shared by the CP-SAT models in deterministic "
                                     "time; BaselineSettings.within); 0 = config/task_baselines.yaml's budgets", low=0.0)
    train_threads: int = setting(1, "torch CPU threads of each PPO update (collection and evaluation stay on one); "
                                 "a run repeats bit for bit for a given count, not across counts; 2 on two cores "
                                 "makes an update of site_8r or site_16r 1.4-1.6 x faster", low=1)
    target_kl: float = setting(0.0, "stop the epochs of an update early when approx_kl exceeds this (0 = never)", low=0.0)

    # Networks
    hidden_size: int = setting(64, "width of the actor's and critic's hidden layers and of the GRU", low=1)
    critic_layers: int = setting(2, "hidden layers of the critic MLP", low=1)
    append_agent_id: bool = setting(True, "append a one-hot robot index to each robot's observation (mlp actor)")
    actor: str = setting("mlp", "actor network: mlp on the scenario-sized observation (the paper's) | set: attention "
                         "over robots and tasks, for scenarios of any size (mappo/set_networks.py)", choices=ACTORS)
    set_heads: int = setting(4, "set actor and critic: attention heads (divides hidden_size)", low=1)
    set_layers: int = setting(2, "set actor and critic: attention blocks", low=1)
    init_actor: str = setting("", "the actor a fresh run starts from: a set actor's file (fine-tuning; train --init "
                              "overrides); empty: new weights")

    # Bookkeeping
    checkpoint_every: int = setting(10, "updates between checkpoints (one is also written at exit)", low=1)
    eval_every: int = setting(5, "updates between greedy evaluations (0 = only at the end)", low=0)
    eval_episodes: int = setting(8, "episodes per greedy evaluation", low=1)
    keep_best: bool = setting(False, "actor.pt holds the actor of the best greedy evaluation so far (shortest mean "
                              "makespan of complete, logic-consistent episodes) instead of the last one")
    log_every: int = setting(1, "updates between progress lines", low=1)

    @property
    def rollout_length(self) -> int:
        """Decision steps each environment contributes to one batch."""
        return self.batch_size // self.n_envs

    @property
    def n_updates(self) -> int:
        """Updates in the whole budget (the last batch is completed, never cut)."""
        return max(1, math.ceil(self.total_env_steps / self.batch_size))

    @property
    def n_minibatches(self) -> int:
        """Minibatches per epoch: batch_size / minibatch_size rounded, at most one per chunk."""
        chunks = self.batch_size // self.chunk_length
        return max(1, min(chunks, round(self.batch_size / self.minibatch_size)))


def _read_field(settings: ConfigSection, f: dataclasses.Field) -> Any:
    """One setting read through the strict reader by the field's type, choices and range."""
    kind = f.type if isinstance(f.type, str) else getattr(f.type, "__name__", str(f.type))
    meta = f.metadata
    low, high = meta["low"], meta["high"]
    minimum, above = (None, low) if meta["low_open"] else (low, None)
    if kind.startswith("Dict"):
        return check_reward_overrides(settings.raw(f.name), settings.location(f.name))
    if kind == "bool":
        return settings.boolean(f.name)
    if kind == "int":
        return settings.integer(f.name, minimum=minimum, maximum=high)
    if kind == "float":
        return settings.number(f.name, minimum=minimum, maximum=high, above=above)
    if meta["choices"] is not None:
        return settings.choice(f.name, meta["choices"])
    return settings.string(f.name)


def _check_consistency(source: str, config: MappoConfig) -> None:
    """Relations between settings; each failure names the key that has to change."""
    if config.batch_size % config.n_envs:
        raise ConfigError(f"{source}: batch_size: {config.batch_size} is not divisible by n_envs = {config.n_envs}")
    if config.decision_order == "sequential_logic" and config.action_mask != "finished":
        raise ConfigError(f"{source}: action_mask: decision_order sequential_logic reads which tasks are finished "
                          f"from the environment's mask, so it needs action_mask finished, not {config.action_mask}")
    if config.turn_order != "index" and (config.actor != "set" or config.decision_order == "simultaneous"):
        raise ConfigError(f"{source}: turn_order: {config.turn_order} orders a sequential decision of the set actor; "
                          f"this run has actor {config.actor}, decision_order {config.decision_order} (use index)")
    if config.actor == "set" and config.append_agent_id:
        raise ConfigError(f"{source}: append_agent_id: the set actor tells robots apart by their tokens, not by an "
                          "index; set it false")
    if config.init_actor and config.actor != "set":
        raise ConfigError(f"{source}: init_actor: a run starts from a set actor's weights only with actor: set")
    if config.self_imitation_epochs and config.actor != "set":
        raise ConfigError(f"{source}: self_imitation_epochs: the imitation replays episodes as the set actor's rows; "
                          f"this run has actor {config.actor} (use 0)")
    if config.teacher != "none" and not config.self_imitation_epochs:
        raise ConfigError(f"{source}: teacher: {config.teacher}'s schedule is taught by self-imitation; "
                          "set self_imitation_epochs > 0 (or teacher none)")
    if config.actor == "set" and config.hidden_size % config.set_heads:
        raise ConfigError(f"{source}: set_heads: {config.set_heads} does not divide hidden_size = {config.hidden_size}")
    if config.rollout_length % config.chunk_length:
        raise ConfigError(f"{source}: chunk_length: {config.chunk_length} does not divide batch_size / n_envs = "
                          f"{config.rollout_length}")


def config_from_dict(values: Any, source: str = "<settings>") -> MappoConfig:
    """A MappoConfig from a mapping of field names to values, checked key by key."""
    settings = ConfigSection(values, source, noun="setting")
    fields = {f.name: f for f in dataclasses.fields(MappoConfig)}
    checked = {name: _read_field(settings, f) for name, f in fields.items() if settings.has(name)}
    settings.check_all_used(known=list(fields))
    config = MappoConfig(**checked)
    _check_consistency(source, config)
    return config


def load_config(path: Union[str, Path], overrides: Optional[Dict[str, Any]] = None) -> MappoConfig:
    """The settings in a YAML file (absent keys keep their defaults), then `overrides` on top."""
    settings = read_yaml(path, noun="setting")
    values = dict(settings.data)
    values.update(overrides or {})
    return config_from_dict(values, str(path))


def resolve_preset(preset: str) -> Path:
    """`tuned` / `paper` / `sequential` / `set` name a shipped preset; anything else is a path to a YAML file."""
    candidate = preset_dir() / f"{preset}.yaml"
    if "/" not in preset and not preset.endswith((".yaml", ".yml")) and candidate.exists():
        return candidate
    return Path(preset)


def config_to_dict(config: MappoConfig) -> Dict[str, Any]:
    """Plain mapping of every setting (stored in checkpoints and actor files)."""
    return dataclasses.asdict(config)
