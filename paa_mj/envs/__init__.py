"""The gymnast as Gymnasium environments, one or many at a time (extra ``paa_mj[gym]``).

- :mod:`~paa_mj.envs.spaces`: the episode types, the observation and action maps;
- :mod:`~paa_mj.envs.stepper`: N robots stepped by one compiled call (physics, rewards, the task's book);
- :mod:`~paa_mj.envs.single`: :class:`GymnastEnv`, one environment (its docstring lists the registered ids);
- :mod:`~paa_mj.envs.vector`: :class:`GymnastVectorEnv`, N environments stepped together;
- :mod:`~paa_mj.envs.policy`: a controller of the package as a policy, and a trained policy as a controller.

Importing this package registers the environments with Gymnasium when it is installed
(``gym.make("paa_mj.envs:paa_mj/GymnastKip-v1")`` imports it by itself).
"""
from ..lazy import lazy_exports

ENV_ID = "paa_mj/GymnastKip-v0"
KIP_ID = "paa_mj/GymnastKip-v1"
BALANCE_ID = "paa_mj/GymnastBalance-v1"

_EXPORTS = {
    "GymnastEnv": ".single",
    "GymnastKipEnv": ".single",
    "GymnastVectorEnv": ".vector",
    "SB3Policy": ".policy",
    "controller_policy": ".policy",
    "observation": ".spaces",
    "action_to_torque": ".spaces",
    "torque_to_action": ".spaces",
}

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())


def register():
    """Register the environments with Gymnasium (done on import of this package, where Gymnasium is installed)."""
    try:
        import gymnasium as gym
    except ImportError:  # an extra: without it there is nothing to register
        return
    if ENV_ID not in gym.registry:
        gym.register(id=ENV_ID, entry_point="paa_mj.envs.single:GymnastKipEnv")
    for env_id, episode in ((KIP_ID, "kip"), (BALANCE_ID, "balance")):
        if env_id not in gym.registry:
            # the horizon in steps is the environment's own (its seconds over its period): it adds the TimeLimit
            gym.register(id=env_id, entry_point="paa_mj.envs.single:registered",
                         vector_entry_point="paa_mj.envs.vector:GymnastVectorEnv", kwargs={"episode": episode})


register()

__all__ = ["BALANCE_ID", "ENV_ID", "GymnastEnv", "GymnastKipEnv", "GymnastVectorEnv", "KIP_ID", "SB3Policy",
           "action_to_torque", "controller_policy", "observation", "register", "torque_to_action"]
