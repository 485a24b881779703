"""The release: the documentation builds without warnings, the tutorial runs, the package installs."""
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


#: The API reference of the modules the full build checks by name, and a page of display maths: the small form of
#: the site, built by the site's own configuration (docs/conf.py) in the quick suite.
SMALL_SITE = {
    "index.md": "# paa_mj\n\n```{toctree}\nmodel\napi\n```\n",
    "model.md": "# The model\n\nThe energy (9):\n\n$$\nE_r = m g l\n$$\n",
    "api.rst": "API reference\n=============\n\n" + "".join(
        f".. automodule:: {name}\n" for name in ("paa_mj.control.energy", "paa_mj.sim.batch", "paa_mj.studies.atlas",
                                                  "paa_mj.control.tvlqr")),
}


def _build(source, out, monkeypatch):
    """sphinx-build -W in this process (the package's modules, which autodoc imports, are loaded already)."""
    pytest.importorskip("sphinx")
    from sphinx.cmd.build import build_main

    monkeypatch.setattr(sys, "path", list(sys.path))  # conf.py puts the checkout first: for this build only
    return build_main(["-W", "--keep-going", "-q", "-b", "html", str(source), str(out)])


def _api_and_maths_rendered(out):
    model = (out / "model.html").read_text()
    assert "math notranslate" in model  # the equations are rendered by MathJax, not shown as text
    api = (out / "api.html").read_text()
    for name in ("paa_mj.control.energy.EnergyVCLController", "paa_mj.sim.batch.simulate_batch",
                 "paa_mj.studies.atlas.atlas", "paa_mj.control.tvlqr.TVLQRController"):
        assert f'id="{name}"' in api, name


def test_a_small_site_builds_without_warnings_by_the_site_s_configuration(tmp_path, monkeypatch):
    """The quick form of the next test: four modules' docstrings and a page of maths, by docs/conf.py."""
    source = tmp_path / "source"
    source.mkdir()
    (source / "conf.py").write_text((ROOT / "docs" / "conf.py").read_text())
    for name, text in SMALL_SITE.items():
        (source / name).write_text(text)
    code = _build(source, tmp_path / "html", monkeypatch)
    assert code == 0, "sphinx-build failed (its warnings are above, in the captured stderr)"
    _api_and_maths_rendered(tmp_path / "html")


@pytest.mark.slow
def test_docs_build_without_warnings(tmp_path, monkeypatch):
    """The whole site (about 40 CPU-s)."""
    code = _build(ROOT / "docs", tmp_path, monkeypatch)
    assert code == 0, "sphinx-build failed (its warnings are above, in the captured stderr)"
    _api_and_maths_rendered(tmp_path)
    assert (tmp_path / "tutorial.html").exists()


def _texts_and_images(notebook):
    """Per code cell: its text output (the cross-check's 1e-15-level numbers left out) and its number of images."""
    cells = [cell for cell in notebook.cells if cell.cell_type == "code"]
    texts = ["".join(line for line in "".join(o.get("text", "") for o in cell.get("outputs", [])).splitlines(True)
                     if not line.startswith("CrossCheck(")) for cell in cells]
    images = [sum("image/png" in o.get("data", {}) for o in cell.get("outputs", [])) for cell in cells]
    return texts, images


def test_the_tutorial_is_a_valid_notebook_stored_with_its_outputs():
    """The quick form of the next test: valid, every code cell run in order, its figures each shown once."""
    nbformat = pytest.importorskip("nbformat")
    stored = nbformat.read(ROOT / "docs" / "tutorial.ipynb", as_version=4)
    nbformat.validate(stored)
    cells = [cell for cell in stored.cells if cell.cell_type == "code"]
    assert [cell.execution_count for cell in cells] == list(range(1, len(cells) + 1))
    texts, images = _texts_and_images(stored)
    assert "balanced: True" in "".join(texts) and "switch to the LQR at 17.986" in "".join(texts)
    assert sum(images) >= 3 and max(images) == 1


@pytest.mark.slow
def test_the_tutorial_notebook_runs_and_is_stored_with_its_outputs(tmp_path):
    """Run afresh, the tutorial prints what it holds, and shows each of its figures once (about 25 CPU-s)."""
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    stored = nbformat.read(ROOT / "docs" / "tutorial.ipynb", as_version=4)
    notebook = nbformat.read(ROOT / "docs" / "tutorial.ipynb", as_version=4)
    client = nbclient.NotebookClient(notebook, timeout=600, kernel_name="python3",
                                     resources={"metadata": {"path": str(tmp_path)}})
    client.execute()
    texts, images = _texts_and_images(notebook)
    assert "balanced: True" in "".join(texts) and "switch to the LQR at 17.986" in "".join(texts)
    assert sum(images) >= 3 and max(images) == 1  # angles, torques, basin: each once
    stored_texts, stored_images = _texts_and_images(stored)
    assert (stored_texts, stored_images) == (texts, images), \
        "docs/tutorial.ipynb is stale: execute it again and store it with its outputs"


@pytest.mark.slow  # pip wheel, pip install and two processes: about 7 CPU-s
def test_a_wheel_builds_without_deprecation_and_runs_from_elsewhere(tmp_path):
    wheels = tmp_path / "wheels"
    proc = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-w", str(wheels),
                           str(ROOT)], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "deprecat" not in (proc.stdout + proc.stderr).lower()
    wheel = next(wheels.glob("paa_mj-*.whl"))
    target = tmp_path / "site"
    proc = subprocess.run([sys.executable, "-m", "pip", "install", "--no-deps", "--target", str(target), str(wheel)],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    env = dict(os.environ, PYTHONPATH=str(target))
    from paa_mj import __version__

    version = subprocess.run([sys.executable, "-m", "paa_mj.cli", "--version"], capture_output=True, text=True,
                             cwd=elsewhere, env=env, timeout=300)
    assert version.returncode == 0 and version.stdout.strip() == f"paa-mj {__version__}"
    # check loads the installed robot files and MuJoCo; for the gymnast (the paper's closed forms) it compiles no
    # kernels (a fresh copy of the package compiles its own: the chain's would cost 2 CPU-s, all of them 35)
    check = subprocess.run([sys.executable, "-c", "import paa_mj, sys; print(paa_mj.__file__);"
                            " from paa_mj.cli import main; sys.exit(main(['check', '--robot', 'gymnast',"
                            " '--samples', '10']))"], capture_output=True, text=True, cwd=elsewhere, env=env,
                           timeout=300)
    assert check.returncode == 0, check.stderr[-2000:]
    assert check.stdout.splitlines()[0].startswith(str(target))  # the installed copy, not the checkout
    assert "robot gymnast" in check.stdout and float(check.stdout.split("max_rel_err_qacc")[1].split()[0]) < 1e-9


def test_the_citation_and_the_changelog_name_this_version():
    """CITATION.cff's version and the CHANGELOG's newest entry are the package's (CITATION.cff had stayed two
    versions behind)."""
    import re

    from paa_mj import __version__

    root = Path(__file__).resolve().parents[1]
    citation = re.search(r'^version: "([^"]+)"', (root / "CITATION.cff").read_text(), re.M)
    newest = re.search(r"^## (\S+)", (root / "CHANGELOG.md").read_text(), re.M)
    assert citation and citation.group(1) == __version__
    assert newest and newest.group(1) == __version__
