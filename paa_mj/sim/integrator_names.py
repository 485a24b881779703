"""MuJoCo's integrators by name, as the command line offers them (plain data: no MuJoCo import)."""

INTEGRATOR_NAMES = ("RK4", "Euler", "implicitfast", "implicit")
