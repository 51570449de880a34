"""env.api.StepOutput <-> marl_mrta/TaskEnvOutput, the one place the wire format is defined.

`info` travels as JSON (`info_json`); its episode record (`info["episode"]`, an EpisodeRecord)
is rebuilt on the receiving side, so a client sees what the environment returned.
"""
from __future__ import annotations

import dataclasses
import json
import math
from typing import Any, Dict

import numpy as np

from marl_mrta.msg import TaskEnvOutput

from ..env.api import REWARD_COMPONENTS, StepOutput
from ..tasks.schedule import EpisodeRecord, ScheduleEntry


def _jsonable(value: Any) -> Any:
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: _jsonable(getattr(value, f.name)) for f in dataclasses.fields(value)}
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return _jsonable(value.tolist())
    if isinstance(value, (np.floating, np.integer, np.bool_)):
        return _jsonable(value.item())
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    if isinstance(value, (str, int, float, bool)) or value is None:
        return value
    return str(value)


def record_from_dict(data: Dict[str, Any]) -> EpisodeRecord:
    """The EpisodeRecord whose fields `data` holds (as _jsonable wrote them)."""
    names = {f.name for f in dataclasses.fields(EpisodeRecord)}
    fields = {k: v for k, v in data.items() if k in names}
    fields["entries"] = [ScheduleEntry(**entry) for entry in data.get("entries", [])]
    return EpisodeRecord(**fields)


def to_message(output: StepOutput) -> TaskEnvOutput:
    n_agents, obs_dim = output.obs.shape
    msg = TaskEnvOutput(n_agents=n_agents, obs_dim=obs_dim, n_actions=output.action_mask.shape[1])
    msg.obs = output.obs.astype(np.float32).ravel().tolist()
    msg.state = output.state.astype(np.float32).tolist()
    msg.rewards = output.rewards.astype(np.float32).tolist()
    for name in REWARD_COMPONENTS:
        setattr(msg, "reward_" + name, output.reward_components[name].astype(np.float32).tolist())
    msg.done, msg.truncated = bool(output.done), bool(output.truncated)
    msg.action_mask = output.action_mask.astype(np.uint8).ravel().tobytes()
    msg.info_json = json.dumps(_jsonable(output.info))
    return msg


def from_message(msg: TaskEnvOutput) -> StepOutput:
    n, d, a = msg.n_agents, msg.obs_dim, msg.n_actions
    # rospy gives uint8[] as bytes (a list of ints when the message was built by hand).
    mask = np.frombuffer(bytes(msg.action_mask), dtype=np.uint8).reshape(n, a).astype(bool)
    info = json.loads(msg.info_json) if msg.info_json else {}
    if isinstance(info.get("episode"), dict):
        info["episode"] = record_from_dict(info["episode"])
    return StepOutput(
        obs=np.asarray(msg.obs, dtype=np.float32).reshape(n, d),
        state=np.asarray(msg.state, dtype=np.float32),
        rewards=np.asarray(msg.rewards, dtype=np.float32),
        reward_components={name: np.asarray(getattr(msg, "reward_" + name), dtype=np.float32)
                           for name in REWARD_COMPONENTS},
        done=bool(msg.done), truncated=bool(msg.truncated), action_mask=mask, info=info)
