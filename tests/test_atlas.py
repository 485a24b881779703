"""The atlas: a family of robots, its theory, its simulated kips."""
import json

import numpy as np
import pytest

from paa_mj.cli import main
from paa_mj.studies.atlas import scale



def run(capsys, *args):
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture(scope="module")
def atlas4():
    """The command's JSON, from its ``main`` in this process (test_json_output_of_every_command... runs atlas too)."""
    import contextlib
    import io

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(["atlas", "--robot", "example2", "--vary", "l1,m1", "--grid", "4", "--json", "--scheduler",
                     "inline"])
    assert code == 0, err.getvalue()
    return json.loads(out.getvalue())


def test_atlas_json_has_every_key(atlas4):
    assert set(atlas4) >= {"robot", "vary", "factors", "robots", "counts"}
    assert atlas4["robot"] == "example2" and atlas4["vary"] == ["l1", "m1"]
    assert len(atlas4["robots"]) == 16 and len(atlas4["factors"][0]) == 4
    np.testing.assert_allclose(atlas4["factors"][0], np.geomspace(0.25, 4, 4))
    for row in atlas4["robots"]:
        assert set(row) >= {"factors", "params", "E_r", "holds_54", "f_min", "f_max", "udd_controllable", "kD_min",
                            "eta1", "eta2", "gains"}
        assert set(row["params"]) == {"m", "l", "lc", "J"}
        assert row["gains"]["kD"] == pytest.approx(1.05 * row["kD_min"])
        assert row["gains"]["kP"] == pytest.approx(1.05 * max(row["eta1"], row["eta2"]))
    assert atlas4["counts"]["robots"] == 16
    assert 0 < atlas4["counts"]["(54) holds"] < 16  # example2 fails (54); some of its family do not


def test_scaling_rules(example2):
    p = example2.params
    longer = scale(p, "l1", 2.0)
    assert longer.l[0] == 2 * p.l[0] and longer.lc[0] == 2 * p.lc[0] and longer.J[0] == pytest.approx(4 * p.J[0])
    heavier = scale(p, "m3", 3.0)
    assert heavier.m[2] == 3 * p.m[2] and heavier.J[2] == pytest.approx(3 * p.J[2]) and heavier.l[2] == p.l[2]


@pytest.mark.parametrize("index", [0, 6, 15])  # a corner, a robot that fails (54), the far corner
def test_robots_agree_with_theory_of_the_same_robot_from_make_model(atlas4, index, tmp_path, capsys):
    row = atlas4["robots"][index]
    p = row["params"]
    path = tmp_path / "robot.xml"
    args = ["make-model", "--m", *p["m"], "--l", *p["l"], "--lc", *p["lc"], "--J", *p["J"], "--out", path]
    assert run(capsys, *args)[0] == 0
    code, out, err = run(capsys, "theory", "--robot", path, "--json", "--kD", row["gains"]["kD"], "--kP",
                         row["gains"]["kP"], "--kV", row["gains"]["kV"])
    assert code == 0, err
    theory = json.loads(out)
    for key in ("E_r", "kD_min", "eta1", "eta2"):
        assert theory[key] == pytest.approx(row[key], rel=1e-9), key
    assert theory["constraint_54"]["holds"] == row["holds_54"]
    assert theory["udd_controllable"] == row["udd_controllable"]
    for key in ("f_min", "f_max"):
        if row[key] is not None:
            assert theory["constraint_54"][key] == pytest.approx(row[key], rel=1e-9)


def test_the_base_robot_is_in_an_odd_grid(capsys):
    code, out, _ = run(capsys, "atlas", "--robot", "gymnast", "--vary", "m2,l3", "--grid", "3", "--json",
                       "--scheduler", "inline")
    assert code == 0
    summary = json.loads(out)
    base = [row for row in summary["robots"] if row["factors"] == [1.0, 1.0]]
    assert len(base) == 1
    assert base[0]["kD_min"] == pytest.approx(4503.38, abs=0.01) and base[0]["holds_54"]


