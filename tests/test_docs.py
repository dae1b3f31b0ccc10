"""Every code example of the docs runs: the ```python blocks of README.md and docs/**/*.md, and
the `$ lidar-sig ...` lines of the ```console blocks, and the output a block shows is the real
output: what a console block shows after a command, and what a Python statement prints, which
the page shows in comments starting with ``# -> `` (at the end of the statement's lines, or on
lines of their own just after it, one per line printed). A Python statement that prints without
showing what is a failure: no printed value of the docs goes unchecked.

Each page runs in a folder of its own, laid out like the project's (data_samples/ in it,
../shared/data beside it), its blocks in the order of the page, as a reader follows it: a block
may use what an earlier block of its page wrote, never what another page wrote. A block's test
first runs the earlier blocks of its page that have not run yet, so any block can run alone and
in any order. The commands run in this process (tests/command_line.py), exactly as shown.

Shown output is compared line by line with the real output: the first line shown after a
command is the first line it prints; the lines after it are lines it prints, in that order (a
page may leave lines out). Lines starting with `lidar-sig: ` are stderr's. Timings, rates and
the package version are not compared; figures with a decimal point are compared to a relative
1e-6 (the last digits of a float depend on the CPU's floating-point kernels), whole numbers
exactly; a JSON line is compared as JSON, value by value, the same way.
"""
import ast
import contextlib
import io
import json
import math
import re
import tokenize

import pytest

from command_line import run
from conftest import DATA, ROOT

PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
BLOCK = re.compile(r"^```(python|console)\n(.*?)^```", re.S | re.M)
RTOL = 1e-6


def blocks(page):
    return [(kind, text) for kind, text in BLOCK.findall(page.read_text(encoding="utf-8"))]


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


# -- comparing shown output with real output --------------------------------------------------

NUMBER = re.compile(r"-?\d+(?:,\d{3})*(?:\.\d+)?(?:[eE][-+]?\d+)?")
UNCOMPARED = [(re.compile(r"\b\d+(?:\.\d+)? s\b"), "<seconds> s"),  # timings
              (re.compile(r"\b\d[\d,]* points/s\b"), "<rate> points/s"),
              (re.compile(r"\blidar_sig \d+\.\d+\S*?(?=[)\s]|$)"), "lidar_sig <version>")]


def same_number(real, shown):
    """Whole numbers exactly; figures with a decimal point or an exponent to RTOL."""
    if real == shown:
        return True
    if not re.search(r"[.eE]", real + shown):
        return False
    a, b = (float(x.replace(",", "")) for x in (real, shown))
    return math.isclose(a, b, rel_tol=RTOL, abs_tol=1e-12)


def same_value(real, shown):
    """JSON values: floats to RTOL, everything else exactly."""
    if isinstance(real, float) or isinstance(shown, float):
        return (isinstance(real, (int, float)) and isinstance(shown, (int, float))
                and not isinstance(real, bool) and not isinstance(shown, bool)
                and math.isclose(real, shown, rel_tol=RTOL, abs_tol=1e-12))
    if isinstance(real, dict) and isinstance(shown, dict):
        return real.keys() == shown.keys() and all(same_value(real[k], shown[k]) for k in real)
    if isinstance(real, list) and isinstance(shown, list):
        return len(real) == len(shown) and all(same_value(a, b) for a, b in zip(real, shown))
    return type(real) is type(shown) and real == shown


def same_line(real, shown):
    if shown.startswith("{"):
        try:
            return same_value(json.loads(real), json.loads(shown))
        except ValueError:  # not JSON (a Python dict as print shows it): compared as text below
            pass
    for pattern, mask in UNCOMPARED:
        real, shown = pattern.sub(mask, real), pattern.sub(mask, shown)
    return (NUMBER.sub("#", real) == NUMBER.sub("#", shown)
            and all(same_number(a, b) for a, b in zip(NUMBER.findall(real), NUMBER.findall(shown))))


def assert_shows(real, shown, command, stream):
    """``shown`` lines are lines of ``real``, in order, the first of them the first of ``real``."""
    if not shown:
        return
    real = real.splitlines()
    assert real and same_line(real[0], shown[0]), f"{command}\n{stream} starts:\n{real[:1]}\npage shows:\n{shown[0]}"
    at = 1
    for line in shown[1:]:
        while at < len(real) and not same_line(real[at], line):
            at += 1
        assert at < len(real), f"{command}\n{stream} has no line like:\n{line}\nafter its first; {stream}:\n" + \
            "\n".join(real)
        at += 1


