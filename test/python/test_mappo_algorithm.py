"""MAPPO algorithm pieces on hand-made tensors: GAE with a time-limit cut, PPO clipping and
entropy, ValueNorm, action masking, GRU reset at episode boundaries."""
import math

import pytest
import torch

from marl_mrta.mappo.buffer import RolloutBuffer, compute_gae
from marl_mrta.mappo.networks import Actor, log_prob_and_entropy, masked_logits, sample_actions
from marl_mrta.mappo.trainer import clipped_surrogate, clipped_value_loss, explained_variance
from marl_mrta.mappo.value_norm import ValueNorm

GAMMA, LAMBDA = 0.5, 0.5
# One robot, four steps: episode 1 = steps 0-1, cut by the time limit after step 1 (its final
# state is worth 10); episode 2 = steps 2-3, still running (the state after step 3 is worth 4).
REWARDS = [1.0, 2.0, 3.0, 4.0]
VALUES = [0.5, 1.0, 1.5, 2.0]
FINAL_VALUE, LAST_VALUE = 10.0, 4.0
# By hand, γλ = 0.25:
#   δ0 = 1 + 0.5·1.0 − 0.5 = 1.0     δ1 = 2 + 0.5·10 − 1.0 = 6.0  (bootstrap on the final state)
#   δ2 = 3 + 0.5·2.0 − 1.5 = 2.5     δ3 = 4 + 0.5·4.0 − 2.0 = 4.0
#   A3 = 4.0   A2 = 2.5 + 0.25·4.0 = 3.5   A1 = 6.0 (episode boundary)   A0 = 1.0 + 0.25·6.0 = 2.5
TRUNCATED_ADVANTAGES = [2.5, 6.0, 3.5, 4.0]
TRUNCATED_RETURNS = [3.0, 7.0, 5.0, 6.0]
# Same trajectory but step 1 *terminates*: δ1 = 2 − 1.0 = 1.0, A1 = 1.0, A0 = 1.0 + 0.25 = 1.25.
TERMINATED_ADVANTAGES = [1.25, 1.0, 3.5, 4.0]


def _col(values):
    return torch.tensor(values).unsqueeze(-1)


def test_gae_bootstraps_on_truncation_not_on_termination():
    next_values = _col([VALUES[1], FINAL_VALUE, VALUES[3], LAST_VALUE])
    ends = _col([False, True, False, False])
    truncated = compute_gae(_col(REWARDS), _col(VALUES), next_values, terminated=_col([False] * 4),
                            episode_end=ends, gamma=GAMMA, gae_lambda=LAMBDA)
    assert truncated.advantages.squeeze(-1).tolist() == pytest.approx(TRUNCATED_ADVANTAGES)
    assert truncated.returns.squeeze(-1).tolist() == pytest.approx(TRUNCATED_RETURNS)
    terminated = compute_gae(_col(REWARDS), _col(VALUES), next_values, terminated=ends,
                             episode_end=ends, gamma=GAMMA, gae_lambda=LAMBDA)
    assert terminated.advantages.squeeze(-1).tolist() == pytest.approx(TERMINATED_ADVANTAGES)


def test_buffer_returns_match_hand_computed_trajectory():
    buffer = RolloutBuffer(rollout_length=4, n_envs=1, n_agents=1, obs_dim=1, state_dim=1, n_actions=2, hidden_size=1)
    for t in range(4):
        buffer.insert(obs=torch.zeros(1, 1, 1), state=torch.zeros(1, 1), actions=torch.zeros(1, 1),
                      action_mask=torch.ones(1, 1, 2, dtype=torch.bool), log_probs=torch.zeros(1, 1),
                      values=torch.tensor([[VALUES[t]]]), rewards=torch.tensor([[REWARDS[t]]]),
                      episode_start=torch.tensor([t in (0, 2)]), terminated=torch.tensor([False]),
                      truncated=torch.tensor([t == 1]),
                      final_values=torch.tensor([[FINAL_VALUE if t == 1 else -99.0]]),
                      actor_hidden=torch.zeros(1, 1, 1))
    buffer.compute_returns(torch.tensor([[LAST_VALUE]]), GAMMA, LAMBDA)
    assert buffer.advantages.flatten().tolist() == pytest.approx(TRUNCATED_ADVANTAGES)
    assert buffer.returns.flatten().tolist() == pytest.approx(TRUNCATED_RETURNS)


