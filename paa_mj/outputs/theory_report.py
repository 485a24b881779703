"""The theory of one robot and one set of gains, as one report: data (JSON) and a text table.

Gathers :mod:`paa_mj.theory` (Theorem 1's conditions, linear analysis at UDD)
and :mod:`paa_mj.control.closed_loop` (the closed loop at DUU).
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

from ..control.gains import check_gain_range
from ..control.closed_loop import duu_eigenvalues
from ..model.dynamics import AnalyticModel
from ..task import Task
from ..theory.conditions import constraint_54, frozen_acrobot_controllable, thresholds
from ..theory.linear import goal_controllability, lqr_gain, sampled_balance


@dataclass
class TheoryReport:
    """Every condition of the paper for one robot and one set of gains."""

    beta: list
    E_r: float
    kD_min: float
    kD_min_at: list
    eta1: float
    eta1_at: list
    eta2: float
    eta2_at: float
    constraint_54: dict
    deltabar_min: float
    deltabar_max: float
    frozen_acrobot_ud_controllable: bool
    udd_controllable: bool
    udd_controllability: dict
    lqr_K: list
    gains: dict
    duu_eigenvalues: list
    duu_charpoly: list
    duu_unstable: bool
    theorem1: dict = field(default_factory=dict)
    #: Spectral radius of the LQR (67) loop sampled with zero-order hold at ``dt`` (< 1: stable), and ``dt`` [s].
    lqr_sampled_radius: float | None = None
    dt: float | None = None
    #: The largest of ``dt``/2^k [s] at which that sampled loop is stable (``dt`` itself where it is; None: none
    #: down to ``dt``/256).
    lqr_stable_dt: float | None = None
    goal: str = "folded"
    #: How kD_min was found, and its certificate: kD_min <= kD_min_upper, by the branch and bound of
    #: :mod:`paa_mj.theory.kd_search`; certified when (upper - kD_min) / kD_min <= kD_min_tolerance.
    kD_min_method: str = ""
    kD_min_upper: float | None = None
    kD_min_certified: bool | None = None
    kD_min_tolerance: float | None = None
    kD_min_gap: float | None = None

    def to_json_dict(self):
        """The report as JSON data; the sampled LQR's keys only where a time step was given."""
        data = asdict(self)
        if self.dt is None:
            del data["lqr_sampled_radius"], data["dt"], data["lqr_stable_dt"]
        return data


def theory_report(am: AnalyticModel, kD, kP, kV, dt=None) -> TheoryReport:
    """Compute every condition of Theorem 1, the linear analysis at UDD and the closed loop at DUU (the paper's
    folded task); with ``dt`` [s] (the simulation's step), the spectral radius of the LQR (67) loop sampled with
    zero-order hold at ``dt``."""
    check_gain_range(kD, kP, kV, am)
    task = Task.named("folded", am)
    kd, e1, e2 = thresholds(am)
    certificate = _certify(am, kd, task)
    c54 = constraint_54(am)
    frozen_ok, db_min, db_max = frozen_acrobot_controllable(am)
    ctrb = goal_controllability(am, task)
    eig, poly = duu_eigenvalues(am, kD, kP, kV)
    K = lqr_gain(am, task)
    conditions = {
        "E_r > 0": bool(am.E_r > 0),
        "(54) holds": c54.holds,
        "kD > kD_min (41)": bool(kD > kd.value),
        "kP > eta1 (59)": bool(kP > e1.value),
        "kP > eta2 (60)": bool(kP > e2.value),
        "kV > 0": bool(kV > 0),
    }
    conditions["all hold"] = all(conditions.values())
    return TheoryReport(
        beta=am.beta.tolist(), E_r=float(am.E_r),
        kD_min=kd.value, kD_min_at=list(kd.argmax),
        eta1=e1.value, eta1_at=list(e1.argmax), eta2=e2.value, eta2_at=float(e2.argmax[0]),
        constraint_54=asdict(c54), deltabar_min=db_min, deltabar_max=db_max,
        frozen_acrobot_ud_controllable=frozen_ok,
        udd_controllable=ctrb.controllable, udd_controllability=asdict(ctrb),
        lqr_K=K.tolist(), gains={"kD": kD, "kP": kP, "kV": kV},
        **_sampled(am, K, dt, task, ctrb.controllable), dt=dt,
        duu_eigenvalues=[[float(e.real), float(e.imag)] for e in eig],
        duu_charpoly=[float(c) for c in poly],
        duu_unstable=bool(np.max(eig.real) > 0),
        theorem1=conditions, **certificate,
    )


def _certify(am, kd, task):
    """The grid's kD_min of (41) certified by the branch and bound (:func:`~paa_mj.theory.conditions.chain_kd_min`,
    the same function of the actuated angles): its upper bound, and the relative gap to the grid's value."""
    from ..theory.conditions import chain_kd_min

    bound = chain_kd_min(am, task, progress=False)
    upper = max(bound.upper, kd.value)
    gap = (upper - kd.value) / abs(kd.value)
    return {"kD_min_method": ("grid 121 x 121 over (q2, q3) and zoomed grids, certified by"
                              f" {bound.method}"),
            "kD_min_upper": upper, "kD_min_certified": bool(gap <= bound.tol), "kD_min_tolerance": bound.tol,
            "kD_min_gap": gap}


