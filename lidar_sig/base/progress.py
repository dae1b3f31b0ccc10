"""Progress of long steps, for people on a terminal and for programs reading stderr; timings for
``--verbose``.

Two tools serve every command and the library alike:

- :func:`step`, a context manager around a step that may take more than a second (reading,
  neighbour search and descriptor, signature, metrics, rendering, writing). It shows the step's
  progress (below), and where the step iterates (:meth:`Step.track`) how far it is; when it ends
  it logs its name, parameters and duration to the ``lidar_sig`` logger at INFO level
  (``--verbose`` prints them).
- :func:`progress`, the same around a loop that is not a step of its own (tiles, subsamples).

Progress takes one of two forms (docs/scripting.md):

- **bars** (tqdm's, on stderr): a step's name and elapsed time once it has lasted
  ``STEP_DELAY`` seconds, a bar where it iterates; they vanish when done.
- **lines**, for a program that reads stderr (a GIS, a workflow manager): one line per stage
  and whole percent, ``lidar-sig: progress: <stage>: <N>%``, from 0% when the stage starts to
  100% when it ends (not said when it fails); a stage without a count of items says 0% and
  100% only. The stage is free text without ": ".

In a notebook (this process is a Jupyter kernel), bars are tqdm's notebook widgets when
ipywidgets is installed (:func:`widgets`), each replaced by its last line in text when it
closes (what a saved notebook shows), else tqdm's text bars on stderr.

Which form, if any: an explicit ``enabled`` wins (False: none; True: lines if the environment
variable ``LIDAR_SIG_PROGRESS`` says ``lines``, else bars); else the setting of the enclosing
:func:`settings` block (the command line's ``--quiet`` is False); else ``LIDAR_SIG_PROGRESS``:
``auto`` (the default: bars when stderr is a terminal; otherwise lines from the command line, a
program reading its stderr; in a notebook, bars where ipywidgets draws them, else lines; and
nothing from a Python script off a terminal), ``lines``, ``bars`` or ``none``. tqdm is imported
when a bar is first made or a line said above one (not when the command line starts).
"""
from __future__ import annotations

import contextlib
import contextvars
import logging
import os
import sys
import threading
import time
from collections.abc import Iterable, Iterator
from typing import TypeVar

from .errors import FACE, LidarSigError

T = TypeVar("T")

log = logging.getLogger("lidar_sig")

#: Seconds a step runs before its line appears on a terminal (quick steps stay silent there).
STEP_DELAY = 0.5
#: Seconds between refreshes of a step's elapsed time.
REFRESH = 0.5
#: The environment variable that chooses the form of progress, and its values.
VARIABLE = "LIDAR_SIG_PROGRESS"
SETTINGS = ("auto", "lines", "bars", "none")
#: What starts every progress line; the stage and the percent follow (``<stage>: <N>%``).
LINE_PREFIX = "lidar-sig: progress: "

_enabled = contextvars.ContextVar("lidar_sig_progress", default=None)


def environment_setting():
    """``LIDAR_SIG_PROGRESS`` (auto, lines, bars or none; auto when unset or empty); a
    LidarSigError for any other value."""
    raw = os.environ.get(VARIABLE, "")
    value = raw.strip().lower() or "auto"
    if value not in SETTINGS:
        raise LidarSigError(f"the environment variable {VARIABLE}={raw!r} is not a progress setting; set it to "
                            f"{', '.join(SETTINGS[:-1])} or {SETTINGS[-1]}, or unset it")
    return value


def form(enabled=None):
    """How progress shows: ``"bars"``, ``"lines"`` or None (not at all); see the module
    docstring for the order in which ``enabled``, :func:`settings` and ``LIDAR_SIG_PROGRESS``
    decide."""
    if enabled is None:
        enabled = _enabled.get()
    if enabled is False:
        return None
    setting = environment_setting()
    if enabled is None:
        if setting == "auto":
            if sys.stderr.isatty():
                return "bars"
            if FACE.get() == "cli":
                return "lines"  # a program reads the command's stderr
            if in_notebook():  # a person watches the cell: widgets where they draw, else lines
                return "bars" if widgets() else "lines"
            return None
        return None if setting == "none" else setting
    return "lines" if setting == "lines" else "bars"  # asked for explicitly


