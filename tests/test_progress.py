"""Progress and logging of long steps: bars on a terminal, plain lines a program can parse off a
terminal, LIDAR_SIG_PROGRESS to choose, silent with --quiet, --verbose timings of every step (what
a run loads: tests/test_startup.py). tests/conftest.py sets LIDAR_SIG_PROGRESS=none for the
other tests; these set or unset it themselves."""
import os
import re
import subprocess
import sys

import pytest

from command_line import run, run_process
from conftest import ROOT, SAMPLES

EPOCH2 = SAMPLES / "epoch2.laz"
STEPS = ("reading epoch2.laz", "neighbourhoods", "saliency (c3dcm multiscale)")


def _steps(stderr):
    return [line for line in stderr.splitlines() if line.startswith("lidar-sig: ")]


def test_verbose_logs_every_step_with_its_parameters_and_timing(tmp_path):
    done = run("saliency", EPOCH2, "-o", "out.laz", "--verbose", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    lines = _steps(done.stderr)
    for name in STEPS + ("writing out.laz",):
        assert any(line.startswith(f"lidar-sig: {name}: ") and " s" in line for line in lines), (name, lines)
    assert any("points 31,354" in line for line in lines)  # facts of the step, not only its time
    assert any("scales k 20, 30, 40" in line for line in lines)
    # the points alone are written: no signature is made
    assert not any(line.startswith("lidar-sig: signature") for line in lines), lines
    done = run("signature", EPOCH2, "-o", "out.h5", "--verbose", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    lines = _steps(done.stderr)
    for name in STEPS + ("signature", "writing out.h5"):
        assert any(line.startswith(f"lidar-sig: {name}: ") and " s" in line for line in lines), (name, lines)


def test_with_progress_none_or_quiet_nothing_but_results(tmp_path):
    done = run_process("saliency", EPOCH2, "-o", "a.laz", cwd=tmp_path)  # LIDAR_SIG_PROGRESS=none
    assert done.returncode == 0 and done.stderr == ""
    done = run("compare", EPOCH2, EPOCH2, "--quiet", "--report", "r.html", cwd=tmp_path)
    assert done.returncode == 0 and done.stderr == ""
    assert "wrote" not in done.stdout


def _on_a_terminal(args, cwd, setting=None):
    """stderr of the command run with stderr on a pseudo-terminal of 120 columns, with
    LIDAR_SIG_PROGRESS set to ``setting`` (None: unset)."""
    import fcntl
    import pty
    import struct
    import termios

    master, slave = pty.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 40, 120, 0, 0))
    proc = subprocess.Popen([sys.executable, "-m", "lidar_sig", *map(str, args)], cwd=cwd, stdin=subprocess.DEVNULL,
                            stdout=subprocess.DEVNULL, stderr=slave, env=_environment(setting))
    os.close(slave)
    out = b""
    while True:
        try:
            chunk = os.read(master, 65536)
        except OSError:  # the terminal closed with the process
            break
        if not chunk:
            break
        out += chunk
    os.close(master)
    proc.wait(timeout=120)
    return proc.returncode, out.decode(errors="replace")


def _environment(setting):
    env = dict(os.environ)
    env.pop("LIDAR_SIG_PROGRESS", None)
    if setting is not None:
        env["LIDAR_SIG_PROGRESS"] = setting
    return env


@pytest.mark.skipif(sys.platform == "win32", reason="pseudo-terminals are POSIX")
def test_on_a_terminal_the_saliency_loop_shows_a_bar_and_quiet_silences_it(tmp_path):
    code, shown = _on_a_terminal(["saliency", EPOCH2, "-o", "a.laz"], tmp_path)
    assert code == 0
    assert re.search(r"saliency \(c3dcm multiscale\): +\d+%\|.*\| \d+/\d+ .*block", shown), shown
    code, shown = _on_a_terminal(["saliency", EPOCH2, "-o", "b.laz", "--quiet"], tmp_path)
    assert code == 0 and shown == ""


def test_a_step_shows_its_elapsed_time_after_a_delay_and_logs_when_done(capsys, caplog):
    import time

    from lidar_sig.base import progress

    with caplog.at_level("INFO", logger="lidar_sig"):
        with progress.step("quick", enabled=True):
            pass
        with progress.step("slow", enabled=True, cells=12) as s:
            time.sleep(progress.STEP_DELAY + 2 * progress.REFRESH)
            s.note(points=1234)
    err = capsys.readouterr().err
    assert "quick" not in err and "slow: 00:01" in err
    assert [r.getMessage().split(":")[0] for r in caplog.records] == ["quick", "slow"]
    assert "(cells 12, points 1,234)" in caplog.records[1].getMessage()


def test_a_note_during_a_shown_step_gets_a_line_of_its_own(monkeypatch, capsys):
    # a note printed while a step's line shows used to be glued to that line
    import time

    from lidar_sig.cli.group import show_note as _note
    from lidar_sig.base.errors import LidarSigWarning
    from lidar_sig.base.progress import step

    monkeypatch.setattr("lidar_sig.base.progress.STEP_DELAY", 0.0)
    with step("working", enabled=True):
        time.sleep(0.1)
        _note("something to know", LidarSigWarning, __file__, 1)
    err = capsys.readouterr().err
    lines = [part for line in err.split("\n") for part in line.split("\r")]
    assert "lidar-sig: note: something to know" in lines  # the whole line, nothing glued to it


