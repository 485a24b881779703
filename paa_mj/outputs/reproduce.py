"""``paa-mj reproduce``: the paper's simulations redone, figures 5-14 and ``report.md``.

Every number in the report is computed here; the paper's values (PAA_MODEL.md
section 8) stand beside ours, labelled as the paper's, each claim marked
reproduced or not.
"""
from __future__ import annotations

import time
import warnings
from pathlib import Path

import numpy as np
from tqdm.auto import tqdm

from ..control.gains import TheoryWarning
from ..errors import SimulationDiverged
from ..io import ensure_dir, write_json, write_text
from ..model.robot import load_robot
from ..model.states import X0_HANGING
from ..sim.analytic import simulate_analytic
from ..sim.rollout import simulate_mujoco
from .plots import angles_figure, discretisation_figure, energy_figure, f54_figure, save_figure, torques_figure
from .theory_report import theory_report

#: What the paper reports (PAA_MODEL.md section 8): used only for comparison in the report.
PAPER = {
    "gymnast": {"beta": [289.5323, 148.6215, 59.8901], "kD_min": 4503, "eta1": 15863, "eta2": 3591,
                "switch_time": 13.38},
    "example2": {"beta": [44.1450, 3.6788, 1.2263]},
}
T_FINAL = 30.0


def _study_cases(quick):
    if quick:
        return [("RK4", 1e-3), ("Euler", 1e-3)]
    return [("RK4", 1e-3), ("RK4", 5e-4), ("RK4", 2.5e-4), ("RK4", 1e-4),
            ("Euler", 1e-3), ("Euler", 5e-4), ("Euler", 2e-4),
            ("implicitfast", 1e-3), ("implicitfast", 5e-4)]


def discretisation_study(robot, quick=False, t_final=60.0):
    """First switch time and success for several integrators and steps, plus the analytic reference.

    Each MuJoCo run stops once its balance can no longer fail (the engine's retirement rule).
    """
    rows = []
    cases = _study_cases(quick)
    for integrator, dt in tqdm(cases, desc="discretisation study", unit="run"):
        try:
            traj = simulate_mujoco(robot, "vcl", X0_HANGING, t_final, dt=dt, integrator=integrator, retire=True)
            status = "ok"
        except SimulationDiverged as err:
            traj, status = err.trajectory, str(err)
        rows.append({"engine": "mujoco", "integrator": integrator, "dt": dt, "switch_time": traj.switch_time,
                     "balanced": traj.balanced(), "status": status})
    traj = simulate_analytic(robot, "vcl", X0_HANGING, t_final if not quick else 30.0)
    rows.append({"engine": "analytic", "integrator": "solve_ivp DOP853 rtol 1e-10", "dt": None,
                 "switch_time": traj.switch_time, "balanced": traj.balanced(), "status": "ok"})
    return rows


def _mark(ok):
    return "reproduced" if ok else "**not reproduced**"


def _fmt(x, digits=4):
    return "never" if x is None else f"{x:.{digits}f}"


