"""Other packages extend lidar_sig through entry points (docs/extending.md): the example
distribution kept in tests/extension_example, installed by pip as a user installs a plugin, adds
a descriptor, a strategy, a metric, a format and a command, and each works where lidar_sig's own
do; a plugin that fails ends the run in one line naming it and its package, exit status 2. And
the page shows the example as it is."""
import json
import os
import re
import shutil
import subprocess
import sys

import laspy
import numpy as np
import pytest

import lidar_sig as ls
from conftest import ROOT, SAMPLES

EXAMPLE = ROOT / "tests" / "extension_example"
PAGE = ROOT / "docs" / "extending.md"
EPOCH1, EPOCH2 = SAMPLES / "epoch1.laz", SAMPLES / "epoch2.laz"
PACKAGE = "lidar-sig-example"


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    """The example distribution installed by pip into a folder of its own (a copy of its source
    is built, so that the repository gets no build files)."""
    top = tmp_path_factory.mktemp("extension")
    shutil.copytree(EXAMPLE, top / "source")
    done = subprocess.run([sys.executable, "-m", "pip", "install", "--no-deps", "--no-build-isolation", "--quiet",
                           "--target", str(top / "site"), str(top / "source")],
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stdout + done.stderr
    return top / "site"


def lidar_sig(site, *args, cwd=None):
    """`lidar-sig ARGS` in a child process that sees the packages installed in ``site``."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(str(p) for p in (site, ROOT) if p))
    return subprocess.run([sys.executable, "-m", "lidar_sig", *map(str, args)], capture_output=True, text=True,
                          env=env, cwd=cwd, timeout=900, stdin=subprocess.DEVNULL)


def one_line_naming(done, *words):
    """A run that ended in one error line naming each of ``words``, exit status 2, no traceback."""
    lines = [ln for ln in done.stderr.splitlines() if not ln.startswith("lidar-sig: progress:")]
    return (done.returncode == 2 and len(lines) == 1 and lines[0].startswith("lidar-sig: error: ")
            and all(w in lines[0] for w in words)), done.stderr


def test_plugins_lists_each_kind_of_the_example_with_its_package(site):
    done = lidar_sig(site, "plugins", "--json")
    assert done.returncode == 0, done.stderr
    found = json.loads(done.stdout)
    for title, name in (("descriptors", "plain-covariance"), ("strategies", "largest"), ("metrics", "hellinger"),
                        ("formats", "npz"), ("commands", "extent")):
        assert found[title][name]["package"] == PACKAGE, (title, found[title])
        assert found[title][next(iter(found[title]))]["package"] == "lidar_sig"  # lidar_sig's own first
    assert found["metrics"]["hellinger"]["name"] == "d_Hellinger" and found["metrics"]["hellinger"]["needs_labels"]
    assert found["formats"]["npz"]["extensions"] == [".npz"] and found["formats"]["npz"]["reads"]
    assert found["commands"]["extent"]["summary"] == "Print a point cloud's number of points and its extent."
    text = lidar_sig(site, "plugins")
    assert text.returncode == 0
    shown = re.search(r"^```text\n(.*?)^```", PAGE.read_text(encoding="utf-8"), re.S | re.M).group(1).splitlines()
    assert len(shown) == 10 and set(shown) <= set(text.stdout.splitlines())  # the page shows what it prints


def test_compare_prints_the_new_metric(site):
    done = lidar_sig(site, "compare", EPOCH1, EPOCH2, "-q")
    assert done.returncode == 0, done.stderr
    line = next(ln for ln in done.stdout.splitlines() if "d_Hellinger" in ln)
    shown = float(line.split()[1])
    # the Hellinger distance of the class shares, from the Bhattacharyya coefficient this time
    p, q = (ls.Pipeline(progress=False).run(e).signature.class_totals.astype(float) for e in (EPOCH1, EPOCH2))
    expected = np.sqrt(1.0 - np.sum(np.sqrt(p / p.sum() * q / q.sum())))
    assert shown == pytest.approx(expected, abs=1e-4)
    assert "L1" in done.stdout.split("d_Hellinger")[0]  # after lidar_sig's own


def test_the_new_format_writes_and_reads_with_the_new_descriptor_and_strategy(site, tmp_path):
    out = tmp_path / "epoch1.npz"
    done = lidar_sig(site, "saliency", EPOCH1, "-o", out, "--descriptor", "plain-covariance", "--strategy", "largest",
                     "--weights", "none", "-q")
    assert done.returncode == 0, done.stderr
    las = laspy.read(EPOCH1)
    with np.load(out) as written:
        np.testing.assert_allclose(written["x"], las.x)
        np.testing.assert_array_equal(written["classification"], las.classification)
        cl, cs, cp = written["Cl"], written["Cs"], written["Cp"]
    # the example's descriptor is the covariance tensor with neighbours counted alike, and its
    # strategy the largest scale: C3DCM at k = 40 without weights, computed here in this process
    expected = ls.Pipeline("c3dcm", "multiscale", ls.knn(40), weights="none", progress=False).run(EPOCH1).saliency
    np.testing.assert_allclose(np.column_stack([cl, cs, cp]), expected.values, atol=1e-6)
    again = tmp_path / "again.laz"  # read by the example's reader, written as LAS
    done = lidar_sig(site, "saliency", out, "-o", again, "--descriptor", "plain-covariance", "--strategy", "largest",
                     "--weights", "none", "-q")
    assert done.returncode == 0, done.stderr
    np.testing.assert_allclose(np.asarray(laspy.read(again)["Cl"]), cl, atol=1e-6)
    shown = lidar_sig(site, "extent", out)  # the new command reads the new format
    assert shown.returncode == 0 and shown.stdout.splitlines()[0] == f"{out}: {len(las.x):,} points", shown.stderr


def test_the_new_command_runs(site, tmp_path):
    done = lidar_sig(site, "extent", EPOCH1)
    assert done.returncode == 0, done.stderr
    las = laspy.read(EPOCH1)
    assert done.stdout.splitlines()[0] == f"{EPOCH1}: {len(las.x):,} points"
    assert done.stdout.splitlines()[1] == f"  x from {las.x.min():.2f} to {las.x.max():.2f}"
    help_ = lidar_sig(site, "--help")
    assert help_.returncode == 0 and re.search(r"^  extent +Print a point cloud", help_.stdout, re.M)
    assert one_line_naming(lidar_sig(site, "extent", tmp_path / "missing.npz"), "missing.npz", "no such file")[0]


BROKEN = '''
import click
import numpy as np
from lidar_sig.io.formats import POINTS, Format
from lidar_sig.metrics import Metric

WORDS = Metric("words", "d_Words", "any", 0.0, True, "a metric that returns a text", "nothing",
               of=lambda a, b: "far apart")


def unreadable(path):
    raise ValueError("the file is not what this reader expected")


def never(path, cloud, fields, *, overwrite=False):
    raise RuntimeError("not written")


BAD = Format("Bad", (".bad",), (POINTS,), reader=unreadable, writer=never)
NOT_A_COMMAND = "a text, not a click command"
NAN = Metric("nan", "d_NaN", "any", 0.0, True, "a metric that returns NaN", "nothing", of=lambda a, b: float("nan"))
INF = Metric("inf", "d_Inf", "any", 0.0, True, "a metric that returns inf", "nothing", of=lambda a, b: np.inf)


@click.command()
def boom():
    """A command that fails."""
    raise RuntimeError("the command's own failure")
'''


def broken_distribution(folder, group, line):
    """A distribution ``lidar-sig-broken`` in ``folder`` declaring ``line`` in entry-point ``group``."""
    (folder / "lidar_sig_broken.py").write_text(BROKEN)
    info = folder / "lidar_sig_broken-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: lidar-sig-broken\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(f"[{group}]\n{line}\n")
    return folder


def test_an_entry_point_that_fails_to_load_is_one_line_naming_it(tmp_path):
    site = broken_distribution(tmp_path, "lidar_sig.metrics", "gone = lidar_sig_broken_missing:GONE")
    ok, said = one_line_naming(lidar_sig(site, "plugins"), "metric 'gone' of lidar-sig-broken", "cannot be loaded",
                               "ModuleNotFoundError", "pip uninstall lidar-sig-broken")
    assert ok, said
    ok, said = one_line_naming(lidar_sig(site, "compare", EPOCH1, EPOCH2), "metric 'gone' of lidar-sig-broken")
    assert ok, said


def test_a_metric_that_returns_no_number_is_one_line_naming_it(tmp_path):
    site = broken_distribution(tmp_path, "lidar_sig.metrics", "words = lidar_sig_broken:WORDS")
    ok, said = one_line_naming(lidar_sig(site, "compare", EPOCH1, EPOCH2, "-q"), "metric 'words' of lidar-sig-broken",
                               "returned a str, not a number")
    assert ok, said


def test_a_format_whose_reader_raises_is_one_line_naming_it(tmp_path):
    (tmp_path / "site").mkdir()
    site = broken_distribution(tmp_path / "site", "lidar_sig.formats", "bad = lidar_sig_broken:BAD")
    data = tmp_path / "cloud.bad"
    data.write_text("anything")
    ok, said = one_line_naming(lidar_sig(site, "info", data), "format 'bad' of lidar-sig-broken",
                               "failed reading cloud.bad", "ValueError: the file is not what this reader expected")
    assert ok, said
    out = tmp_path / "out.bad"
    ok, said = one_line_naming(lidar_sig(site, "saliency", EPOCH1, "-o", out, "-q"), "format 'bad' of lidar-sig-broken",
                               "RuntimeError: not written")
    assert ok, said
    assert not out.exists()


def notes(done):
    return [ln for ln in done.stderr.splitlines() if ln.startswith("lidar-sig: note: ")]


def assert_help_lists_the_others_with_one_note(site, *words):
    for help_ in (["--help"], []):  # the list of commands, asked for or shown for no command
        done = lidar_sig(site, *help_)
        assert done.returncode in (0, 2) and "Traceback" not in done.stderr, done.stderr  # click: 2 for no command
        assert re.search(r"^  saliency +", done.stdout + done.stderr, re.M), done.stdout + done.stderr
        said = notes(done)
        assert len(said) == 1 and all(w in said[0] for w in words), done.stderr


def test_a_command_that_is_not_one_is_one_line_naming_it_and_the_others_run(tmp_path):
    site = broken_distribution(tmp_path, "lidar_sig.commands", "odd = lidar_sig_broken:NOT_A_COMMAND")
    ok, said = one_line_naming(lidar_sig(site, "odd"), "command 'odd' of lidar-sig-broken", "not a click command")
    assert ok, said
    assert_help_lists_the_others_with_one_note(site, "command 'odd' of lidar-sig-broken")
    assert lidar_sig(site, "saliency", "--help").returncode == 0  # the other commands are not loaded
    listed = lidar_sig(site, "plugins")
    assert listed.returncode == 0 and "lidar-sig-broken" in listed.stdout, listed.stderr


def test_a_command_that_cannot_be_loaded_leaves_the_others_and_the_help(tmp_path):
    site = broken_distribution(tmp_path, "lidar_sig.commands", "gone = lidar_sig_broken_missing:GONE")
    assert_help_lists_the_others_with_one_note(site, "command 'gone' of lidar-sig-broken", "cannot be loaded")
    ok, said = one_line_naming(lidar_sig(site, "gone"), "command 'gone' of lidar-sig-broken", "ModuleNotFoundError")
    assert ok, said
    shown = lidar_sig(site, "info", EPOCH1)
    assert shown.returncode == 0 and shown.stderr == "", shown.stderr


def test_a_command_named_like_a_built_in_leaves_every_command_and_the_help_with_a_note(tmp_path):
    site = broken_distribution(tmp_path, "lidar_sig.commands", "info = lidar_sig_broken:boom")
    assert_help_lists_the_others_with_one_note(site, "command 'info' of lidar-sig-broken", "rename")
    shown = lidar_sig(site, "info", EPOCH1)  # lidar_sig's own, with the note
    assert shown.returncode == 0 and f"{EPOCH1}:" in shown.stdout, shown.stderr
    assert len(notes(shown)) == 1 and "lidar-sig-broken" in notes(shown)[0]
    assert lidar_sig(site, "plugins").returncode == 0


def test_a_plugin_command_that_raises_is_one_line_naming_its_package(tmp_path):
    site = broken_distribution(tmp_path, "lidar_sig.commands", "boom = lidar_sig_broken:boom")
    ok, said = one_line_naming(lidar_sig(site, "boom"), "command 'boom' of lidar-sig-broken",
                               "RuntimeError: the command's own failure", "pip uninstall lidar-sig-broken")
    assert ok, said


@pytest.mark.parametrize("group, line, ask", [
    ("lidar_sig.commands", "quits = lidar_sig_quits:anything", ["quits"]),
    ("lidar_sig.metrics", "quits = lidar_sig_quits:anything", ["compare", EPOCH1, EPOCH2, "-q"]),
])
def test_a_plugin_that_calls_sys_exit_at_import_is_one_line_naming_it(tmp_path, group, line, ask):
    site = broken_distribution(tmp_path, group, line)
    (site / "lidar_sig_quits.py").write_text("import sys\nsys.exit(3)\n")
    ok, said = one_line_naming(lidar_sig(site, *ask), "'quits' of lidar-sig-broken", "SystemExit: 3")
    assert ok, said


@pytest.mark.parametrize("name, shown", [("nan", "nan"), ("inf", "inf")])
def test_a_metric_returning_nan_or_inf_is_one_line_naming_it_and_no_json_is_printed(tmp_path, name, shown):
    site = broken_distribution(tmp_path, "lidar_sig.metrics", f"{name} = lidar_sig_broken:{name.upper()}")
    done = lidar_sig(site, "compare", EPOCH1, EPOCH2, "-q", "--json")
    ok, said = one_line_naming(done, f"metric '{name}' of lidar-sig-broken", f"returned {shown}, not a finite number")
    assert ok, said
    assert done.stdout == ""  # no JSON with NaN in it, no ranking by it


def test_the_page_shows_the_example_as_it_is():
    # the page's Python block is the example's module (tests/test_docs.py runs it, tests/test_typing.py
    # checks it with mypy --strict), its TOML block the example's pyproject.toml
    text = PAGE.read_text(encoding="utf-8")
    assert re.findall(r"^```python\n(.*?)^```", text, re.S | re.M) == [
        (EXAMPLE / "lidar_sig_example.py").read_text(encoding="utf-8")]
    toml = re.findall(r"^```toml\n(.*?)^```", text, re.S | re.M)
    assert toml == [(EXAMPLE / "pyproject.toml").read_text(encoding="utf-8")]
