"""Improving a policy from demonstrations and rollouts.

`rail/` holds RAIL (observation statistics, ARS's noise and update, the LS-GAN discriminator, an iteration, its
trainer, the step signal); `sb3/` the Stable-Baselines3 drivers (GAIL, the PPO driver, their PPO, resume and the
shared-road environments), imported only by the commands that run them. Here: behaviour cloning (`bc.py`), DAgger
(`dagger.py`, its mixture `mixture.py`, and against the log of a recorded scene `log_dagger.py` with its teacher
`log_teacher.py`), the run folder every training command writes (`run_folder.py`), validation during training
(`validation.py`), TensorBoard logging and torch's thread setting.

May import: the top level, `sim`, `drivers`, `runners`, `recordings` and `evaluation`.
"""
