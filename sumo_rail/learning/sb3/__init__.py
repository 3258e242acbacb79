"""The Stable-Baselines3 drivers: GAIL (`gail.py`) and the PPO driver (`ppo.py`) on what they share: PPO with a
`PolicyShape` actor (`actor.py`, `runs.py`), the reward labelling (`rewards.py`), resume (`resume.py`), the environment
processes (`envs.py`) and the respawning shared-road VecEnv (`shared_road.py`). Stable-Baselines3 is optional (the
`baselines` extra): it is imported only where a run builds PPO or its vector environments (`vec_envs.py`)."""
