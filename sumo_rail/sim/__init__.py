"""The environment, and the only stage that speaks to SUMO (docs/design.md, "Where to find it": the SUMO
boundary): one SUMO per process (`sumo_api` is the only importer of libsumo/traci), the generated network, where the
traffic comes from (`traffic_source`, a recorded scene's in `replay`), who drives an ego (`controllers`), watching
episodes (`observers`), the virtual LIDAR, observations, actions, rewards, the Gymnasium env (one ego) and the
PettingZoo env (several egos on one road, `parallel_env.py`), both driving each ego with `ego.py`.

May import: the top level (config, seeding, datasets).
"""
