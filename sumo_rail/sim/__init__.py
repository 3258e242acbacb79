"""The environment: one SUMO per process (`simulation` is the only importer of libsumo/traci), the generated
network, the virtual LIDAR, observations, actions, rewards, the Gymnasium env (one ego) and the PettingZoo
env (several egos on one road, `parallel_env.py`), both driving each ego with `ego.py`.

May import: the top level (config, seeding, datasets).
"""
