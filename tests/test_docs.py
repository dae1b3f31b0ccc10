"""Every code example of the docs runs: the ```python blocks of README.md and docs/**/*.md, and
the `$ lidar-sig ...` lines of the ```console blocks, from a folder laid out like the
project's (data_samples/ beside, ../shared/data above), page by page in one folder so that a
page can use what an earlier block wrote."""
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import DATA, ROOT

PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
BLOCK = re.compile(r"^```(python|console)\n(.*?)^```", re.S | re.M)


def blocks(page):
    return [(kind, text) for kind, text in BLOCK.findall(page.read_text(encoding="utf-8"))]


@pytest.fixture(scope="module")
def project(tmp_path_factory):
    """A folder like the project's: data_samples/ in it, shared/data beside it."""
    top = tmp_path_factory.mktemp("docs")
    (top / "project").mkdir()
    (top / "project" / "data_samples").symlink_to(ROOT / "data_samples")
    if DATA.exists():
        (top / "shared").symlink_to(DATA.parent)
    return top / "project"


def _needs(text):
    """Why a block cannot run here, or None."""
    if "../shared/data" in text and not DATA.exists():
        return f"real survey data not found at {DATA}"
    if "import open3d" in text:
        try:
            import open3d  # noqa: F401
        except ImportError:
            return "open3d is not installed (pip install -e '.[formats]')"
    return None


PYTHON = [(page, i, text) for page in PAGES for i, (kind, text) in enumerate(blocks(page)) if kind == "python"]
CONSOLE = [(page, i, text) for page in PAGES for i, (kind, text) in enumerate(blocks(page)) if kind == "console"]


def test_the_docs_have_examples_of_both_kinds():
    assert len(PYTHON) >= 8 and len(CONSOLE) >= 8


@pytest.mark.parametrize("page, i, text", CONSOLE, ids=[f"{p.relative_to(ROOT)}#{i}" for p, i, _ in CONSOLE])
def test_console_example_runs(project, page, i, text):
    commands = [line[2:] for line in text.splitlines() if line.startswith("$ ")]
    assert commands, "a console block shows at least one command"
    for command in commands:
        args = command.split()
        assert args[0] == "lidar-sig", command
        done = subprocess.run([sys.executable, "-m", "lidar_sig", *args[1:], *(["--overwrite"] if _writes(args) else [])],
                              cwd=project, capture_output=True, text=True)
        assert done.returncode == 0, f"{command}\n{done.stderr}"
        # the page shows the command's real output: its first line, timings aside
        shown = text.split(f"$ {command}\n", 1)[1].splitlines()
        if shown and not shown[0].startswith(("$ ", "lidar-sig: ")):
            first = done.stdout.splitlines()[0] if done.stdout else ""
            assert re.sub(r"\d+\.\d+ s", "", first) == re.sub(r"\d+\.\d+ s", "", shown[0]), command


def _writes(args):
    return any(a in ("-o", "--report", "--plots", "--plot") for a in args) and "--overwrite" not in args


@pytest.mark.parametrize("page, i, text", PYTHON, ids=[f"{p.relative_to(ROOT)}#{i}" for p, i, _ in PYTHON])
def test_python_example_runs(project, page, i, text, monkeypatch):
    why = _needs(text)
    if why:
        pytest.skip(why)
    if "o3d.visualization.draw" in text:  # no screen here: the window is the only thing not run
        import open3d

        monkeypatch.setattr(open3d.visualization, "draw", lambda *a, **k: None)
    monkeypatch.chdir(project)
    env = {"__name__": "__main__"}
    exec(compile(text, f"{page.name} block {i}", "exec"), env)