# -- running the blocks of a page -------------------------------------------------------------

def run_console(text, folder):
    commands = [line[2:] for line in text.splitlines() if line.startswith("$ ")]
    assert commands, "a console block shows at least one command"
    for command in commands:
        args = command.split()
        assert args[0] == "lidar-sig", command
        done = run(*args[1:], cwd=folder)
        assert done.returncode == 0, f"{command}\n{done.stderr}"
        shown = text.split(f"$ {command}\n", 1)[1].split("\n$ ", 1)[0].splitlines()
        assert_shows(done.stdout, [line for line in shown if not line.startswith("lidar-sig: ")], command, "stdout")
        assert_shows(done.stderr, [line for line in shown if line.startswith("lidar-sig: ")], command, "stderr")


SHOWN = re.compile(r"#\s*->\s?(.*)$")


def shown_prints(text):
    """``(statement, shown lines)`` for each top-level statement of a Python block: the lines
    its ``# -> `` comments show it prints."""
    lines = text.splitlines()
    tree = ast.parse(text)
    out = []
    for i, node in enumerate(tree.body):
        stop = tree.body[i + 1].lineno - 1 if i + 1 < len(tree.body) else len(lines)
        shown = []
        for line in lines[node.lineno - 1:stop]:
            match = SHOWN.search(line)
            if match and (line.lstrip().startswith("#") or _in_comment(line, match.start())):
                shown.append(match.group(1).rstrip())
        out.append((node, shown))
    return out


def _in_comment(line, at):
    """Whether position ``at`` of a code line is inside its trailing comment, not in a string."""
    try:
        tokens = list(tokenize.generate_tokens(io.StringIO(line).readline))
    except (tokenize.TokenError, IndentationError):
        return False
    return any(t.type == tokenize.COMMENT and t.start[1] <= at for t in tokens)


def run_python(text, folder, name, monkeypatch):
    with monkeypatch.context() as patch:
        if "o3d.visualization.draw" in text:  # no screen here: the window is the only thing not run
            import open3d

            patch.setattr(open3d.visualization, "draw", lambda *a, **k: None)
        patch.chdir(folder)
        namespace = {"__name__": "__main__"}
        for node, shown in shown_prints(text):
            printed = io.StringIO()
            with contextlib.redirect_stdout(printed):
                exec(compile(ast.Module([node], type_ignores=[]), name, "exec"), namespace)
            real = printed.getvalue().splitlines()
            where = f"{name}, line {node.lineno}"
            assert real or not shown, f"{where} shows {shown} but prints nothing"
            assert shown or not real, f"{where} prints {real} but the page does not show it (a '# -> ' comment)"
            assert len(real) == len(shown) and all(same_line(r, s) for r, s in zip(real, shown)), \
                f"{where} prints:\n" + "\n".join(real) + "\nthe page shows:\n" + "\n".join(shown)


@pytest.fixture(scope="session")
def page_folders(tmp_path_factory):
    """Per page: its folder, laid out like the project's, and what became of each block run there."""
    folders = {}

    def folder(page):
        if page not in folders:
            top = tmp_path_factory.mktemp(page.stem)
            (top / "project").mkdir()
            (top / "project" / "data_samples").symlink_to(ROOT / "data_samples")
            if DATA.exists():
                (top / "shared").symlink_to(DATA.parent)
            folders[page] = {"folder": top / "project", "outcome": {}}
        return folders[page]
    return folder


@pytest.fixture
def run_block(page_folders, monkeypatch):
    """Run block ``i`` of ``page`` in the page's folder, after the earlier blocks of the page that
    have not run there yet (a block runs once: one that ran before a later block is not run again)."""
    def run_it(page, i):
        state = page_folders(page)
        page_blocks = blocks(page)
        for j in range(i + 1):
            if j not in state["outcome"]:
                kind, text = page_blocks[j]
                why = _needs(text)
                if why:
                    state["outcome"][j] = ("skipped", why)
                elif any(result != "passed" for result, _ in state["outcome"].values()):
                    state["outcome"][j] = ("skipped", "an earlier block of the page did not run")
                else:
                    try:
                        if kind == "console":
                            run_console(text, state["folder"])
                        else:
                            run_python(text, state["folder"], f"{page.relative_to(ROOT)} block {j}", monkeypatch)
                    except Exception as exc:
                        state["outcome"][j] = ("failed", f"{type(exc).__name__}: {exc}")
                        raise
                    state["outcome"][j] = ("passed", "")
            result, why = state["outcome"][j]
            if result == "failed":
                pytest.fail(f"block {j} of the page, which this block follows, failed: {why}" if j < i else why)
            if result == "skipped":
                pytest.skip(f"block {j} of the page, which this block follows: {why}" if j < i else why)
    return run_it