def test_ppo_ratio_clipping_on_toy_distribution():
    old = torch.log(torch.tensor([0.2, 0.2, 0.2]))
    new = torch.log(torch.tensor([0.3, 0.1, 0.3])).requires_grad_()   # ratios 1.5, 0.5, 1.5
    advantages = torch.tensor([1.0, 1.0, -1.0])
    result = clipped_surrogate(new, old, advantages, clip_coef=0.2)
    # sample 0: min(1.5, 1.2)·1 = 1.2 (clipped); sample 1: min(0.5, 0.8) = 0.5;
    # sample 2: min(−1.5, −1.2) = −1.5 (the pessimistic, unclipped side)
    assert float(result.policy_loss.detach()) == pytest.approx(-(1.2 + 0.5 - 1.5) / 3)
    assert float(result.clipfrac) == pytest.approx(1.0)
    ratio = torch.tensor([1.5, 0.5, 1.5])
    assert float(result.approx_kl) == pytest.approx(float(((ratio - 1) - ratio.log()).mean()))
    result.policy_loss.backward()
    # The clipped sample gets no gradient; the others get −A·ratio/3.
    assert new.grad.tolist() == pytest.approx([0.0, -0.5 / 3, 1.5 / 3])


def test_ppo_ratio_inside_clip_range_is_unclipped():
    old = torch.log(torch.tensor([0.5, 0.5]))
    new = torch.log(torch.tensor([0.55, 0.45]))
    result = clipped_surrogate(new, old, torch.tensor([2.0, 2.0]), clip_coef=0.2)
    assert float(result.policy_loss) == pytest.approx(-(1.1 * 2 + 0.9 * 2) / 2)
    assert float(result.clipfrac) == 0.0


def test_entropy_and_log_prob_of_toy_distribution_with_a_mask():
    logits = torch.log(torch.tensor([[0.5, 0.25, 0.25, 0.0 + 1e-3]]))
    mask = torch.tensor([[True, True, True, False]])
    log_prob, entropy = log_prob_and_entropy(masked_logits(logits, mask), torch.tensor([1]))
    # The masked action's 0.001 is removed and the rest renormalised: p = (0.5, 0.25, 0.25).
    assert float(entropy) == pytest.approx(1.5 * math.log(2.0), rel=1e-5)
    assert float(log_prob) == pytest.approx(math.log(0.25), rel=1e-5)


def test_value_loss_clipping():
    old, target = torch.tensor([0.0]), torch.tensor([1.0])
    far = torch.tensor([0.9], requires_grad=True)
    # Clipped prediction 0.2 is worse than 0.9: the max picks the clipped term, 0.5·0.8².
    loss = clipped_value_loss(far, old, target, clip_coef=0.2)
    assert float(loss.detach()) == pytest.approx(0.5 * 0.8 ** 2)
    loss.backward()
    assert float(far.grad) == 0.0
    assert float(clipped_value_loss(far, old, target, clip_coef=0.0).detach()) == pytest.approx(0.5 * 0.1 ** 2)


def test_explained_variance():
    targets = torch.tensor([1.0, 2.0, 3.0, 4.0])
    assert explained_variance(targets, targets) == pytest.approx(1.0)
    assert explained_variance(torch.full((4,), 2.5), targets) == pytest.approx(0.0)


def test_value_norm_round_trip_and_running_statistics():
    generator = torch.Generator().manual_seed(0)
    first = torch.randn(500, generator=generator) * 7.0 + 30.0
    second = torch.randn(300, generator=generator) * 2.0 - 5.0
    norm = ValueNorm()
    norm.update(first)
    norm.update(second)
    both = torch.cat([first, second]).double()
    assert float(norm.mean) == pytest.approx(float(both.mean()), rel=1e-9)
    assert float(norm.var) == pytest.approx(float(both.var(unbiased=False)), rel=1e-9)
    values = torch.linspace(-50, 50, 11)
    assert torch.allclose(norm.denormalize(norm.normalize(values)), values, atol=1e-4)
    normalised = norm.normalize(both.float())
    assert float(normalised.mean()) == pytest.approx(0.0, abs=1e-4)
    assert float(normalised.std(unbiased=False)) == pytest.approx(1.0, abs=1e-3)
    restored = ValueNorm()
    restored.load_state_dict(norm.state_dict())
    assert torch.equal(restored.normalize(values), norm.normalize(values))


