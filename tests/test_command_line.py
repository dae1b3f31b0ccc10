"""The in-process runner of the command line (tests/command_line.py) sees what a child process's
parent would see: what C code prints, warnings, tracebacks; and leaves this process as it was."""
import logging
import os
import sys
import warnings

import pytest

from command_line import run, run_process


@pytest.fixture
def plugins_command(monkeypatch):
    """Replace what `lidar-sig plugins` does with the function given."""
    from lidar_sig.cli.list_plugins import plugins  # the command the group loads for `plugins`

    def replace(function):
        # the command's options (such as --json) are not the test's concern
        monkeypatch.setattr(plugins, "callback", lambda **options: function())
    return replace


def test_an_uncaught_exception_is_exit_1_with_its_traceback(plugins_command):
    def fails():
        raise ZeroDivisionError("on purpose")

    plugins_command(fails)
    done = run("plugins")
    assert done.returncode == 1 and "Traceback (most recent call last)" in done.stderr
    assert done.stderr.strip().endswith("ZeroDivisionError: on purpose")


def test_what_c_code_writes_on_the_descriptors_is_captured(plugins_command):
    def writes():
        os.write(1, b"on descriptor 1\n")
        os.write(2, b"on descriptor 2\n")
        print("on sys.stdout")

    plugins_command(writes)
    done = run("plugins")
    assert done.returncode == 0
    assert done.stdout == "on descriptor 1\non sys.stdout\n" and done.stderr == "on descriptor 2\n"


def test_warnings_and_unhandled_log_records_show_on_stderr_as_in_a_new_interpreter(plugins_command):
    def warns():
        warnings.warn("a third-party warning", RuntimeWarning)
        warnings.warn("hidden by Python's default filters", DeprecationWarning)
        logging.getLogger("some.library").warning("a record nobody handles")

    plugins_command(warns)
    for _ in range(2):  # shown again in another run, as in another process
        done = run("plugins")
        assert done.returncode == 0
        lines = done.stderr.splitlines()
        assert "a record nobody handles" in lines and "RuntimeWarning: a third-party warning" in done.stderr
        assert "DeprecationWarning" not in done.stderr


def test_this_process_is_left_as_it_was(tmp_path):
    folder, streams, filters = os.getcwd(), (sys.stdin, sys.stdout, sys.stderr), list(warnings.filters)
    done = run("saliency", tmp_path / "missing.laz", "-o", "o.laz", cwd=tmp_path)
    assert done.returncode == 2 and "missing.laz" in done.stderr
    assert os.getcwd() == folder and (sys.stdin, sys.stdout, sys.stderr) == streams
    assert warnings.filters == filters


def test_both_runners_give_the_same_output():
    assert run("plugins").stdout == run_process("plugins").stdout