# 2 s: every kip is cut short before its switch, and says so; 25 s (8 CPU-s): kips that end every way
@pytest.mark.parametrize("t_final", ["2", pytest.param("25", marks=pytest.mark.slow)])
def test_simulated_atlas_says_how_each_kip_ended(capsys, tmp_path, t_final):
    code, out, err = run(capsys, "atlas", "--robot", "gymnast", "--vary", "l1,m1", "--range", "0.9:1.1", "--grid", "2",
                         "--simulate", "--starts", "1", "--t-final", t_final, "--json", "--scheduler", "inline",
                         "--out", tmp_path)
    assert code == 0, err
    summary = json.loads(out)
    assert all(row["outcome"] in ("success", "switched, no success", "never switched, stuck at DUU",
                                  "never switched", "diverged") for row in summary["robots"])
    assert "confusion" in summary["counts"] and sum(summary["counts"]["confusion"].values()) == 4
    assert summary["findings"]
    for name in ("atlas.json", "atlas.npz", "atlas_theory.png", "atlas_theory.svg", "atlas_outcome.png"):
        assert (tmp_path / name).exists(), name


@pytest.mark.parametrize("name, grid", [("example2", 2), ("gymnast", 3)])
def test_an_atlas_says_once_how_many_of_its_robots_cannot_hold_their_balance(capsys, monkeypatch, name, grid):
    """Each robot's own gain on its own plant: the warning counts the robots whose rows say the sampled LQR (67) is
    unstable, none where every row is stable (the gymnast's family, each held on the base robot before)."""
    from paa_mj.sim.compiled import retirement

    monkeypatch.setattr(retirement, "_WARNED", set())  # as in a new command
    code, out, err = run(capsys, "atlas", "--robot", name, "--grid", str(grid), "--simulate", "--starts", "0",
                         "--t-final", "0.2", "--scheduler", "inline", "--json")
    unstable = [row for row in json.loads(out)["robots"] if not row["lqr_sampled_stable"]]
    lines = [line for line in err.splitlines() if "unstable when sampled" in line]
    assert code == 0 and len(lines) == (1 if unstable else 0)  # once for the family, not once per robot
    if unstable:
        assert f"on {len(unstable)} of the {grid * grid} robots of this atlas" in lines[0]
        assert f"(the first: {name} at the folded goal" in lines[0]
    assert name != "example2" or len(unstable) == grid * grid


@pytest.mark.parametrize("args, fragment", [
    (["--vary", "l1,l1"], "two different parameters"),
    (["--vary", "l1,q2"], "two different parameters"),
    (["--range", "4:1"], "0 < LOW < HIGH"),
    (["--range", "nan:2"], "0 < LOW < HIGH"),
    (["--starts", "3"], "--starts applies with --simulate only"),
    (["--grid", "1000"], "--grid must be an integer in [2, 256]"),
])
def test_atlas_bad_input(capsys, args, fragment):
    code, _, err = run(capsys, "atlas", *args)
    assert code == 2 and fragment in err and len(err.strip().splitlines()) == 1


def test_large_maps_are_one_image_in_their_svg(tmp_path):
    """A map of more cells than RASTER_CELLS is one image in its SVG (a 1024 x 1024 basin would otherwise write
    a path per cell: minutes and hundreds of megabytes); a smaller one keeps a path per cell."""
    from paa_mj.outputs.plots import RASTER_CELLS, cell_map, new_figure, save_figure

    for side, stem in ((int(RASTER_CELLS**0.5) + 1, "large"), (8, "small")):
        fig, ax = new_figure()
        cell_map(ax, np.arange(side), np.arange(side), np.random.default_rng(0).random((side, side)))
        save_figure(fig, tmp_path, stem)
    large, small = ((tmp_path / f"{stem}.svg").read_text() for stem in ("large", "small"))
    assert large.count("<image") == 1 and large.count("<path") < 100
    assert small.count("<image") == 0 and small.count("<path") >= 64