def in_notebook() -> bool:
    """Whether this process is a Jupyter kernel (a notebook's in JupyterLab, Notebook, VS Code),
    whose stderr is not a terminal but whose cells a person watches."""
    ipython = sys.modules.get("IPython")
    if ipython is None or "ipykernel" not in sys.modules:
        return False
    try:
        shell = ipython.get_ipython()
    except Exception:  # an IPython too old or half imported: not a kernel we know
        return False
    return type(shell).__name__ == "ZMQInteractiveShell"


def widgets() -> bool:
    """Whether bars show as tqdm's notebook widgets: in a notebook, with ipywidgets installed."""
    if not in_notebook():
        return False
    try:
        import ipywidgets  # noqa: F401
    except ImportError:
        return False
    return True


def _bar(**options):
    """A tqdm bar: the notebook's widget where :func:`widgets` (:func:`_notebook_bar`), else
    text on stderr."""
    from tqdm import tqdm

    tqdm.monitor_interval = 0  # no monitor thread: a process of one thread may fork (change_map/_cores.py)
    if widgets():
        return _notebook_bar()(file=sys.stderr, **options)
    return tqdm(file=sys.stderr, **options)


def _notebook_bar():
    """tqdm's notebook bar, shown through a display handle so that when it closes its output
    becomes the bar's last line in text ("tiles: 100%|...| 5/5 [...]"): a saved notebook, read
    without its widgets' state, shows where each bar ended, not the "0%" it started at."""
    from tqdm.notebook import tqdm as widget_bar

    class NotebookBar(widget_bar):
        def __init__(self, *args, **kwargs):
            self._handle = None
            super().__init__(*args, display=False, **kwargs)
            if not self.disable and self.delay <= 0:
                self._show()

        def _show(self):
            from IPython.display import display

            self._handle = display(self.container, display_id=True)
            self.displayed = True

        def display(self, *args, check_delay=True, **kwargs):
            if check_delay and self.delay > 0 and not self.displayed:
                self._show()
            return super().display(*args, check_delay=check_delay, **kwargs)

        def close(self):
            if self.disable or self._handle is None:
                return super().close()
            last = self.format_meter(**{**self.format_dict, "ascii": True})
            super().close()
            self._handle.update({"text/plain": last}, raw=True)
            self._handle = None

    return NotebookBar


def shown(enabled=None):
    """Whether progress shows at all (:func:`form` is not None)."""
    return form(enabled) is not None


@contextlib.contextmanager
def settings(*, enabled: bool | None = None, verbose: bool = False) -> Iterator[None]:
    """Within the block, progress is shown as ``enabled`` says (None: as ``LIDAR_SIG_PROGRESS``
    says) and, with ``verbose``, each step's parameters and timing are printed on stderr."""
    token = _enabled.set(enabled)
    handler = None
    if verbose:
        handler = _TqdmHandler()
        handler.setFormatter(logging.Formatter("lidar-sig: %(message)s"))
        log.addHandler(handler)
        previous = log.level
        log.setLevel(logging.INFO)
    try:
        yield
    finally:
        _enabled.reset(token)
        if handler is not None:
            log.removeHandler(handler)
            log.setLevel(previous)


class _TqdmHandler(logging.Handler):
    """Log lines printed above any bar on stderr, so that bars stay intact."""

    def emit(self, record):
        try:
            say(self.format(record))
        except Exception:  # logging must never break the run
            self.handleError(record)


def say(line):
    """Print ``line`` on stderr above any bar or step line, which stay intact below it."""
    from tqdm import tqdm

    tqdm.write(line, file=sys.stderr)


def stage_name(text):
    """``text`` as a stage of a progress line: one line, without ": " (which separates the
    stage from the percent)."""
    return " ".join(str(text).replace(": ", " - ").split())


