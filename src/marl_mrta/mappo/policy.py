"""The trained actor on its own: save it, load it, act with it (evaluation, per-robot nodes).

An actor file holds the actor's weights and everything needed to rebuild it (dimensions and
the settings that shape its input), nothing of the critic or optimisers, so that execution
stays decentralised: each robot needs only this file and its own observation.
"""
from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Callable, Dict, Optional, Sequence, Tuple, Union

import numpy as np
import torch

from marl_mrta.common.actor_settings import actor_path
from marl_mrta.common.paths import package_root
from marl_mrta.env.observation import ORIENTATIONS
from marl_mrta.mappo.claims import (ClaimRules, actor_input_size, is_sequential, turns_from_rows, with_claims,
                                    with_set_claims)
from marl_mrta.mappo.networks import Actor, masked_logits, sample_actions
from marl_mrta.mappo.set_networks import SetActor
from marl_mrta.mappo.set_view import SetView
from marl_mrta.model.scenario import Scenario

#: The MLP actor of one scenario's sizes.
ACTOR_FORMAT = "marl_mrta.mappo.actor/1"
#: The set actor (mappo/set_networks.py): any scenario; the file names no sizes.
SET_ACTOR_FORMAT = "marl_mrta.mappo.actor/2"


#: Actor files shipped with the package, by the name that stands for them wherever an actor file
#: is taken (evaluate --policy, execute.launch policy:=, train --init): policies/<name>.pt.

#: act_team's hook on an in-turn decision: (turn, robot, logits (n_actions,), mask (n_actions,),
#: claimed (n_tasks,) bool: by the turns before) -> the action to take at that turn, or None for
#: the actor's own choice.
TurnPick = Callable[[int, int, torch.Tensor, torch.Tensor, torch.Tensor], Optional[int]]


class PolicyFileError(ValueError):
    """An unreadable or foreign actor file; str(error) is one line naming the file."""


def actor_file_path(policy: Union[str, Path]) -> Path:
    """The file an actor reference names: a shipped policy's name (SHIPPED_POLICIES), or a path."""
    return actor_path(policy, package_root())


def atomic_torch_save(obj: Any, path: Union[str, Path]) -> None:
    """Write via a temporary file and os.replace, so a kill never leaves a half-written file."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "wb") as handle:
        torch.save(obj, handle)
        handle.flush()
        os.fsync(handle.fileno())
    os.replace(tmp, path)


def save_actor(path: Union[str, Path], actor: Actor, *, obs_dim: int, n_agents: int,
               append_agent_id: bool, settings: Dict[str, Any], scenario: str,
               predecessors: Sequence[Sequence[int]]) -> None:
    """Write the standalone actor file (atomically)."""
    atomic_torch_save({
        "format": ACTOR_FORMAT,
        "weights": actor.state_dict(),
        "obs_dim": obs_dim,
        "n_agents": n_agents,
        "n_actions": actor.n_actions,
        "hidden_size": actor.hidden_size,
        "append_agent_id": append_agent_id,
        "settings": settings,
        "scenario": scenario,
        "predecessors": [[int(p) for p in preds] for preds in predecessors],
    }, path)


def save_set_actor(path: Union[str, Path], actor: SetActor, *, settings: Dict[str, Any], trained_on: str) -> None:
    """Write a set actor's file (atomically): weights, network shape, settings, what it was trained on."""
    atomic_torch_save({
        "format": SET_ACTOR_FORMAT,
        "weights": actor.state_dict(),
        "hidden_size": actor.hidden_size,
        "heads": actor.heads,
        "layers": actor.layers,
        "settings": settings,
        "trained_on": trained_on,
    }, path)


