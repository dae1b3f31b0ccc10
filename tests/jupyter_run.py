"""Notebooks as their users run them: a real JupyterLab server on this machine, and notebooks
executed by nbconvert's client (a real IPython kernel).

- :class:`JupyterLab` starts ``jupyter lab`` headless on a free localhost port with a token, its
  files, settings and runtime in a temporary folder, and stops it (kernels included).
- :func:`notebook` writes a notebook of code cells; :func:`execute` runs one through a kernel
  and returns it with its outputs.

Used by tests/test_jupyter.py (named so as not to hide the jupyter module of jupyter_core); nothing
here reaches beyond 127.0.0.1.
"""
from __future__ import annotations

import json
import os
import secrets
import signal
import socket
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

from conftest import ROOT

#: Seconds a server has to answer, and a cell to run (the first run compiles the kernels).
START_TIMEOUT = 90
CELL_TIMEOUT = 600


def missing_lab():
    """Why JupyterLab cannot run here (None when it can)."""
    for module, package in (("jupyterlab", "jupyterlab"), ("ipykernel", "ipykernel"), ("nbformat", "nbformat")):
        try:
            __import__(module)
        except ImportError:
            return f"{package} is not installed (pip install -e '.[test]')"
    return None


def missing_nbconvert():
    """Why a notebook cannot be executed here (None when it can)."""
    for module, package in (("nbclient", "nbconvert"), ("ipykernel", "ipykernel"), ("nbformat", "nbformat")):
        try:
            __import__(module)
        except ImportError:
            return f"{package} is not installed (pip install -e '.[test]')"
    return None


def environment(folder, **extra):
    """The environment of a server or kernel: this tree's lidar_sig first on the path, and every
    Jupyter and IPython folder of its own under ``folder`` (no user settings read or written)."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT)] + [p for p in env.get("PYTHONPATH", "").split(os.pathsep) if p])
    for name in ("JUPYTER_CONFIG_DIR", "JUPYTER_RUNTIME_DIR", "IPYTHONDIR", "JUPYTERLAB_SETTINGS_DIR",
                 "JUPYTERLAB_WORKSPACES_DIR"):
        path = Path(folder) / ".jupyter" / name.lower()
        path.mkdir(parents=True, exist_ok=True)
        env[name] = str(path)
    env.update({k: str(v) for k, v in extra.items()})
    return env


def notebook(path, cells):
    """Write a notebook of code ``cells`` (source strings) for the python3 kernel at ``path``."""
    import nbformat

    nb = nbformat.v4.new_notebook()
    nb.cells = [nbformat.v4.new_code_cell(source) for source in cells]
    nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3", "language": "python"}
    nbformat.write(nb, str(path))
    return Path(path)


def execute(path, env):
    """Run every cell of the notebook at ``path`` in a python3 kernel started with ``env``, in
    the notebook's folder, as ``jupyter nbconvert --execute`` does; the executed notebook."""
    import nbformat
    from nbclient import NotebookClient

    nb = nbformat.read(str(path), as_version=4)
    client = NotebookClient(nb, timeout=CELL_TIMEOUT, kernel_name="python3",
                            resources={"metadata": {"path": str(Path(path).parent)}})
    saved = dict(os.environ)
    os.environ.clear()
    os.environ.update(env)  # the kernel inherits this process's environment
    try:
        client.execute()
    finally:
        os.environ.clear()
        os.environ.update(saved)
    return nb


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class JupyterLab:
    """``jupyter lab`` serving ``folder`` on 127.0.0.1 with a token; a context manager. The
    application is exposed in the page (``window.jupyterapp``) so that a test runs its commands."""

    def __init__(self, folder):
        self.folder = Path(folder)
        self.token = secrets.token_hex(16)
        self.port = free_port()
        self.log = self.folder / ".jupyter" / "server.log"
        self.process = None

    @property
    def url(self):
        return f"http://127.0.0.1:{self.port}"

    def page(self, notebook_name):
        """The address of the page showing ``notebook_name`` (a file of the folder)."""
        return f"{self.url}/lab/tree/{notebook_name}?token={self.token}"

    def __enter__(self):
        env = environment(self.folder)
        # no prompt over the page: no build check (an extension installed beside JupyterLab asks
        # for one) and no news
        labconfig = Path(env["JUPYTER_CONFIG_DIR"]) / "labconfig"
        labconfig.mkdir(parents=True, exist_ok=True)
        (labconfig / "page_config.json").write_text(json.dumps({
            "buildCheck": False, "buildAvailable": False,
            "disabledExtensions": {"@jupyterlab/apputils-extension:announcements": True}}))
        # every cell in the page, not only those in view (JupyterLab 4 renders a long notebook's
        # cells as they scroll in), so that a test finds every output
        tracker = Path(env["JUPYTERLAB_SETTINGS_DIR"]) / "@jupyterlab" / "notebook-extension"
        tracker.mkdir(parents=True, exist_ok=True)
        (tracker / "tracker.jupyterlab-settings").write_text(json.dumps({"windowingMode": "none"}))
        self.log.parent.mkdir(parents=True, exist_ok=True)
        args = [sys.executable, "-m", "jupyterlab", "--no-browser", "--ServerApp.ip=127.0.0.1",
                f"--ServerApp.port={self.port}", "--ServerApp.port_retries=0",
                f"--IdentityProvider.token={self.token}", f"--ServerApp.root_dir={self.folder}",
                "--expose-app-in-browser",
                "--LabApp.check_for_updates_class=jupyterlab.NeverCheckForUpdate", "--LabApp.extension_manager=readonly",
                "--ServerApp.terminals_enabled=False"]
        if hasattr(os, "geteuid") and os.geteuid() == 0:  # CI runs as root
            args.append("--allow-root")
        with open(self.log, "wb") as log:
            self.process = subprocess.Popen(args, cwd=self.folder, env=env, stdin=subprocess.DEVNULL, stdout=log,
                                            stderr=subprocess.STDOUT, start_new_session=True)
        deadline = time.monotonic() + START_TIMEOUT
        while time.monotonic() < deadline:
            if self.process.poll() is not None:
                raise RuntimeError(f"jupyter lab ended with status {self.process.returncode}:\n{self.log.read_text()}")
            try:
                with urllib.request.urlopen(f"{self.url}/api/status?token={self.token}", timeout=5) as answer:
                    json.load(answer)
                return self
            except OSError:
                time.sleep(0.5)
        self.__exit__()
        raise RuntimeError(f"jupyter lab did not answer within {START_TIMEOUT} s:\n{self.log.read_text()}")

    def __exit__(self, *exc):
        if self.process is None or self.process.poll() is not None:
            return
        # the server stops its kernels on SIGTERM; its own process group only, started above
        os.killpg(self.process.pid, signal.SIGTERM)
        try:
            self.process.wait(timeout=30)
        except subprocess.TimeoutExpired:
            os.killpg(self.process.pid, signal.SIGKILL)
            self.process.wait(timeout=10)