# -- progress lines a program can parse ---------------------------------------------------------

LINE = re.compile(r"^lidar-sig: progress: (?P<stage>(?:(?!: ).)+): (?P<percent>\d{1,3})%$")


def _stages(stderr):
    """{stage: [percents in order]} of the progress lines; every line of ``stderr`` must be one."""
    stages = {}
    for line in stderr.splitlines():
        found = LINE.match(line)
        assert found, f"not a progress line: {line!r}"
        stages.setdefault(found["stage"], []).append(int(found["percent"]))
    return stages


def _complete(percents):
    return percents[0] == 0 and percents[-1] == 100 and percents == sorted(percents) \
        and len(set(percents)) == len(percents)


def test_off_a_terminal_progress_comes_as_lines_of_every_stage_as_the_docs_show(tmp_path):
    done = subprocess.run([sys.executable, "-m", "lidar_sig", "saliency", str(EPOCH2), "-o", "epoch2_sal.laz"],
                          cwd=tmp_path, capture_output=True, text=True, env=_environment(None),
                          stdin=subprocess.DEVNULL, timeout=600)
    assert done.returncode == 0, done.stderr
    stages = _stages(done.stderr)
    assert list(stages) == ["reading epoch2.laz", "neighbourhoods", "saliency (c3dcm multiscale)",
                            "writing epoch2_sal.laz"]
    assert all(_complete(p) for p in stages.values()), stages
    shown = (ROOT / "docs" / "scripting.md").read_text().split("```text\n", 1)[1].split("```", 1)[0]
    assert done.stderr == shown  # the page's example is this run's stderr
    done = subprocess.run([sys.executable, "-m", "lidar_sig", "saliency", str(EPOCH2), "-o", "b.laz", "--quiet"],
                          cwd=tmp_path, capture_output=True, text=True, env=_environment("lines"),
                          stdin=subprocess.DEVNULL, timeout=600)
    assert done.returncode == 0 and done.stderr == ""  # --quiet silences even the lines asked for


def test_lines_on_a_terminal_when_asked_and_nothing_with_none(tmp_path):
    code, shown = _on_a_terminal(["saliency", EPOCH2, "-o", "a.laz"], tmp_path, setting="lines")
    assert code == 0
    stages = _stages(shown.replace("\r\n", "\n"))
    assert "saliency (c3dcm multiscale)" in stages
    code, shown = _on_a_terminal(["saliency", EPOCH2, "-o", "b.laz"], tmp_path, setting="none")
    assert code == 0 and shown == ""


def test_bars_off_a_terminal_when_asked(tmp_path):
    done = subprocess.run([sys.executable, "-m", "lidar_sig", "saliency", str(EPOCH2), "-o", "a.laz"], cwd=tmp_path,
                          capture_output=True, text=True, env=_environment("bars"), stdin=subprocess.DEVNULL,
                          timeout=600)
    assert done.returncode == 0
    assert "lidar-sig: progress:" not in done.stderr and re.search(r"saliency \(c3dcm multiscale\): +\d+%\|",
                                                                      done.stderr), done.stderr


def test_a_loop_with_a_count_says_each_whole_percent_once(monkeypatch, capsys):
    from lidar_sig.base import progress

    monkeypatch.setenv("LIDAR_SIG_PROGRESS", "lines")
    assert list(progress.progress(range(250), desc="cells: of the map")) == list(range(250))
    with progress.step("tiles") as s:
        assert sum(1 for _ in s.track(range(3))) == 3
    with pytest.raises(RuntimeError), progress.step("failing"):
        raise RuntimeError("stopped")
    stages = _stages(capsys.readouterr().err)
    assert stages == {"cells - of the map": list(range(101)), "tiles": [0, 33, 66, 100], "failing": [0]}


def test_a_change_map_says_its_cells_and_levels_in_lines(monkeypatch, tmp_path):
    monkeypatch.setenv("LIDAR_SIG_PROGRESS", "lines")
    done = run("changes", SAMPLES / "epoch1.laz", SAMPLES / "epoch2_aligned.laz", "--top", "1", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    stages = _stages(done.stderr)
    for stage in ("reading epoch1.laz", "reading epoch2_aligned.laz", "cell metrics", "level of detection"):
        assert _complete(stages[stage]), (stage, stages)
    assert len(stages["cell metrics"]) > 3  # the cells (or their parts) counted, not only begun and ended


def test_a_bad_progress_setting_is_refused_in_one_line(monkeypatch, tmp_path):
    monkeypatch.setenv("LIDAR_SIG_PROGRESS", "loud")
    done = run("saliency", EPOCH2, "-o", "a.laz", cwd=tmp_path)
    assert done.returncode == 2 and not (tmp_path / "a.laz").exists()
    assert done.stderr == ("lidar-sig: error: the environment variable LIDAR_SIG_PROGRESS='loud' is not a progress "
                           "setting; set it to auto, lines, bars or none, or unset it\n")