def _sampled(am, K, dt, task, controllable):
    """The LQR (67) loop sampled at ``dt``: its spectral radius and the largest stable dt/2^k (None without dt)."""
    if dt is None or not controllable:
        return {"lqr_sampled_radius": None, "lqr_stable_dt": None}
    balance = sampled_balance(am, K, dt, task)
    return {"lqr_sampled_radius": float(balance["radius"]), "lqr_stable_dt": balance["stable_dt"]}


def chain_theory_report(am: AnalyticModel, kD, kP, kV, task: Task, dt=None, kd_budget_cpu_s=None) -> dict:
    """What is defined and computable for a robot or goal beyond Theorem 1 (beyond the paper).

    The energy at the goal and its sign, the singularity bound (41) from its definition, linear
    controllability at the goal (our rank and PBH test, and python-control's ``ctrb``), the LQR gain there,
    and the merged acrobot of Sect. 2.4 (deltabar of (30), Lemma 1). Theorem 1's other conditions
    ((54), (59), (60)) are proved for the paper's gymnast and folded goal only: the report says so.
    """
    import control

    from ..theory.conditions import chain_kd_min
    from ..theory.merged import merged_acrobot
    from ..theory.linear import goal_linearization, linear_controllability

    check_gain_range(kD, kP, kV, am)
    E_r = task.goal_energy(am)
    kd = chain_kd_min(am, task, budget_cpu_s=kd_budget_cpu_s)
    safe_above = kd.value if kd.certified else kd.upper
    A, B = goal_linearization(am, task)
    ctrb = linear_controllability(A, B)
    with np.errstate(all="ignore"):  # unscaled, A^(2n - 1) B overflows on long chains
        unscaled = control.ctrb(A, B)
    rank = int(np.linalg.matrix_rank(unscaled)) if np.all(np.isfinite(unscaled)) else None
    merged = merged_acrobot(am)
    K = lqr_gain(am, task)
    why = (f"this robot has {am.n_links} links" if am.n_links != 3 else "this robot has damping or armature") \
        if not am.paper_shape else f"the goal is {task.name}"
    return {
        "links": am.n_links, "goal": task.name, "beta": am.gravity_constants.tolist(), "E_r": E_r,
        "E_r_positive": bool(E_r > 0),
        **kd.as_dict("kD_min"), "kD_min_boxes": kd.boxes, "kD_above_kD_min": bool(kD > safe_above),
        "goal_controllable": ctrb.controllable, "goal_controllability": asdict(ctrb), "ctrb_rank": rank,
        "state_dimension": int(A.shape[0]),
        "lqr_K": K.tolist(),
        **_sampled(am, K, dt, task, ctrb.controllable), "dt": dt,
        "merged_acrobot_ud_controllable": merged.controllable, "deltabar_min": merged.minimum,
        "deltabar_max": merged.maximum, "deltabar_min_at": list(merged.argmin), "deltabar_max_at": list(merged.argmax),
        "deltabar_method": merged.method,
        "gains": {"kD": kD, "kP": kP, "kV": kV},
        "theorem1": f"not covered: Theorem 1 and the bounds (54), (59), (60) are proved for the paper's 3-link gymnast"
                    f" without damping and its folded goal (UDD); {why}. kD_min (41) here is its definition"
                    " computed for this robot (beyond the paper).",
    }


def chain_theory_table(name, r) -> str:
    """A plain-text table of :func:`chain_theory_report`."""
    g = r["gains"]
    lines = [
        f"Theory for robot {name}: {r['links']} links, {r['goal']} goal (beyond the paper)",
        "  b_k (gravity constants)    " + "  ".join(f"{v:.4f}" for v in r["beta"]) + "  J",
        f"  E_r = P(q*)                {r['E_r']:.4f} J   {'> 0' if r['E_r_positive'] else '<= 0'}",
        f"  kD_min (41), by definition {_kd_words(r)}   at q_a = ({', '.join(f'{v:.4f}' for v in r['kD_min_at'])});"
        f" kD = {g['kD']:g} {'above' if r['kD_above_kD_min'] else 'NOT above'}",
        f"      by {r['kD_min_method']}" + (f", {r['kD_min_boxes']} boxes" if r["kD_min_boxes"] else ""),
        f"  goal linearly controllable {_yes(r['goal_controllable'])} (PBH margin"
        f" {r['goal_controllability']['pbh_min']:.3g}; scaled Kalman rank {r['goal_controllability']['rank']} of"
        f" {r['state_dimension']}, python-control ctrb rank "
        + ("- (it overflows)" if r["ctrb_rank"] is None else f"{r['ctrb_rank']}")
        + ("" if r["goal_controllability"]["rank"] == r["ctrb_rank"] == r["state_dimension"] else
           ": the powers of A are too ill-conditioned for a rank on this chain, PBH decides") + ")",
        f"  merged acrobot (30)        deltabar in [{r['deltabar_min']:.6g}, {r['deltabar_max']:.6g}] (extremes found):"
        f" up-down controllable for every frozen posture: {_decided(r['merged_acrobot_ud_controllable'])}",
        f"      {r['deltabar_method']}",
        f"  LQR gain K at the goal     Q = 1e4 I{r['state_dimension']}, R = I{r['links'] - 1}",
    ]
    for row in r["lqr_K"]:
        lines.append("      [" + "  ".join(f"{v:10.3f}" for v in row) + " ]")
    lines += _sampled_line(r)
    lines.append(f"  gains                      kD = {g['kD']:g}, kP = {g['kP']:g}, kV = {g['kV']:g}")
    lines += _rule_line(r)
    lines.append(f"  Theorem 1                  {r['theorem1']}")
    return "\n".join(lines)


