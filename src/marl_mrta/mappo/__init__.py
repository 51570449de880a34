"""MAPPO (centralised critic, shared recurrent actor) for task allocation, free of ROS.

config (settings) · networks (actor, critic) · buffer (storage, GAE, chunks) ·
trainer (PPO update) · env_pool (N environments) · runner (the loop, checkpoints) ·
policy (standalone actor for evaluation and per-robot execution) · plots.
"""