PYTHON = [(page, i) for page in PAGES for i, (kind, _) in enumerate(blocks(page)) if kind == "python"]
CONSOLE = [(page, i) for page in PAGES for i, (kind, _) in enumerate(blocks(page)) if kind == "console"]


def test_the_docs_have_examples_of_both_kinds():
    assert len(PYTHON) >= 8 and len(CONSOLE) >= 8


@pytest.mark.parametrize("page, i", CONSOLE, ids=[f"{p.relative_to(ROOT)}#{i}" for p, i in CONSOLE])
def test_console_example_runs(run_block, page, i):
    run_block(page, i)


@pytest.mark.parametrize("page, i", PYTHON, ids=[f"{p.relative_to(ROOT)}#{i}" for p, i in PYTHON])
def test_python_example_runs(run_block, page, i):
    run_block(page, i)


def test_a_python_statement_must_show_what_it_prints_and_print_what_it_shows(tmp_path, monkeypatch):
    block = 'x = 41507\nprint(x, "points")   # -> 41507 points\nfor k in (1, 2):\n    print(k / 3)\n# -> 0.3333333\n# -> 0.6666667\n'
    run_python(block, tmp_path, "page", monkeypatch)
    for wrong in (block.replace("# -> 41507 points", "# -> 41508 points"),   # a value changed
                  block.replace("   # -> 41507 points", ""),                 # printed, not shown
                  block.replace("# -> 0.6666667\n", ""),                    # a line printed, not shown
                  'x = 1   # -> 1\n',                                         # shown, not printed
                  'print("# -> 1")\n'):                                     # a string is not a comment
        with pytest.raises(AssertionError):
            run_python(wrong, tmp_path, "page", monkeypatch)


def test_shown_output_is_compared_to_the_tolerance_of_the_cpu_not_beyond():
    # the issue 16 case: the last digit of a float differs on another CPU
    assert same_line('{"fv": 0.12531354900639383, "a": {"points": 41507}}',
                     '{"fv": 0.12531354900639385, "a": {"points": 41507}}')
    assert not same_line('{"fv": 0.1253, "a": {"points": 41507}}', '{"fv": 0.1254, "a": {"points": 41507}}')
    assert not same_line('{"fv": 0.1253, "a": {"points": 41508}}', '{"fv": 0.1253, "a": {"points": 41507}}')
    assert not same_line('{"fv": 0.1253, "warnings": []}', '{"fv": 0.1253}')
    assert same_line("  delta_FV      0.1253   distance", "  delta_FV      0.1253   distance")
    assert not same_line("  delta_FV      0.1254   distance", "  delta_FV      0.1253   distance")
    assert not same_line("x: 41,508 points", "x: 41,507 points") and not same_line("k 20, 30", "k 20, 40")
    assert same_line("wrote a.laz in 0.8 s", "wrote a.laz in 1.7 s")
    assert same_line("1 process: 1.5 s, 27,986 points/s", "1 process: 1.2 s, 30,094 points/s")
    assert same_line("a.h5: archive v2 (lidar_sig 0.2.0)", "a.h5: archive v2 (lidar_sig 0.1.0)")
    assert not same_line("a.h5: archive v3 (lidar_sig 0.1.0)", "a.h5: archive v2 (lidar_sig 0.1.0)")
    assert_shows("first\nsecond\nthird\n", ["first", "third"], "cmd", "stdout")
    with pytest.raises(AssertionError):
        assert_shows("first\nsecond\nthird\n", ["second"], "cmd", "stdout")
    with pytest.raises(AssertionError):
        assert_shows("first\nsecond\nthird\n", ["first", "third", "second"], "cmd", "stdout")
