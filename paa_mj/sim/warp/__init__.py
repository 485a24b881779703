"""The rollout engine on MuJoCo Warp (extra ``gpu``): N rollouts as N worlds of one device.

- :mod:`~paa_mj.sim.warp.engine`: the loop on a device, the controller on the device too;
- :mod:`~paa_mj.sim.warp.translate`: the compiled laws' and the step's source as Warp functions;
- :mod:`~paa_mj.sim.warp.device`: loading Warp, naming the device.
"""
