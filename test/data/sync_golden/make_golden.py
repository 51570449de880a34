"""Writes the synchronous-mode golden episodes: digests of the episode documents
(EpisodeRecord.to_dict) and of every step's outputs of the paper's decision process, for the labs and site_8r under
random, GA, auction and exact policies, both noise profiles and both hold settings.
test/python/test_sync_golden.py checks that the synchronous mode still gives them to the bit.

    python3 test/data/sync_golden/make_golden.py OUT.json
"""
import hashlib
import json
import sys

import numpy as np

from marl_mrta.baselines.auction import solve_auction
from marl_mrta.baselines.ga import solve_ga
from marl_mrta.baselines.random_policy import RandomPolicy
from marl_mrta.baselines.reference import scheduling_instance, solve_reference
from marl_mrta.env.factory import make_env
from marl_mrta.evaluation.policies import PlanPolicy
from marl_mrta.common.paths import package_root

CASES = [(name, profile, hold) for name in ("lab_2r", "lab_3r", "lab_4r", "site_8r")
         for profile in ("ideal", "measured_tb3") for hold in (False, True)]
EPISODES = 2


def digest(output) -> str:
    h = hashlib.sha256()
    for array in (output.obs, output.state, output.rewards, output.action_mask,
                  *[output.reward_components[k] for k in sorted(output.reward_components)]):
        h.update(np.ascontiguousarray(array).tobytes())
    h.update(repr((output.done, output.truncated, output.info.step, output.info.elapsed)).encode())
    return h.hexdigest()


def run(env, policy, seed):
    output = env.reset(seed=seed)
    policy.begin_episode(output, 0)
    steps = [digest(output)]
    while not (output.done or output.truncated):
        output = env.step(policy.act(output))
        steps.append(digest(output))
    document = output.info.episode.to_dict()
    return {"makespan": document["makespan"], "steps": len(steps) - 1,
            "document_sha256": hashlib.sha256(json.dumps(document, sort_keys=True).encode()).hexdigest(),
            "outputs_sha256": hashlib.sha256("".join(steps).encode()).hexdigest()}


def main(out):
    golden = {}
    for name, profile, hold in CASES:
        scenario = package_root() / "scenarios" / f"{name}.xml"
        env = make_env(scenario, profile=profile, hold_successors=hold, seed=0)
        instance = scheduling_instance(env.scenario, env.settings.min_step, env.settings.goal_timeout,
                                       hold_successors=hold)
        plans = {"ga": solve_ga(instance, seed=0), "auction": solve_auction(instance)}
        if name != "site_8r":
            plans["exact"] = solve_reference(instance).plan
        policies = {"random": RandomPolicy(env.n_agents, env.n_tasks, seed=0)}
        policies.update({method: PlanPolicy(plan, env.n_agents, env.n_tasks) for method, plan in plans.items()})
        for method, policy in policies.items():
            key = f"{name}/{profile}/hold={hold}/{method}"
            golden[key] = [run(env, policy, seed) for seed in range(EPISODES)]
            print(key, file=sys.stderr)
    with open(out, "w") as f:
        json.dump(golden, f, indent=1, sort_keys=True)


if __name__ == "__main__":
    main(sys.argv[1])
