"""The built-in controllers by name: what each is, which take the gains of (40) and which take options.

Read from the records the laws' modules declare (:func:`~paa_mj.control.record.controller` on each builder), in
the modules' text, without importing them: the command line's help reads this with no MuJoCo, numba or SciPy.
:mod:`paa_mj.control.registry` imports the same modules and joins each name to its builder; a test holds the two
views equal. A module of ``paa_mj/control/`` that declares a controller is found here (:func:`record_modules`):
adding a controller touches its own file and the docs.
"""
from __future__ import annotations

import ast
from pathlib import Path

from .record import CAPABILITIES, ControllerRecord

_HERE = Path(__file__).resolve().parent
_MARK = "@controller("


def _value(node):
    """A declared argument: a literal, or the name (a string) of what the module defines (a kernel)."""
    if isinstance(node, ast.Name):
        return node.id
    if isinstance(node, ast.Attribute):
        return ast.unparse(node)
    if isinstance(node, (ast.Tuple, ast.List)):
        return tuple(_value(item) for item in node.elts)
    return ast.literal_eval(node)


def _declared(module: str, tree) -> list:
    records = []
    for node in tree.body:
        if not isinstance(node, ast.FunctionDef):
            continue
        for decorator in node.decorator_list:
            if isinstance(decorator, ast.Call) and getattr(decorator.func, "id", None) == "controller":
                name, description = (ast.literal_eval(arg) for arg in decorator.args)
                capabilities = {k.arg: _value(k.value) for k in decorator.keywords if k.arg in CAPABILITIES}
                records.append(ControllerRecord(name, description, node.name, module, **capabilities))
    return records


def record_modules() -> tuple:
    """The modules of ``paa_mj/control/`` that declare a controller (``@controller(...)`` on a builder), by name."""
    return tuple(f"{__package__}.{path.stem}" for path in sorted(_HERE.glob("*.py"))
                 if path.stem != "record" and _MARK in path.read_text(encoding="utf-8"))


def read_records() -> dict:
    """The built-in controllers' records as their modules' text declares them (builders and kernels by name), in
    the order of :func:`record_modules` and of declaration within a module."""
    records = {}
    for module in record_modules():
        source = (_HERE / f"{module.rsplit('.', 1)[1]}.py").read_text(encoding="utf-8")
        for record in _declared(module, ast.parse(source)):
            records[record.name] = record
    return records


#: The built-in controllers' records, read from their modules (:func:`read_records`).
RECORDS = read_records()
#: Built-in controller names and what each is.
DESCRIPTIONS = {name: r.description for name, r in RECORDS.items()}
#: Controllers that swing up, then hand over to a balance: a run of them has a switch to speak of (the others, the
#: LQR alone, passive or a user's, have none).
HANDS_OVER = tuple(name for name, r in RECORDS.items() if r.hands_over or r.switches or r.roa or r.plans)
#: Controllers that take the gains kD, kP, kV of (40) / (12).
GAIN_CONTROLLERS = tuple(name for name, r in RECORDS.items() if r.gains)
#: Controllers that plan a kip, with options limit, duration and intervals.
PLANNERS = tuple(name for name, r in RECORDS.items() if r.plans)
#: Controllers that balance by the LQR (67), with the option lqr_weights = (q, r): Q = q I, R = r I (the paper's
#: q = 1e4, r = 1 by default).
LQR_CONTROLLERS = tuple(name for name, r in RECORDS.items() if r.lqr)
#: Controllers that switch from a swing-up to (67), with the option switch = "region" ((68), the default) or "roa"
#: (the LQR's cost-to-go below the level of its region of attraction, :mod:`paa_mj.theory.roa`).
SWITCHED = tuple(name for name, r in RECORDS.items() if r.switches)
#: Controllers that can hand over on the LQR's region of attraction, whose level takes the run's torque limits
#: (option limit: the model's actuator ranges capped by it).
ROA_SWITCHED = SWITCHED + tuple(name for name, r in RECORDS.items() if r.roa and not r.switches)
#: Controllers that take options, and which.
OPTIONS = {name: r.options for name, r in RECORDS.items() if r.options}
#: Controllers whose every kernel has a device form: what the Warp engine runs.
DEVICE_CONTROLLERS = tuple(name for name, r in RECORDS.items() if r.device)
#: Compare's default leaderboard (``paa-mj compare``).
COMPARE_CONTROLLERS = tuple(name for name, r in RECORDS.items() if r.compare)


def hands_over_on_roa(name, switch=None) -> bool:
    """Whether the controller ``name`` (with the option ``switch``) hands over on the LQR's region of attraction,
    whose level depends on the run's torque limits (its option ``limit``)."""
    return name in RECORDS and RECORDS[name].hands_over_on_roa(switch)


def takes_run_limit(name, switch=None) -> bool:
    """Whether the controller ``name`` (with the option ``switch``) is told the run's torque limits (its option
    ``limit``): a planner plans its kip within them, a controller with ``limit`` among its own settings (``mpc``)
    plans within them online, a hand-over on the LQR's region of attraction takes its level at them."""
    return name in PLANNERS or (name in RECORDS and "limit" in RECORDS[name].settings) or hands_over_on_roa(name, switch)
