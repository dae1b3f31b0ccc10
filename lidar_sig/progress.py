"""Progress bars on a terminal only (stderr), silent otherwise or when asked."""
import sys

from tqdm.auto import tqdm


def progress(iterable, *, total=None, desc="", enabled=None, unit="it"):
    """Wrap ``iterable`` in a tqdm bar; ``enabled=None`` shows it only when stderr is a tty."""
    if enabled is None:
        enabled = sys.stderr.isatty()
    return tqdm(iterable, total=total, desc=desc, disable=not enabled, unit=unit,
                leave=False, file=sys.stderr)