def run_in_page(browser, lab, notebook_name, selector, count=1):
    """Open ``notebook_name`` in JupyterLab's page, run all its cells once its kernel is ready,
    and wait until ``count`` elements match ``selector`` in its outputs; the page's error
    outputs (tracebacks) as text, if any."""
    driver = browser.driver
    driver.set_script_timeout(CELL_TIMEOUT)
    driver.get(lab.page(notebook_name))
    deadline = time.monotonic() + START_TIMEOUT
    while not driver.execute_script("const a = window.jupyterapp; const w = a && a.shell.currentWidget;"
                                    "return !!(w && w.sessionContext && w.content && w.content.widgets.length)"):
        if time.monotonic() > deadline:
            raise RuntimeError(f"JupyterLab showed no notebook within {START_TIMEOUT} s")
        time.sleep(0.25)
    answer = driver.execute_async_script(
        "const done = arguments[arguments.length - 1]; const app = window.jupyterapp;"
        "const w = app.shell.currentWidget;"
        "w.sessionContext.ready.then(() => app.commands.execute('notebook:run-all-cells'))"
        ".then(() => done('ran'), e => done('failed: ' + e));")
    if answer != "ran":
        raise RuntimeError(f"JupyterLab could not run the notebook: {answer}")
    deadline = time.monotonic() + CELL_TIMEOUT
    while time.monotonic() < deadline:
        errors = driver.execute_script(
            "return [...document.querySelectorAll('.jp-OutputArea-output[data-mime-type=\"application/vnd.jupyter.stderr\"]')]"
            ".map(e => e.innerText).filter(t => t.includes('Error') || t.includes('Traceback'))")
        if errors:
            return errors
        found = driver.execute_script("return document.querySelectorAll('.jp-OutputArea-output ' + arguments[0]).length",
                                      selector)
        if found >= count:
            return []
        time.sleep(0.5)
    raise RuntimeError(f"the notebook showed fewer than {count} of {selector} within {CELL_TIMEOUT} s")
