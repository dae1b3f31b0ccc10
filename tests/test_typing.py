"""Editors and type checkers see the API: the package's own hints (``py.typed``, the public names
of ``__init__.pyi``) make every Python example of the docs pass ``mypy --strict``, the extension
points (``lidar_sig/plugins/``, metrics, formats, their registry) and the jobs (``lidar_sig/jobs/``)
pass it too, and
``ls.Pipeline`` and the other public names resolve statically."""
import re
import subprocess
import sys

import pytest

from conftest import ROOT
from test_docs import PAGES, blocks

CONFIG = """[mypy]
strict = True
follow_imports = silent
warn_unused_configs = True

[mypy-open3d,open3d.*]
follow_imports = skip
ignore_missing_imports = True
"""


def _mypy(tmp_path, files):
    pytest.importorskip("mypy", reason="mypy is not installed (pip install -e '.[test]')")
    (tmp_path / "mypy.ini").write_text(CONFIG)
    return subprocess.run([sys.executable, "-m", "mypy", "--config-file", str(tmp_path / "mypy.ini"),
                           "--cache-dir", str(tmp_path / "cache"), *map(str, files)],
                          capture_output=True, text=True, cwd=tmp_path, timeout=900,
                          env={"MYPYPATH": str(ROOT), "PATH": "/usr/bin:/bin"})


def test_every_python_example_of_the_docs_type_checks_strictly(tmp_path):
    files = []
    for page in PAGES:
        code = [text for kind, text in blocks(page) if kind == "python"]
        if code:  # a page's blocks run in order, one after the other: one module
            path = tmp_path / (re.sub(r"\W", "_", str(page.relative_to(ROOT))) + ".py")
            path.write_text("\n".join(code))
            files.append(path)
    assert len(files) >= 6
    checked = _mypy(tmp_path, files)
    assert checked.returncode == 0, checked.stdout + checked.stderr


#: Jobs another engineer is rewriting (the change map at survey scale), not yet typed; that engineer
#: empties this set.
UNTYPED_JOBS_BEING_REWRITTEN: set[str] = set()


def test_the_extension_points_and_the_jobs_type_check_strictly(tmp_path):
    # a plugin author's editor knows what a descriptor, a strategy, a metric and a format
    # implement, and what a job takes
    package = ROOT / "lidar_sig"
    points = [package / "base" / "extensions.py", package / "metrics" / "_metric.py",
              package / "metrics" / "_registered.py", package / "io" / "formats.py"]  # metrics and formats
    files = sorted((package / "plugins").rglob("*.py")) + points + sorted(
        p for p in (package / "jobs").glob("*.py") if p.name not in UNTYPED_JOBS_BEING_REWRITTEN)
    assert len(files) >= 24
    checked = _mypy(tmp_path, files)
    assert checked.returncode == 0, checked.stdout + checked.stderr
    assert f"no issues found in {len(files)} source files" in checked.stdout


def test_the_public_names_resolve_statically(tmp_path):
    probe = tmp_path / "probe.py"
    probe.write_text("import lidar_sig as ls\n"
                     "reveal_type(ls.Pipeline)\nreveal_type(ls.Pipeline().run)\nreveal_type(ls.compare)\n"
                     "reveal_type(ls.Execution)\nreveal_type(ls.jobs.saliency)\nreveal_type(ls.changes)\n")
    checked = _mypy(tmp_path, [probe])
    said = checked.stdout
    revealed = [line.split("Revealed type is ", 1)[1] for line in said.splitlines() if "Revealed type is" in line]
    assert len(revealed) == 6, said
    for line, name in zip(revealed, ("lidar_sig.pipeline.flow.Pipeline", "lidar_sig.pipeline.result.Result",
                                     "lidar_sig.comparison._compared.Comparison", "lidar_sig.tiling.execution.Execution",
                                     "lidar_sig.jobs.saliency.SaliencyRun", "lidar_sig.change_map._maps.ChangeMap")):
        assert name in line, (name, line)