def reproduce(out_dir="out/reproduction", quick=False, video=True):
    """Run both robots, write figures, the study, ``results.json`` and ``report.md``; return the report path."""
    out = ensure_dir(out_dir)
    figs = ensure_dir(out / "figures")
    started = time.time()
    results = {}
    gymnast, example2 = load_robot("gymnast"), load_robot("example2")

    # --- theory ------------------------------------------------------------------
    th1 = theory_report(gymnast.analytic, **gymnast.gains).to_json_dict()
    th2 = theory_report(example2.analytic, **example2.gains).to_json_dict()
    results["theory"] = {"gymnast": th1, "example2": th2}
    save_figure(f54_figure(gymnast.analytic, "Fig. 5: f(z) of (54), Table 1 robot"), figs, "fig05_f54_table1")
    save_figure(f54_figure(example2.analytic, "Fig. 11: f(z) of (54), Table 2 robot"), figs, "fig11_f54_table2")

    # --- simulations ---------------------------------------------------------------
    runs = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", TheoryWarning)  # Example 2 violates (54) on purpose
        specs = [("gymnast_swingup", gymnast, "vcl-only"), ("gymnast_switch", gymnast, "vcl"),
                 ("example2_swingup", example2, "vcl-only")]
        for key, robot, controller in tqdm(specs, desc="simulations", unit="run"):
            runs[key] = simulate_mujoco(robot, controller, X0_HANGING, T_FINAL, progress=True)
            runs[key].save(out / "runs" / key)
    g_sw, g_hy, e_sw = runs["gymnast_swingup"], runs["gymnast_switch"], runs["example2_swingup"]
    for fig, stem in [
            (energy_figure(g_sw, "Fig. 6: V and E - E_r, Table 1, controller (40)"), "fig06_energy_table1"),
            (angles_figure(g_sw, "Fig. 7: angles, Table 1, controller (40)"), "fig07_angles_table1"),
            (torques_figure(g_sw, "Fig. 8: torques, Table 1, controller (40)"), "fig08_torques_table1"),
            (angles_figure(g_hy, "Fig. 9: angles, Table 1, (40) then LQR (67)"), "fig09_angles_switch_table1"),
            (torques_figure(g_hy, "Fig. 10: torques, Table 1, (40) then LQR (67)"), "fig10_torques_switch_table1"),
            (energy_figure(e_sw, "Fig. 12: V and E - E_r, Table 2, controller (40)"), "fig12_energy_table2"),
            (angles_figure(e_sw, "Fig. 13: angles, Table 2, controller (40)"), "fig13_angles_table2"),
            (torques_figure(e_sw, "Fig. 14: torques, Table 2, controller (40)"), "fig14_torques_table2")]:
        save_figure(fig, figs, stem)

    study = discretisation_study(gymnast, quick=quick)
    results["discretisation_study"] = study
    save_figure(discretisation_figure(study), figs, "switch_time_vs_dt")

    video_path = None
    if video:
        video_path = _kip_video(out, g_hy, gymnast)
    results["runs"] = {k: v.summary() for k, v in runs.items()}
    write_json(out / "results.json", results)
    report = _report_text(th1, th2, g_sw, g_hy, e_sw, study, video_path, out, time.time() - started)
    write_text(out / "report.md", report)
    return out / "report.md"


def _kip_video(out, traj, robot):
    """The Table 1 kip as MP4 and a filmstrip, when the video module and a GL backend are there."""
    try:
        from .video import filmstrip, render_trajectory
    except ImportError:
        return None
    from ..errors import PaaError

    try:
        path = render_trajectory(robot, traj, out / "kip_table1.mp4")
        filmstrip(robot, traj, out / "figures" / "filmstrip_table1.png")
        return path
    except PaaError as err:
        print(f"paa-mj: warning: no video: {err}")
        return None


def _swing_facts(traj):
    n = len(traj.t)
    last = traj.t >= traj.t[-1] - 2.0
    return {
        "V0": float(traj.V[0]), "V_end": float(traj.V[-1]),
        "E0": float(traj.E_minus_Er[0]), "E_end": float(traj.E_minus_Er[-1]),
        "q1_range": float(np.ptp(traj.q[:, 0])),
        "q2_end": float(traj.q[-1, 1]), "q3_end": float(traj.q[-1, 2]),
        "max_cos_q1": float(np.max(np.cos(traj.q[:, 0]))),
        "tau2_larger": float(np.mean(np.abs(traj.tau[:, 0]) > np.abs(traj.tau[:, 1]))) if n else 0.0,
        "tau_end": float(np.max(np.abs(traj.tau[last]))), "tau_max": float(np.max(np.abs(traj.tau))),
    }