def test_masked_actions_are_never_sampled():
    generator = torch.Generator().manual_seed(0)
    # The masked actions would be the most likely ones by far without the mask.
    logits = torch.tensor([[8.0, 0.0, 8.0, 0.0, 1.0]]).expand(20_000, 5)
    mask = torch.tensor([[False, True, False, True, True]]).expand(20_000, 5)
    actions = sample_actions(masked_logits(logits, mask), generator)
    assert not mask[torch.arange(20_000), actions].eq(False).any()
    assert set(actions.unique().tolist()) == {1, 3, 4}


def _actor_and_sequence():
    torch.manual_seed(0)
    actor = Actor(obs_dim=3, n_actions=4, hidden_size=8)
    obs = torch.randn(6, 2, 3)                 # (T, B, obs_dim)
    return actor, obs


def test_gru_state_resets_exactly_at_episode_start():
    actor, obs = _actor_and_sequence()
    starts = torch.zeros(6, 2, dtype=torch.bool)
    starts[3, 0] = True                         # sequence 0 starts a new episode at t = 3
    hidden0 = torch.randn(2, 8)
    with torch.no_grad():
        whole = actor(obs, hidden0, starts).logits
        fresh = actor(obs[3:], torch.zeros(2, 8), torch.zeros(3, 2, dtype=torch.bool)).logits
        carried = actor(obs, hidden0, torch.zeros(6, 2, dtype=torch.bool)).logits
    # After the reset, sequence 0 behaves as if it had just begun ...
    assert torch.allclose(whole[3:, 0], fresh[:, 0], atol=1e-6)
    # ... and before it, and for sequence 1 throughout, nothing was reset.
    assert torch.equal(whole[:3], carried[:3])
    assert torch.equal(whole[:, 1], carried[:, 1])
    assert not torch.allclose(carried[3:, 0], fresh[:, 0], atol=1e-3)


def test_minibatch_chunks_carry_the_stored_hidden_state():
    """Training on chunks recomputes exactly the logits seen while collecting."""
    actor, obs = _actor_and_sequence()
    T, E, N, H = 6, 1, 2, 8
    buffer = RolloutBuffer(rollout_length=T, n_envs=E, n_agents=N, obs_dim=3, state_dim=1, n_actions=4, hidden_size=H)
    hidden = torch.randn(E * N, H)
    starts = [True, False, False, True, False, False]
    collected = []
    with torch.no_grad():
        for t in range(T):
            start = torch.tensor([starts[t]])
            out = actor(obs[t:t + 1], hidden, start.repeat(N).unsqueeze(0))
            collected.append(out.logits[0])
            buffer.insert(obs=obs[t].reshape(E, N, 3), state=torch.zeros(E, 1), actions=torch.zeros(E, N),
                          action_mask=torch.ones(E, N, 4, dtype=torch.bool), log_probs=torch.zeros(E, N),
                          values=torch.zeros(E, N), rewards=torch.zeros(E, N), episode_start=start,
                          terminated=torch.tensor([t == 2]), truncated=torch.tensor([False]),
                          final_values=torch.zeros(E, N), actor_hidden=hidden.reshape(E, N, H))
            hidden = out.hidden
    buffer.compute_returns(torch.zeros(E, N), 0.9, 0.9)
    chunks = list(buffer.minibatches(chunk_length=2, n_minibatches=3, generator=torch.Generator().manual_seed(1)))
    assert len(chunks) == 3
    with torch.no_grad():
        for batch in chunks:
            L, B = batch.episode_start.shape
            logits = actor(batch.obs.reshape(L, B * N, 3), batch.actor_hidden.reshape(B * N, H),
                           batch.episode_start.unsqueeze(-1).expand(L, B, N).reshape(L, B * N)).logits
            first = int(torch.nonzero(torch.all(buffer.obs[:, 0] == batch.obs[0, 0], dim=(-1, -2)))[0])
            for t in range(L):
                assert torch.allclose(logits[t], collected[first + t], atol=1e-6)
