"""The compiled CPU engine: a rollout's step in numba, ``mj_step`` called from it, many rollouts on every core.

- :mod:`~paa_mj.sim.compiled.records`: the records the compiled engine reads and writes;
- :mod:`~paa_mj.sim.compiled.step`: one step of a rollout, compiled (the Warp engine translates the same functions);
- :mod:`~paa_mj.sim.compiled.engine`: the rollout engine (controller + ``mj_step`` in compiled code);
- :mod:`~paa_mj.sim.compiled.retirement`: when a balancing rollout can stop early;
- :mod:`~paa_mj.sim.compiled.mujoco_lib`: MuJoCo's C functions from numba;
- :mod:`~paa_mj.sim.compiled.mujoco_batch`: the same plan through ``mujoco.batch``, head to head.
"""
