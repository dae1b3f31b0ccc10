"""Progress and logging of long steps: bars on a terminal only, silent with --quiet or off a
terminal, --verbose timings of every step (what a run loads: tests/test_startup.py)."""
import os
import re
import subprocess
import sys

import pytest

from command_line import run, run_process
from conftest import SAMPLES

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


def test_off_a_terminal_or_quiet_nothing_but_results(tmp_path):
    done = run_process("saliency", EPOCH2, "-o", "a.laz", cwd=tmp_path)
    assert done.returncode == 0 and done.stderr == ""  # stderr is a pipe: no bars
    done = run("compare", EPOCH2, EPOCH2, "--quiet", "--report", "r.html", cwd=tmp_path)
    assert done.returncode == 0 and done.stderr == ""
    assert "wrote" not in done.stdout


def _on_a_terminal(args, cwd):
    """stderr of the command run with stderr on a pseudo-terminal of 120 columns."""
    import fcntl
    import pty
    import struct
    import termios

    master, slave = pty.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 40, 120, 0, 0))
    proc = subprocess.Popen([sys.executable, "-m", "lidar_sig", *map(str, args)], cwd=cwd, stdin=subprocess.DEVNULL,
                            stdout=subprocess.DEVNULL, stderr=slave)
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


@pytest.mark.skipif(sys.platform == "win32", reason="pseudo-terminals are POSIX")
def test_on_a_terminal_the_saliency_loop_shows_a_bar_and_quiet_silences_it(tmp_path):
    code, shown = _on_a_terminal(["saliency", EPOCH2, "-o", "a.laz"], tmp_path)
    assert code == 0
    assert re.search(r"saliency \(c3dcm multiscale\): +\d+%\|.*\| \d+/\d+ .*block", shown), shown
    code, shown = _on_a_terminal(["saliency", EPOCH2, "-o", "b.laz", "--quiet"], tmp_path)
    assert code == 0 and shown == ""


def test_a_step_shows_its_elapsed_time_after_a_delay_and_logs_when_done(capsys, caplog):
    import time

    from lidar_sig import progress

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
    from lidar_sig.errors import LidarSigWarning
    from lidar_sig.progress import step

    monkeypatch.setattr("lidar_sig.progress.STEP_DELAY", 0.0)
    with step("working", enabled=True):
        time.sleep(0.1)
        _note("something to know", LidarSigWarning, __file__, 1)
    err = capsys.readouterr().err
    lines = [part for line in err.split("\n") for part in line.split("\r")]
    assert "lidar-sig: note: something to know" in lines  # the whole line, nothing glued to it
