"""Many episodes at once: one episode as a pure function of its inputs (`rollout`), the serial, process-pool
and Ray backends that run them, the recorder of demonstrations and the Parquet tables they write.

May import: the top level, `sim` and `drivers`.
"""
