"""An --out folder has one owner, a study (its command, and realaigym's protocol) named in its manifest: another
study there is refused in one line, or with --fresh replaces it, its files and chunks only."""
import json

import pytest


def _files(folder):
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def _one_line(result, fragment):
    assert result.returncode == 2 and "Traceback" not in result.stderr, result.stderr
    assert fragment in result.stderr and len(result.stderr.strip().splitlines()) == 1, result.stderr


def test_realaigym_protocols_do_not_share_a_folder(run, tmp_path):
    out = tmp_path / "rg"
    assert run("realaigym", "--protocol", "performance-v2", "--controller", "spong", "--out", out).returncode == 0
    assert json.loads((out / ".paa-mj-study.json").read_text())["study"] == "realaigym --protocol performance-v2"
    before = _files(out)
    _one_line(run("realaigym", "--protocol", "global-v3", "--controller", "spong", "--out", out),
              "holds the results of 'paa-mj realaigym --protocol performance-v2': choose another --out, or give"
              " --fresh to replace them")
    assert _files(out) == before
    (out / "notes.txt").write_text("mine")  # nobody's: never removed
    replaced = run("realaigym", "--protocol", "global-v3", "--controller", "spong", "--out", out, "--fresh")
    assert replaced.returncode == 0
    assert "removed the results of 'paa-mj realaigym --protocol performance-v2'" in replaced.stderr
    assert json.loads((out / "realaigym.json").read_text())["protocol"] == "global-v3"
    assert {"global_v3.png", "notes.txt", "realaigym.json"} <= set(_files(out))
    assert (out / "notes.txt").read_text() == "mine"
    again = run("realaigym", "--protocol", "global-v3", "--controller", "spong", "--out", out)  # its own: replaced
    assert again.returncode == 0 and "removed" not in again.stderr


def test_a_study_in_another_study_s_folder_is_refused_unless_fresh(run, tmp_path, one_panel_figures):
    one_panel_figures("basin_figure", "robustness_figure")  # the folder's files are checked, not their drawing
    out = tmp_path / "s"
    basin = ["basin", "--grid", "2", "--t-final", "0.05", "--scheduler", "inline", "--out", out]
    assert run(*basin).returncode == 0
    before = _files(out)
    robustness = ["robustness", "--trials", "1", "--factors", "noise", "--t-final", "0.05", "--scheduler", "inline",
                  "--out", out]
    _one_line(run(*robustness), "holds the results of 'paa-mj basin'")
    assert _files(out) == before
    # the same command with other options is another study: its kept chunks are not removed without --fresh
    _one_line(run(*basin[:2], "3", *basin[3:]), "keeps the finished chunks of another basin study")
    assert _files(out) == before
    assert run(*robustness, "--fresh").returncode == 0
    left = set(_files(out))
    assert "robustness.npz" in left and not {"basin.npz", "basin.png"} & left
    assert not any(name.startswith(".chunks/basin-") for name in left)
