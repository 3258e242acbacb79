"""Improving a policy from demonstrations and rollouts: observation statistics, ARS (noise, update), behaviour
cloning, the LS-GAN discriminator, RAIL's iteration and run folder, and the GAIL baseline.

May import: the top level, `sim`, `drivers`, `runners` and `evaluation`.
"""
