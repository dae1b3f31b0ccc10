"""The memory budget of a run: what one block of points needs, and how many points a
processing tile may hold so that every process stays within the budget.

Both are linear models of the peak resident memory of a process, upper bounds of what was
measured on generated airborne scenes (benchmarks/bench_tiles.py; docs/performance.md):

- one block (``lidar-sig saliency`` of a whole cloud): :data:`BASE_BYTES` (the interpreter,
  the libraries, one block of neighbour lists) plus :data:`BLOCK_BYTES_PER_POINT` per point
  (measured: 549 MiB at 1 million points, 1,340 MiB at 5 million; Optimal-scale 554 MiB at 1
  million);
- a process running tiles: the same base plus :data:`TILE_BYTES_PER_POINT` per point of a
  tile's block (its core points and halo), which also covers the staged records it loads
  (measured: 230 to 250 bytes a point above the base, 819 MiB for blocks of 1.9 million).

The command line reads the point count from a LAS/LAZ header (no point is read) and runs a
file in tiles when one block would need more than the budget (``--memory``, default
:data:`DEFAULT_MEMORY`).
"""
from __future__ import annotations

import math
import os
import re
import warnings
from pathlib import Path

from ..base.errors import LidarSigError, LidarSigWarning, arg, brief, counted

TIB = 2**40
GIB = 2**30
MIB = 2**20
#: Memory budget per process when none is given: 1 GiB.
DEFAULT_MEMORY = GIB
#: Resident memory of a process before any point: interpreter, libraries, one block of
#: neighbour lists (bytes).
BASE_BYTES = 360 * MIB
#: Bytes per point of a cloud run as one block (coordinates, their sorted copy, the voxel
#: index, the weights, the per-point outputs).
BLOCK_BYTES_PER_POINT = 212
#: Bytes per point of a tile's block (core and halo) in a process running tiles.
TILE_BYTES_PER_POINT = 300
#: Share of a tile's block that is its core (the halo and the recomputed points are the rest).
CORE_SHARE = 0.85
#: Fewest points a processing tile may hold under a budget: a smaller budget is refused.
MIN_BUDGET_TILE_POINTS = 20_000
#: Largest budget: 1 PiB, more than any machine holds (a larger one is a mistake).
MAX_MEMORY = 2**50

_UNITS = {"": 1, "k": 2**10, "m": MIB, "g": GIB, "t": 2**40}
# a number, then a unit: K, M, G or T (with or without "iB"/"B"), "B" alone, or nothing (bytes)
_PATTERN = re.compile(r"^\s*([0-9]*\.?[0-9]+(?:e[+-]?[0-9]+)?)\s*(?:([kmgt])(?:i?b)?|b)?\s*$", re.IGNORECASE)


def budget_bytes(value):
    """Bytes of a memory budget given as a number of bytes (an int, a numpy integer or a bare
    number in text) or as a size ``1GiB``, ``800MiB``, ``1.5G``, ``2GB``, ``500B`` (units are
    binary: 1G = 1GiB = 2**30 bytes; B is bytes); LidarSigError naming the value and the fix
    otherwise, and for a budget too small to run a tile in or larger than any machine
    (:data:`MAX_MEMORY`). A budget above this machine's memory is taken with a note."""
    import numbers

    if isinstance(value, numbers.Real) and not isinstance(value, bool):
        shown = f"{brief(value)} bytes"
        number = int(value) if isinstance(value, numbers.Integral) else \
            float(value) if math.isfinite(value) else math.nan
        match = None
    else:
        match = _PATTERN.match(str(value)) if isinstance(value, str) else None
        number = float(match.group(1)) * _UNITS[(match.group(2) or "").lower()] if match else math.nan
        shown = brief(value)
    if not number > 0:  # not a number, or not positive (an int too large for a float passes: capped below)
        raise LidarSigError(f"{arg('memory')} must be a positive size such as 1GiB, 800MiB or 2G, got {shown}")
    if number > MAX_MEMORY:  # an int of any size, or a float up to inf
        raise LidarSigError(f"{arg('memory')} must be at most {size(MAX_MEMORY)} (more than any machine holds), "
                            f"got {shown}")
    budget = int(number)
    least = BASE_BYTES + TILE_BYTES_PER_POINT * MIN_BUDGET_TILE_POINTS
    if budget < least:
        bare = match is not None and match.group(2) is None and not value.strip().lower().endswith("b")
        raise LidarSigError(f"{arg('memory', value)} ({counted(budget, 'byte')}) is less than a process needs to run "
                            f"a tile ({size(least)}); give at least {math.ceil(least / MIB)}MiB"
                            + (" (a number without a unit is bytes: give a unit, e.g. 2GiB)" if bare else ""))
    machine = machine_bytes()
    if machine is not None and budget > machine:
        warnings.warn(f"{arg('memory', value)} is more than this machine's memory ({size(machine)}): a run that "
                      "needs it will swap or be stopped; give at most what the machine holds",
                      LidarSigWarning, stacklevel=3)
    return budget


def machine_bytes():
    """This machine's physical memory in bytes, or None where it cannot be read."""
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (AttributeError, ValueError, OSError):
        return None


def block_bytes(n_points):
    """Peak resident memory (bytes) of a cloud of ``n_points`` run as one block."""
    return BASE_BYTES + BLOCK_BYTES_PER_POINT * int(n_points)


def over_budget(n_points, budget):
    """True when one block of ``n_points`` would need more than ``budget`` bytes."""
    return block_bytes(n_points) > budget


def header_points(path):
    """Points of a LAS/LAZ file from its header alone, or None for another format or a header
    that cannot be read (reading the file then names the problem)."""
    from ..io import LAS_EXTENSIONS

    if not isinstance(path, (str, Path)) or Path(path).suffix.lower() not in LAS_EXTENSIONS \
            or not Path(path).is_file():
        return None
    import laspy

    try:
        with laspy.open(path) as reader:
            return int(reader.header.point_count)
    except Exception:  # laspy raises many kinds on a damaged header
        return None


def points_over_budget(path, budget):
    """Points of the LAS/LAZ file ``path`` when one block of them would need more than
    ``budget`` bytes (it is then processed in tiles), else None."""
    n = header_points(path)
    return n if n is not None and over_budget(n, budget) else None


def tile_points(budget):
    """Core points of a processing tile such that its block (core and halo) stays within
    ``budget`` bytes in the process that runs it."""
    return max(MIN_BUDGET_TILE_POINTS, int(CORE_SHARE * (budget - BASE_BYTES) / TILE_BYTES_PER_POINT))


def size(n_bytes):
    """A memory size for messages: "1 GiB", "1.5 GiB", "800 MiB", "2 TiB"."""
    if n_bytes >= 1000 * GIB:
        return f"{n_bytes / TIB:.4g} TiB"
    if n_bytes >= GIB:
        return f"{n_bytes / GIB:.3g} GiB"
    return f"{n_bytes / MIB:.0f} MiB"


def exceed(n_points: int, budget: int) -> str:
    """For messages: "N points exceed the 1 GiB memory budget as one block"."""
    return f"{counted(n_points, 'point')} exceed the {size(budget)} memory budget as one block"


def one_block_note(name, n_points, budget, descriptor):
    """The note of a file over the budget that still runs as one block: its ``descriptor`` needs
    the whole cloud at once."""
    return (f"{name}: {exceed(n_points, budget)}, but the {descriptor} descriptor needs the whole cloud at "
            "once: processed as one block")
