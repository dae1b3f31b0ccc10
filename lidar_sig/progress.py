"""Progress of long steps for people, on a terminal only; timings for ``--verbose``.

Two tools serve every command and the library alike:

- :func:`step`, a context manager around a step that may take more than a second (reading,
  neighbour search and descriptor, signature, metrics, rendering, writing). On a terminal it
  shows the step's name and elapsed time once the step has lasted ``STEP_DELAY`` seconds, and a
  bar where the step iterates (:meth:`Step.track`); when it ends it logs its name, parameters
  and duration to the ``lidar_sig`` logger at INFO level (``--verbose`` prints them).
- :func:`progress`, a bar around a loop (used where a loop is not a step of its own).

Whether anything is shown: an explicit ``enabled`` wins; else the setting of the enclosing
:func:`settings` block (the command line's ``--quiet``); else only when stderr is a terminal.
The bars are tqdm's, imported when one is first made or a line said (not when the command
line starts).
"""
from __future__ import annotations

import contextlib
import contextvars
import logging
import sys
import threading
import time
from collections.abc import Iterator

log = logging.getLogger("lidar_sig")

#: Seconds a step runs before its line appears (quick steps stay silent).
STEP_DELAY = 0.5
#: Seconds between refreshes of a step's elapsed time.
REFRESH = 0.5

_enabled = contextvars.ContextVar("lidar_sig_progress", default=None)


def shown(enabled=None):
    """Whether to show progress: ``enabled`` if given, else the :func:`settings` in force,
    else whether stderr is a terminal."""
    if enabled is None:
        enabled = _enabled.get()
    if enabled is None:
        enabled = sys.stderr.isatty()
    return bool(enabled)


@contextlib.contextmanager
def settings(*, enabled: bool | None = None, verbose: bool = False) -> Iterator[None]:
    """Within the block, progress is shown as ``enabled`` says (None: on a terminal only) and,
    with ``verbose``, each step's parameters and timing are printed on stderr."""
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


def progress(iterable, *, total=None, desc="", enabled=None, unit="it"):
    """Wrap ``iterable`` in a bar on stderr; see the module docstring for when it shows."""
    from tqdm import tqdm

    return tqdm(iterable, total=total, desc=desc, disable=not shown(enabled), unit=unit,
                leave=False, file=sys.stderr)


class Step:
    """A running :func:`step`: add facts with :meth:`note`, iterate with :meth:`track`."""

    def __init__(self, name, enabled, params):
        self.name = name
        self.params = dict(params)
        self.start = time.perf_counter()
        self._bar = None
        self._done = threading.Event()
        if shown(enabled):
            from tqdm import tqdm

            self._bar = tqdm(total=None, desc=name, bar_format="{desc}: {elapsed}", leave=False,
                             file=sys.stderr, delay=STEP_DELAY)
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

    def track(self, iterable, *, total=None, unit="it"):
        """Iterate with a bar in place of the step's line (total from ``len`` if not given)."""
        if self._bar is None:
            yield from iterable
            return
        total = len(iterable) if total is None else total
        self._bar.bar_format = None
        self._bar.unit = unit
        self._bar.reset(total=total)
        for item in iterable:
            yield item
            self._bar.update()

    def close(self):
        self._done.set()
        if self._bar is not None:
            self._bar.close()
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
    finally:
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
