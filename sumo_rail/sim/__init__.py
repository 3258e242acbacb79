"""The environment: one SUMO per process (`simulation` is the only importer of libsumo/traci), the generated
network, the virtual LIDAR, observations, actions, rewards and the Gymnasium env.

May import: the top level (config, seeding, datasets).
"""