def _report_text(th1, th2, g_sw, g_hy, e_sw, study, video_path, out, seconds):
    p1, p2 = PAPER["gymnast"], PAPER["example2"]
    s1, s2 = _swing_facts(g_sw), _swing_facts(e_sw)
    beta_ok1 = np.allclose(th1["beta"], p1["beta"], atol=5e-5)
    beta_ok2 = np.allclose(th2["beta"], p2["beta"], atol=5e-5)
    c1, c2 = th1["constraint_54"], th2["constraint_54"]
    rel = lambda ours, paper: abs(ours - paper) / paper  # noqa: E731
    eig1 = ", ".join(f"{re:+.4f}{im:+.4f}j" for re, im in th1["duu_eigenvalues"])
    eig2 = ", ".join(f"{re:+.3g}{im:+.4f}j" for re, im in th2["duu_eigenvalues"])
    poly1 = ", ".join(f"{c:.6g}" for c in th1["duu_charpoly"])
    switched = [r for r in study if r["switch_time"] is not None]
    all_balanced = all(r["balanced"] for r in switched) and len(switched) == len(study)
    spread = (min(r["switch_time"] for r in switched), max(r["switch_time"] for r in switched)) if switched else (None, None)
    rk4 = g_hy.switch_time
    rows = [
        ("Table 1: b1, b2, b3 [J]", "289.5323, 148.6215, 59.8901", ", ".join(f"{b:.4f}" for b in th1["beta"]), _mark(beta_ok1)),
        ("Table 1: E_r > 0", "yes", f"E_r = {th1['E_r']:.4f} J", _mark(th1["E_r"] > 0)),
        ("Table 1: 0 < f(z) < 1 (Fig. 5)", "yes", f"f in [{c1['f_min']:.5f}, {c1['f_max']:.5f}]", _mark(0 < c1["f_min"] and c1["f_max"] < 1)),
        ("Table 1: UDD linearly controllable", "yes", f"rank {th1['udd_controllability']['rank']}", _mark(th1["udd_controllable"])),
        ("Table 1: kD_min (41)", "4503", f"{th1['kD_min']:.2f} (rel. diff {rel(th1['kD_min'], p1['kD_min']):.1e})", _mark(rel(th1["kD_min"], p1["kD_min"]) < 1e-3)),
        ("Table 1: eta1, kP bound (62)", "15863", f"{th1['eta1']:.2f} (rel. diff {rel(th1['eta1'], p1['eta1']):.1e})", _mark(rel(th1["eta1"], p1["eta1"]) < 1e-3)),
        ("Table 1: eta2, kP bound (63)", "3591", f"{th1['eta2']:.2f} (rel. diff {rel(th1['eta2'], p1['eta2']):.1e})", _mark(rel(th1["eta2"], p1["eta2"]) < 1e-3)),
        ("Figs. 6-8: V -> 0", "yes", f"V: {s1['V0']:.4g} -> {s1['V_end']:.4g} at {g_sw.t[-1]:.0f} s", _mark(s1["V_end"] < 1e-4 * s1["V0"])),
        ("Figs. 6-8: E - E_r -> 0", "yes", f"E - E_r: {s1['E0']:.2f} -> {s1['E_end']:.4f} J", _mark(abs(s1["E_end"]) < 1e-2 * abs(s1["E0"]))),
        ("Figs. 6-8: q2 -> -pi, q3 -> 0", "yes", f"q2 + pi = {s1['q2_end'] + np.pi:.2e}, q3 = {s1['q3_end']:.2e}", _mark(abs(s1["q2_end"] + np.pi) < 0.05 and abs(s1["q3_end"]) < 0.05)),
        ("Figs. 6-8: link 1 swings through > 2 pi", "yes", f"range of q1 = {s1['q1_range']:.3f} rad", _mark(s1["q1_range"] > 2 * np.pi)),
        ("Figs. 6-8: |tau2| mostly > |tau3|", "yes", f"{100 * s1['tau2_larger']:.0f} % of samples", _mark(s1["tau2_larger"] > 0.5)),
        ("Figs. 9-10: LQR balances at UDD", "yes", f"balanced: {g_hy.balanced()}", _mark(g_hy.balanced())),
        ("Figs. 9-10: first switch time", "about 13.38 s", f"{_fmt(rk4, 3)} s (MuJoCo RK4, 1 ms)", _mark(rk4 is not None and abs(rk4 - p1["switch_time"]) < 0.5)),
        ("DUU unstable in closed loop, gains (66)", "yes (char. polynomial)", f"eigenvalues {eig1}", _mark(th1["duu_unstable"])),
        ("Table 2: b1, b2, b3 [J]", "44.1450, 3.6788, 1.2263", ", ".join(f"{b:.4f}" for b in th2["beta"]), _mark(beta_ok2)),
        ("Table 2: E_r > 0", "yes", f"E_r = {th2['E_r']:.4f} J", _mark(th2["E_r"] > 0)),
        ("Table 2: UDD linearly controllable", "yes", f"rank {th2['udd_controllability']['rank']}", _mark(th2["udd_controllable"])),
        ("Table 2: f = 1 at z = 0, 2 pi, (54) fails (Fig. 11)", "yes", f"min |f - 1| = {c2['closest_to_one']:.1e} at z = {c2['z_closest']:.4f}; f in [{c2['f_min']:.4f}, {c2['f_max']:.4f}]", _mark(not c2["holds"])),
        ("Figs. 12-14: V does not go to 0", "yes", f"V: {s2['V0']:.4g} -> {s2['V_end']:.4g}", _mark(s2["V_end"] > 1e-2 * s2["V0"])),
        ("Figs. 12-14: E - E_r does not go to 0", "yes", f"E - E_r: {s2['E0']:.3f} -> {s2['E_end']:.3f} J", _mark(abs(s2["E_end"]) > 1.0)),
        ("Figs. 12-14: q2 -> -pi, q3 -> 0", "yes", f"q2 + pi = {s2['q2_end'] + np.pi:.2e}, q3 = {s2['q3_end']:.2e}", _mark(abs(s2["q2_end"] + np.pi) < 0.05 and abs(s2["q3_end"]) < 0.05)),
        ("Figs. 12-14: link 1 never swings up", "yes", f"max cos q1 = {s2['max_cos_q1']:.3f} (link 1 {'stays below' if s2['max_cos_q1'] < 0 else 'rises above'} the bar)", _mark(s2["max_cos_q1"] < 0)),
        ("Figs. 12-14: torques decay to 0", "yes", f"max |tau| in the last 2 s: {s2['tau_end']:.2e} (peak {s2['tau_max']:.2f}) N m", _mark(s2["tau_end"] < 0.05 * s2["tau_max"])),
    ]
    lines = [
        "# Liu & Xin (2015) reproduced in MuJoCo",
        "",
        f"Generated by `paa-mj reproduce` in {seconds:.0f} s. Simulations: MuJoCo {__import__('mujoco').__version__},"
        " RK4 at 1 ms, torque held over each step (zero-order hold), from (65) q = (-pi, 0, 0), qd = 0,"
        f" {T_FINAL:.0f} s, gains (66) for Table 1 (kD = 4550, kP = 16000, kV = 5000) and kD = 31, kP = 90, kV = 90 for Table 2."
        " The column *paper* holds the paper's values (PAA_MODEL.md section 8); every other number is computed.",
        "",
        "| claim | paper | ours | verdict |",
        "|---|---|---|---|",
    ]
    cell = lambda text: str(text).replace("|", "\\|")  # noqa: E731
    lines += ["| " + " | ".join(cell(x) for x in row) + " |" for row in rows]
    lines += [
        "",
        "## Differences, stated plainly",
        "",
        f"- **Switch time.** The paper switched to LQR at about 13.38 s. Our MuJoCo run (RK4, 1 ms) first enters region (68)"
        f" at {_fmt(rk4, 3)} s; the analytic reference with continuous-time control at"
        f" {_fmt(next((r['switch_time'] for r in study if r['engine'] == 'analytic'), None), 3)} s."
        " The discretisation study below shows how much this number moves with the integrator and the time step"
        f" (from {_fmt(spread[0], 2)} s to {_fmt(spread[1], 2)} s)."
        " The robust claim, that the robot does enter the region and the LQR then balances it, holds in"
        f" {'every' if all_balanced else 'not every'} run of the study. Nothing was tuned towards 13.38 s.",
        f"- **DUU eigenvalues.** The paper gives the characteristic polynomial of the closed-loop Jacobian at DUU;"
        " its coefficients are not in our copy of the paper's summary (PAA_MODEL.md), so we can only compare the conclusion."
        f" Ours, Table 1 with gains (66): det(sI - J) coefficients (highest power first) {poly1};"
        f" eigenvalues {eig1}: {'unstable, as the paper concludes' if th1['duu_unstable'] else 'NOT unstable, unlike the paper'}."
        f" For Table 2 (gains 31, 90, 90) the rightmost pair is {eig2.split(', ')[0]}, barely unstable, which fits the"
        " Table 2 run lingering near DUU (link 1 hanging, links 2-3 up).",
        f"- **Bounds.** kD_min, eta1 and eta2 differ from the paper's rounded values by"
        f" {rel(th1['kD_min'], p1['kD_min']):.1e}, {rel(th1['eta1'], p1['eta1']):.1e} and {rel(th1['eta2'], p1['eta2']):.1e}"
        " (relative); our maxima come from a grid refined by Nelder-Mead and are checked against a 1501 x 1501 grid in the tests.",
        f"- **Table 2 and (30).** deltabar of the frozen-q3 Acrobot ranges over [{th2['deltabar_min']:.4g}, {th2['deltabar_max']:.4g}]:"
        " it reaches 0 exactly where f(z) = 1 (z = 0), so for Table 2 the frozen Acrobot loses controllability there"
        " although the 3-link robot's UDD is linearly controllable.",
        "",
        "## Discretisation study (Table 1, first switch time)",
        "",
        "| engine | integrator | time step | first switch [s] | balanced | status |",
        "|---|---|---|---|---|---|",
    ]
    for r in study:
        dt = "continuous" if r["dt"] is None else f"{r['dt'] * 1e3:g} ms"
        lines.append(f"| {r['engine']} | {r['integrator']} | {dt} | {_fmt(r['switch_time'], 3)} | {r['balanced']} | {r['status']} |")
    lines += ["", "![switch time against time step](figures/switch_time_vs_dt.png)", "", "## Figures", ""]
    for name, caption in [
        ("fig05_f54_table1.png", "Fig. 5: f(z), Table 1"), ("fig06_energy_table1.png", "Fig. 6"),
        ("fig07_angles_table1.png", "Fig. 7"), ("fig08_torques_table1.png", "Fig. 8"),
        ("fig09_angles_switch_table1.png", "Fig. 9"), ("fig10_torques_switch_table1.png", "Fig. 10"),
        ("fig11_f54_table2.png", "Fig. 11: f(z), Table 2"), ("fig12_energy_table2.png", "Fig. 12"),
        ("fig13_angles_table2.png", "Fig. 13"), ("fig14_torques_table2.png", "Fig. 14")]:
        lines += [f"![{caption}](figures/{name})", ""]
    if video_path is not None:
        lines += ["## Video", "", f"The Table 1 kip with the LQR switch: [{Path(video_path).name}]({Path(video_path).name}),"
                  " key poses: ![filmstrip](figures/filmstrip_table1.png)", ""]
    lines += ["Trajectories (NPZ, CSV, summary JSON) are in `runs/`; every number above is in `results.json`.", ""]
    return "\n".join(lines)