class ActorPolicy:
    """Acts for any subset of robots from their own observations; carries no global state."""

    def __init__(self, actor: Actor, *, obs_dim: int, n_agents: int, append_agent_id: bool,
                 settings: Dict[str, Any], seed: int = 0, source: str = "",
                 predecessors: Optional[Sequence[Sequence[int]]] = None):
        self.actor = actor.eval()
        self.settings = dict(settings)
        #: The environment's action-mask mode during training; evaluate with the same one.
        self.action_mask: str = self.settings.get("action_mask", "none")
        #: Sequential: robots decide in index order, each seeing the tasks claimed before it (mappo/claims.py).
        self.decision_order: str = self.settings.get("decision_order", "simultaneous")
        self.sequential: bool = is_sequential(self.decision_order)
        #: In sequence: who chooses first (env/observation.py, TURN_ORDERS; the set actor's only).
        self.turn_order: str = self.settings.get("turn_order", "index")
        #: Per task, its predecessors (the scenario the actor was trained on).
        self.predecessors = [list(p) for p in predecessors] if predecessors is not None \
            else [[] for _ in range(actor.n_actions - 1)]
        self.claim_rules = ClaimRules(self.decision_order, self.predecessors)
        self.obs_dim = obs_dim
        self.n_agents = n_agents
        self.n_actions = len(self.predecessors) + 1
        self.append_agent_id = append_agent_id
        self.source = source
        self.generator = torch.Generator().manual_seed(seed)

    def initial_hidden(self, n_agents: int) -> torch.Tensor:
        """Recurrent state for the first decision of an episode, one row per robot."""
        return self.actor.initial_hidden(n_agents)

    def for_scenario(self, scenario: Scenario) -> "ActorPolicy":
        """This policy acting on `scenario` (an MLP actor knows only the scenario it was trained on)."""
        return self

    #: How many orientations of the floor the actor can be shown (turned()): an MLP actor's
    #: inputs are positions on its own scenario's map, so one.
    orientations = 1

    def turned(self, orientation: int) -> "ActorPolicy":
        """This policy shown the floor turned (env/observation.py, ORIENTATIONS; 0: as it is)."""
        if orientation != 0:
            raise ValueError(f"{self.source}: an MLP actor sees its scenario's floor as it is (orientation 0 only)")
        return self

    @torch.no_grad()
    def act_team(self, obs: np.ndarray, action_mask: Optional[np.ndarray], hidden: torch.Tensor,
                 deterministic: bool = True, pick: Optional[TurnPick] = None,
                 deciding: Optional[np.ndarray] = None, claimed: Optional[torch.Tensor] = None
                 ) -> Tuple[np.ndarray, torch.Tensor]:
        """One decision of the whole team (robots 0..n-1), in the order the actor was trained
        with: at once, or one after another with the tasks claimed so far (mappo/claims.py).
        pick(turn, robot, logits, mask, claimed) (sequential actors only) sees each turn's distribution and may
        return the action instead of the actor's own choice (None: the actor's). Event mode:
        `deciding` (n,) bool names the robots that decide (the others' actions are None and their
        recurrent state stays as it was), `claimed` (n_tasks,) long the tasks of busy robots
        (claims.busy_claims), claimed before the first turn."""
        if not self.sequential:
            if pick is not None:
                raise ValueError(f"{self.source}: the robots of this actor decide at once, not in turn")
            actions, new_hidden = self.act(obs, action_mask, hidden, deterministic)
            if deciding is not None:
                free = torch.as_tensor(np.asarray(deciding, dtype=bool))
                actions = np.where(np.asarray(deciding, dtype=bool), actions, self.n_actions - 1)
                new_hidden = torch.where(free.unsqueeze(-1), new_hidden, hidden)
            return actions, new_hidden
        rows = self.encode(np.asarray(obs, dtype=np.float32), range(len(obs)))   # once for every turn
        env_mask = torch.ones(len(rows), self.n_actions, dtype=torch.bool) if action_mask is None \
            else torch.as_tensor(np.asarray(action_mask, dtype=bool))
        hidden_rows = [hidden[i:i + 1] for i in range(len(rows))]
        turn = iter(range(len(rows)))
        none = torch.tensor(self.n_actions - 1)

        def decide(robot: torch.Tensor, claimed: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
            i = int(robot)
            if deciding is not None and not deciding[i]:
                return none
            logits, mask_t, hidden_rows[i] = self._logits_of_rows(rows[i:i + 1], mask[None], hidden[i:i + 1], [i],
                                                                  claimed.numpy()[None])
            chosen = None if pick is None else pick(next(turn), i, logits[0], mask_t[0], claimed > 0)
            return self._pick(logits, mask_t, deterministic)[0] if chosen is None else torch.tensor(chosen)

        actions = self.claim_rules.decide_in_turn(env_mask, decide, self.turns_of_rows(rows), claimed)
        return actions.numpy().astype(np.int64), torch.cat(hidden_rows, 0)

    def turns(self, obs: np.ndarray) -> Optional[torch.Tensor]:
        """The robots in the order they choose, from every robot's observation row (None: index order)."""
        return self.turns_of_rows(self.encode(np.asarray(obs, dtype=np.float32), range(len(obs))))

    def turns_of_rows(self, rows: torch.Tensor) -> Optional[torch.Tensor]:
        """turns() of the encoded rows of every robot."""
        return None

    @torch.no_grad()
    def act(self, obs: np.ndarray, action_mask: Optional[np.ndarray], hidden: torch.Tensor,
            deterministic: bool = True, agent_ids: Optional[Sequence[int]] = None,
            claimed: Optional[np.ndarray] = None) -> Tuple[np.ndarray, torch.Tensor]:
        """One decision. obs (k, obs_dim) for robots agent_ids (default 0..k-1), action_mask
        (k, n_actions) bool or None, hidden (k, H) from initial_hidden() or the last call;
        claimed (k, n_tasks) bool: the tasks claimed before each robot in this step (a
        sequential actor only; default none). Returns actions (k,) int64 (greedy when
        deterministic) and the new hidden state."""
        logits, mask_t, new_hidden = self.logits(obs, action_mask, hidden, agent_ids, claimed)
        return self._pick(logits, mask_t, deterministic).numpy().astype(np.int64), new_hidden

    def _pick(self, logits: torch.Tensor, mask_t: Optional[torch.Tensor], deterministic: bool) -> torch.Tensor:
        if deterministic:
            return masked_logits(logits, mask_t).argmax(-1)
        return sample_actions(logits, self.generator)

    @torch.no_grad()
    def logits(self, obs: np.ndarray, action_mask: Optional[np.ndarray], hidden: torch.Tensor,
               agent_ids: Optional[Sequence[int]] = None, claimed: Optional[np.ndarray] = None
               ) -> Tuple[torch.Tensor, Optional[torch.Tensor], torch.Tensor]:
        """The action distribution of one decision (arguments as act): masked logits (k, n_actions),
        the mask the robots choose under and the new hidden state."""
        obs = np.asarray(obs, dtype=np.float32)
        ids = list(range(len(obs))) if agent_ids is None else list(agent_ids)
        mask_t = None if action_mask is None else torch.as_tensor(np.asarray(action_mask, dtype=bool))
        return self._logits_of_rows(self.encode(obs, ids), mask_t, hidden, ids, claimed)

    def _logits_of_rows(self, rows: torch.Tensor, mask_t: Optional[torch.Tensor], hidden: torch.Tensor,
                        ids: Sequence[int], claimed: Optional[np.ndarray]
                        ) -> Tuple[torch.Tensor, Optional[torch.Tensor], torch.Tensor]:
        """logits() of encoded rows (encode)."""
        inputs, mask_t = self._inputs(rows, mask_t, ids, claimed)
        k = inputs.shape[0]
        out = self.actor(inputs.unsqueeze(0), hidden, torch.zeros(1, k, dtype=torch.bool),
                         None if mask_t is None else mask_t.unsqueeze(0))
        return out.logits[0], mask_t, out.hidden

    def encode(self, obs: np.ndarray, ids: Sequence[int]) -> torch.Tensor:
        """The rows the actor reads of observation rows (k, obs_dim) of robots `ids`, checked."""
        obs_t = torch.as_tensor(obs)
        if obs_t.ndim != 2 or obs_t.shape[1] != self.obs_dim:
            raise ValueError(f"{self.source}: observation shape {tuple(obs_t.shape)}, the actor expects (k, {self.obs_dim})")
        return obs_t

    def _claimed(self, claimed: Optional[np.ndarray], k: int, marks: bool = False) -> torch.Tensor:
        """The claimed tasks (k, n_tasks) of a sequential actor, checked (default: none): flags,
        or with `marks` the claimers (ClaimRules.decide_in_turn: k + 1 = robot k's, 0 = free)."""
        n_tasks = self.n_actions - 1
        kind = torch.long if marks else torch.bool
        claimed_t = torch.zeros(k, n_tasks, dtype=kind) if claimed is None \
            else torch.as_tensor(np.asarray(claimed, dtype=np.int64 if marks else bool))
        if claimed_t.shape != (k, n_tasks):
            raise ValueError(f"{self.source}: claimed shape {tuple(claimed_t.shape)}, the actor expects "
                             f"({k}, {n_tasks})")
        return claimed_t

    def _inputs(self, obs_t: torch.Tensor, mask_t: Optional[torch.Tensor], ids: Sequence[int],
                claimed: Optional[np.ndarray]) -> Tuple[torch.Tensor, Optional[torch.Tensor]]:
        """The actor's inputs and the mask it chooses under, from encoded rows of robots `ids`."""
        if self.sequential:
            claimed_t = self._claimed(claimed, obs_t.shape[0])
            obs_t = with_claims(obs_t, claimed_t)
            if mask_t is None:
                mask_t = torch.ones(obs_t.shape[0], self.n_actions, dtype=torch.bool)
            mask_t = self.claim_rules.mask(mask_t, claimed_t)
        if self.append_agent_id:
            if any(i < 0 or i >= self.n_agents for i in ids):
                raise ValueError(f"{self.source}: robot index out of range 0..{self.n_agents - 1}: {ids}")
            obs_t = torch.cat([obs_t, torch.eye(self.n_agents)[ids]], dim=-1)
        return obs_t, mask_t


class SetActorPolicy(ActorPolicy):
    """A set actor (mappo/set_networks.py) acting on one scenario: the robots' observation rows
    are read as sets (mappo/set_view.py) with the scenario's travel-time table. The same file
    acts on any scenario (for_scenario); unbound, it only carries the weights."""

    def __init__(self, actor: SetActor, *, settings: Dict[str, Any], seed: int = 0, source: str = "",
                 view: Optional[SetView] = None):
        self.view = view
        self.seed = seed
        scenario = view.scenario if view is not None else None
        predecessors = scenario.predecessors if scenario is not None else []
        super().__init__(actor, obs_dim=view.flat.obs_dim if view is not None else 0,
                         n_agents=scenario.n_robots if scenario is not None else 0, append_agent_id=False,
                         settings=settings, seed=seed, source=source, predecessors=predecessors)

    orientations = len(ORIENTATIONS)

    def for_scenario(self, scenario: Scenario) -> "SetActorPolicy":
        return self._seeing(SetView(scenario, self.turn_order))

    def turned(self, orientation: int) -> "SetActorPolicy":
        return self._seeing(self._bound_view().turned(orientation))

    def _seeing(self, view: SetView) -> "SetActorPolicy":
        """The same actor and settings acting through `view`."""
        return SetActorPolicy(self.actor, settings=self.settings, seed=self.seed, source=self.source, view=view)

    def _bound_view(self) -> SetView:
        if self.view is None:
            raise ValueError(f"{self.source}: a set actor acts on a scenario: bind it first (for_scenario)")
        return self.view

    def turns_of_rows(self, rows: torch.Tensor) -> Optional[torch.Tensor]:
        # The rows say who chose before only in a sequential decision (SetObservationEncoder).
        return turns_from_rows(rows, self.n_actions - 1) if self.sequential else None

    def encode(self, obs: np.ndarray, ids: Sequence[int]) -> torch.Tensor:
        view = self._bound_view()
        if any(i < 0 or i >= self.n_agents for i in ids):
            raise ValueError(f"{self.source}: robot index out of range 0..{self.n_agents - 1}: {list(ids)}")
        return torch.as_tensor(view.rows(obs, ids, self.sequential))

    def _inputs(self, rows: torch.Tensor, mask_t: Optional[torch.Tensor], ids: Sequence[int],
                claimed: Optional[np.ndarray]) -> Tuple[torch.Tensor, Optional[torch.Tensor]]:
        if mask_t is None:
            mask_t = torch.ones(rows.shape[0], self.n_actions, dtype=torch.bool)
        if self.sequential:
            claimed_t = self._claimed(claimed, rows.shape[0], marks=True)
            rows = with_set_claims(rows, claimed_t, self.claim_rules.precedence)
            mask_t = self.claim_rules.mask(mask_t, claimed_t > 0)
        return rows, mask_t


def read_actor_file(policy: Union[str, Path]) -> Tuple[Path, Dict[str, Any]]:
    """An actor file's path and its contents (either format); `policy` is a path or a shipped name."""
    if not str(policy).strip():   # Path("") is ".", a directory: the message would name neither
        raise PolicyFileError("policy: empty: give an actor file (a training run's actor.pt) or generalist")
    path = actor_file_path(policy)
    if path.is_dir():
        raise PolicyFileError(f"{path}: a directory, not an actor file (a training run's is its actor.pt)")
    try:
        data = torch.load(path, map_location="cpu", weights_only=True)
    except FileNotFoundError:
        raise PolicyFileError(f"{path}: no such file") from None
    except Exception as error:  # torch raises many types for a foreign or corrupt file
        raise PolicyFileError(f"{path}: not a readable actor file ({type(error).__name__})") from None
    if isinstance(data, dict) and "actor_file" in data:   # a training checkpoint embeds one
        data = data["actor_file"]
    if not isinstance(data, dict) or data.get("format") not in (ACTOR_FORMAT, SET_ACTOR_FORMAT):
        raise PolicyFileError(f"{path}: format: not a {ACTOR_FORMAT} or {SET_ACTOR_FORMAT} actor file")
    return path, data


def set_actor_from_file(path: Path, data: Dict[str, Any]) -> SetActor:
    """The set actor of a SET_ACTOR_FORMAT file's contents."""
    actor = SetActor(data["hidden_size"], data["heads"], data["layers"])
    try:
        actor.load_state_dict(data["weights"])
    except RuntimeError:
        raise PolicyFileError(f"{path}: weights: do not match the stored network shape") from None
    return actor


def load_policy(path: Union[str, Path], seed: int = 0, scenario: Optional[Scenario] = None) -> ActorPolicy:
    """The actor in an actor file (or in a full training checkpoint) ready to act; a set actor
    acts on `scenario` (unbound without one: for_scenario)."""
    path, data = read_actor_file(path)
    if data["format"] == SET_ACTOR_FORMAT:
        policy = SetActorPolicy(set_actor_from_file(path, data), settings=data["settings"], seed=seed, source=str(path))
        return policy.for_scenario(scenario) if scenario is not None else policy
    decision_order = dict(data.get("settings", {})).get("decision_order", "simultaneous")
    actor = Actor(actor_input_size(data["obs_dim"], data["n_actions"], data["n_agents"], data["append_agent_id"],
                                   decision_order), data["n_actions"], data["hidden_size"])
    try:
        actor.load_state_dict(data["weights"])
    except RuntimeError:
        raise PolicyFileError(f"{path}: weights: do not match the stored dimensions") from None
    return ActorPolicy(actor, obs_dim=data["obs_dim"], n_agents=data["n_agents"],
                       append_agent_id=data["append_agent_id"], settings=data["settings"], seed=seed,
                       source=str(path), predecessors=data.get("predecessors"))
