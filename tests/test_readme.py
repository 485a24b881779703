"""The Python on the README and the docs pages runs as written, in order, in one fresh process per page, and prints
what the page says it prints (each ``# -> TEXT`` comment, in order)."""
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"
PAGES = [README, ROOT / "docs" / "python.md", ROOT / "docs" / "gym.md"]
#: docs/python.md runs every layer of the package in turn (16 CPU-s): under ``slow``; the README's and gym.md's code,
#: the same kind of check, stay in the quick suite.
SLOW_PAGES = {"python.md"}
SAYS = re.compile(r"#\s*->\s*(.+?)\s*$", re.M)


def blocks(page):
    return re.findall(r"```python\n(.*?)```", page.read_text(), flags=re.S)


@pytest.mark.parametrize("page", [pytest.param(page, id=page.name, marks=[pytest.mark.slow] * (page.name in SLOW_PAGES))
                                  for page in PAGES])
def test_the_python_of_a_page_runs_and_prints_what_it_says(page, tmp_path):
    code = "\n".join(blocks(page))
    if "render_trajectory" in code:
        from paa_mj.view.gl import probe

        if probe("egl") and probe("osmesa"):
            pytest.skip("no offscreen GL backend for the rendering snippet")
    script = tmp_path / "page.py"
    script.write_text(code)
    proc = subprocess.run([sys.executable, str(script)], cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    printed = iter(line.strip() for line in proc.stdout.splitlines())
    for said in SAYS.findall(code):
        assert any(line == said for line in printed), f"{page.name} says it prints {said!r}; it printed:\n{proc.stdout}"
    if "render_trajectory" in code:
        assert (tmp_path / "kip.mp4").stat().st_size > 10_000


def test_the_readme_shows_python_on_its_first_screen_and_stays_short():
    text = README.read_text()
    assert len(text.encode()) <= 12_000
    assert text.index("```python") < 3_500 and SAYS.search(blocks(README)[0])


def test_the_readme_gives_the_two_commands():
    text = README.read_text()
    assert "bash scripts/reproduce.sh" in text and "bash scripts/test.sh" in text
    assert "bash scripts/test.sh" in (ROOT / ".ci" / "run").read_text()


def test_every_page_is_in_the_docs_and_every_link_of_the_readme_exists():
    index = (ROOT / "docs" / "index.md").read_text()
    for page in (ROOT / "docs").glob("*.md"):
        if page.name != "index.md":
            assert f"\n{page.stem}\n" in index, f"docs/{page.name} is not in the toctree of docs/index.md"
    for link in re.findall(r"\]\(([^)#:]+)(?:#[^)]*)?\)", README.read_text()):
        assert (ROOT / link).exists(), link
