"""RAIL: the running observation statistics (`normalize.py`), ARS's shared noise and update (`noise.py`, `ars.py`),
the LS-GAN discriminator (`discriminator.py`, GAIL's reward too), one iteration (`iteration.py`), the trainer that
runs iterations in a run folder (`trainer.py`) and the measurement of a step's signal (`step_signal.py`)."""