class Lines:
    """Progress of one stage as plain lines on stderr, ``lidar-sig: progress: <stage>: <N>%``,
    one per whole percent reached (0% when made); iterate it like a bar, or call
    :meth:`update` and :meth:`close`."""

    def __init__(self, iterable=None, *, stage, total=None):
        self.iterable = iterable
        self.stage = stage_name(stage)
        self.total = total
        self.done = 0
        self.said = None
        self._say(0)

    def _say(self, percent):
        if percent != self.said:
            self.said = percent
            sys.stderr.write(f"{LINE_PREFIX}{self.stage}: {percent}%\n")
            sys.stderr.flush()

    def reset(self, total=None):
        """Count again from 0 of ``total`` items."""
        self.total, self.done = total, 0

    def update(self, n=1):
        self.done += n
        if self.total:
            self._say(min(100, int(100 * self.done / self.total)))

    def close(self, failed=False):
        """The stage ended: 100% unless it ``failed``."""
        if not failed:
            self._say(100)

    def set_postfix_str(self, text):
        """Bars show a rate after the count; a line does not."""

    def __iter__(self):
        try:
            for item in self.iterable:
                yield item
                self.update()
        except BaseException:
            self.close(failed=True)
            raise
        self.close()


def progress(iterable: Iterable[T], *, total: int | None = None, desc: str = "", enabled: bool | None = None,
             unit: str = "it") -> Iterable[T]:
    """Wrap ``iterable`` in a bar or lines on stderr, or in nothing (see the module docstring)."""
    how = form(enabled)
    if how == "lines":
        if total is None and hasattr(iterable, "__len__"):
            total = len(iterable)
        return Lines(iterable, stage=desc or "working", total=total)
    if how is None:
        from tqdm import tqdm

        return tqdm(iterable, total=total, desc=desc, disable=True)
    return _bar(iterable=iterable, total=total, desc=desc, unit=unit, leave=False)


class Step:
    """A running :func:`step`: add facts with :meth:`note`, iterate with :meth:`track`."""

    def __init__(self, name, enabled, params):
        self.name = name
        self.params = dict(params)
        self.start = time.perf_counter()
        self._bar = None
        self._lines = None
        self._done = threading.Event()
        how = form(enabled)
        if how == "lines":
            self._lines = Lines(stage=name)
        elif how == "bars":
            self._bar = _bar(total=None, desc=name, bar_format="{desc}: {elapsed}{postfix}", leave=False,
                             delay=STEP_DELAY)
            threading.Thread(target=self._refresh, daemon=True).start()

    def _refresh(self):
        if self._done.wait(STEP_DELAY):
            return
        while not self._done.is_set():
            self._bar.refresh()
            self._done.wait(REFRESH)

    def note(self, **params):
        """Facts learnt during the step (e.g. the number of points read), for the log line."""
        self.params.update(params)

    def postfix(self, text):
        """A short text after the step's bar, e.g. the bytes read so far (plain lines show none)."""
        if self._bar is not None:
            self._bar.set_postfix_str(text, refresh=False)

    def track(self, iterable, *, total=None, unit="it"):
        """Iterate with a bar in place of the step's line, or its lines by percent (total from
        ``len`` if not given)."""
        shown = self._bar if self._bar is not None else self._lines
        if shown is None:
            yield from iterable
            return
        total = len(iterable) if total is None else total
        if self._bar is not None:
            self._bar.bar_format = None
            self._bar.unit = unit
        shown.reset(total=total)
        for item in iterable:
            yield item
            shown.update()

    def close(self, failed=False):
        self._done.set()
        if self._bar is not None:
            self._bar.close()
        if self._lines is not None:
            self._lines.close(failed=failed)
        seconds = time.perf_counter() - self.start
        if log.isEnabledFor(logging.INFO):
            facts = ", ".join(f"{k.replace('_', ' ')} {_show(v)}" for k, v in self.params.items())
            log.info(f"{self.name}: {seconds:.2f} s" + (f" ({facts})" if facts else ""))
        return seconds


@contextlib.contextmanager
def step(name, *, enabled=None, **params):
    """Show and time a step that may take more than a second; ``params`` are logged with it.

    >>> with step("reading tile.laz", enabled=False) as s:
    ...     s.note(points=1000)
    """
    s = Step(name, enabled, params)
    try:
        yield s
    except BaseException:
        s.close(failed=True)
        raise
    s.close()


def _show(value):
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, int):
        return f"{value:,}"
    if isinstance(value, float):
        return f"{value:.4g}"
    if isinstance(value, (list, tuple)):
        return ", ".join(_show(v) for v in value)
    return str(value)
