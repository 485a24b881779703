"""Readable text tables of the theory report."""
from __future__ import annotations


def _yes(flag):
    return "yes" if flag else "NO"


def theory_table(name, r) -> str:
    """A plain-text table of :class:`~paa_mj.theory.TheoryReport` (as a dict)."""
    c54 = r["constraint_54"]
    g = r["gains"]
    lines = [
        f"Theory of Liu & Xin (2015) for robot {name}",
        f"  b1, b2, b3 (4)             {r['beta'][0]:.4f}  {r['beta'][1]:.4f}  {r['beta'][2]:.4f}  J",
        f"  E_r = b1 - b2 - b3 (9)     {r['E_r']:.4f} J   {'> 0' if r['E_r'] > 0 else '<= 0: the method does not apply'}",
        f"  kD_min (41)                {r['kD_min']:.6g}   at (q2, q3) = ({r['kD_min_at'][0]:.4f}, {r['kD_min_at'][1]:.4f})",
        f"  eta1 (59)                  {r['eta1']:.6g}   at (y, z) = ({r['eta1_at'][0]:.4f}, {r['eta1_at'][1]:.4f})",
        f"  eta2 (60)                  {r['eta2']:.6g}   at z = {r['eta2_at']:.4f}",
        f"  constraint (54)            {'holds' if c54['holds'] else 'FAILS'}: f in [{c54['f_min']:.6g}, {c54['f_max']:.6g}],"
        f" closest to 1 at z = {c54['z_closest']:.4f} (|f - 1| = {c54['closest_to_one']:.3g})",
        f"  frozen Acrobot (30)        deltabar in [{r['deltabar_min']:.6g}, {r['deltabar_max']:.6g}]:"
        f" up-down controllable for every z: {_yes(r['frozen_acrobot_ud_controllable'])}",
        f"  UDD linearly controllable  {_yes(r['udd_controllable'])} (rank {r['udd_controllability']['rank']},"
        f" PBH margin {r['udd_controllability']['pbh_min']:.3g})",
        f"  LQR gain K (67)            Q = 1e4 I6, R = I2",
    ]
    for row in r["lqr_K"]:
        lines.append("      [" + "  ".join(f"{v:10.3f}" for v in row) + " ]")
    lines.append(f"  gains                      kD = {g['kD']:g}, kP = {g['kP']:g}, kV = {g['kV']:g}")
    lines.append(f"  DUU closed-loop eigenvalues ({'unstable' if r['duu_unstable'] else 'NOT unstable'}):")
    for re, im in r["duu_eigenvalues"]:
        lines.append(f"      {re:+.6f} {im:+.6f}j")
    lines.append("  Theorem 1 conditions:")
    for cond, ok in r["theorem1"].items():
        lines.append(f"      {cond:<22} {_yes(ok)}")
    return "\n".join(lines)