def _rule_line(r):
    rule = r.get("family_rule")
    if rule is None:
        return []
    g = rule["gains"]
    return [f"  family rule ({rule['rule']})  kD = {g['kD']:.6g}, kP = {g['kP']:.6g}, kV = {g['kV']:.6g}"]


def _kd_words(r):
    """The chain's kD_min: its value, certified to its tolerance, or its bracket."""
    if r["kD_min_certified"]:
        return f"{r['kD_min']:.6g} (certified to {r['kD_min_tolerance']:.0e})"
    return f"in [{r['kD_min']:.6g}, {r['kD_min_upper']:.6g}] (NOT certified)"


def _sampled_line(r):
    radius = r.get("lqr_sampled_radius")
    if radius is None:
        return []
    stable = r.get("lqr_stable_dt")
    verdict = "stable" if radius < 1 else "UNSTABLE: these weights do not balance at this time step; " + (
        f"stable from dt = {stable * 1e3:g} ms" if stable is not None else "at no step down to 1/256 of it")
    return [f"  LQR sampled at dt = {r['dt'] * 1e3:g} ms  spectral radius {radius:.6g} ({verdict})"]


def _yes(flag):
    return "yes" if flag else "NO"


def _decided(flag):
    return "undecided" if flag is None else _yes(flag)


def theory_table(name, r) -> str:
    """A plain-text table of :class:`~paa_mj.theory.TheoryReport` (as a dict)."""
    c54 = r["constraint_54"]
    g = r["gains"]
    lines = [
        f"Theory of Liu & Xin (2015) for robot {name}",
        f"  b1, b2, b3 (4)             {r['beta'][0]:.4f}  {r['beta'][1]:.4f}  {r['beta'][2]:.4f}  J",
        f"  E_r = b1 - b2 - b3 (9)     {r['E_r']:.4f} J   {'> 0' if r['E_r'] > 0 else '<= 0: the method does not apply'}",
        f"  kD_min (41)                {r['kD_min']:.6g}   at (q2, q3) = ({r['kD_min_at'][0]:.4f}, {r['kD_min_at'][1]:.4f})",
        f"      {r['kD_min_method']}:",
        f"      kD_min <= {r['kD_min_upper']:.10g}"
        f" ({'certified' if r['kD_min_certified'] else 'NOT certified'} to {r['kD_min_tolerance']:.0e})",
        f"  eta1 (59)                  {r['eta1']:.6g}   at (y, z) = ({r['eta1_at'][0]:.4f}, {r['eta1_at'][1]:.4f})",
        f"  eta2 (60)                  {r['eta2']:.6g}   at z = {r['eta2_at']:.4f}",
        f"  constraint (54)            {'holds' if c54['holds'] else 'FAILS'}: f in [{c54['f_min']:.6g}, {c54['f_max']:.6g}],"
        f" closest to 1 at z = {c54['z_closest']:.4f} (|f - 1| = {c54['closest_to_one']:.3g})",
        f"  frozen Acrobot (30)        deltabar in [{r['deltabar_min']:.6g}, {r['deltabar_max']:.6g}]:"
        f" up-down controllable for every z: {_yes(r['frozen_acrobot_ud_controllable'])}",
        f"  UDD linearly controllable  {_yes(r['udd_controllable'])} (rank {r['udd_controllability']['rank']},"
        f" PBH margin {r['udd_controllability']['pbh_min']:.3g})",
        "  LQR gain K (67)            Q = 1e4 I6, R = I2",
    ]
    for row in r["lqr_K"]:
        lines.append("      [" + "  ".join(f"{v:10.3f}" for v in row) + " ]")
    lines += _sampled_line(r)
    lines.append(f"  gains                      kD = {g['kD']:g}, kP = {g['kP']:g}, kV = {g['kV']:g}")
    lines += _rule_line(r)
    lines.append(f"  DUU closed-loop eigenvalues ({'unstable' if r['duu_unstable'] else 'NOT unstable'}):")
    for re, im in r["duu_eigenvalues"]:
        lines.append(f"      {re:+.6f} {im:+.6f}j")
    lines.append("  Theorem 1 conditions:")
    for cond, ok in r["theorem1"].items():
        lines.append(f"      {cond:<22} {_yes(ok)}")
    return "\n".join(lines)
