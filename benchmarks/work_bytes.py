"""Bytes a point writes into and reads back from a change map's work folder (issue 47, must-show 5).

    python benchmarks/work_bytes.py [--dir DIR] [--memory 400MiB] [--tile-size 100] [--pair A B]

Maps the IGN pair of benchmarks/bench_m3c2_time.py (the six IGN tiles against the block's edited
copy, written once into ``--dir``), or the LAS/LAZ files ``--pair A B`` (e.g. the 20 million pair
of benchmarks/bench_change_scale.py), in work units in this process (``workers=1``), with
``--points b.laz`` written as the command line writes it, and counts:

- **written**: the size of every file the run leaves in its work folder, by kind (staged
  records, second-neighbour distances, per-point saliency, the tiles' sample points, coded
  records, the top view, the units' results), measured once the map and its per-point change are written;
- **read**: the bytes of every array the run takes back from the work folder: whole files read
  with ``numpy.fromfile`` or ``numpy.load``, and the slices taken from memory-mapped files (a
  binary search's few pages are not counted).

Both are divided by the points of both epochs the run staged (withheld and noise points left
out) and printed per kind, with the epochs' densities and their samples'.
"""
from __future__ import annotations

import argparse
import sys
import tempfile
from collections import Counter
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

#: Kinds of file by the folder they lie in (see lidar_sig.tiling and lidar_sig.change_map._units).
KINDS = (("stage", "staged records"), ("second", "second-neighbour distances"), ("tiles", "per-point saliency"),
         ("coded", "coded records"), ("view", "top view"), ("units", "units' results"))
#: Kinds of file by the end of their name, before their folder's: a tile's sample points
#: (lidar_sig.tiling._tasks.sample_path), which the coding reads instead of staged records.
NAMED = ((".sample.npy", "sample points"),)


def kind_of(path, work):
    for end, name in NAMED:
        if str(path).endswith(end):
            return name
    parts = Path(path).resolve().relative_to(work).parts
    for folder, name in KINDS:
        if folder in parts:
            return name
    return "other"


class Reads:
    """Counts the bytes taken back from files under ``work``, by kind."""

    def __init__(self, work):
        self.work, self.bytes = Path(work).resolve(), Counter()

    def mine(self, f):
        try:
            return isinstance(f, (str, Path)) and Path(f).resolve().is_relative_to(self.work)
        except OSError:
            return False

    def install(self):
        real_fromfile, real_load = np.fromfile, np.load
        reads = self

        class Mapped(np.memmap):
            """A memory-mapped file whose slices count as read when taken."""

            def __getitem__(self, key):
                out = super().__getitem__(key)
                if isinstance(out, np.ndarray) and out.ndim and getattr(self, "_kind", None):
                    reads.bytes[self._kind] += out.nbytes
                return out

        def fromfile(f, *args, **kwargs):
            out = real_fromfile(f, *args, **kwargs)
            if reads.mine(f):
                reads.bytes[kind_of(f, reads.work)] += out.nbytes
            return out

        def load(f, *args, **kwargs):
            out = real_load(f, *args, **kwargs)
            if not reads.mine(f):
                return out
            kind = kind_of(f, reads.work)
            if isinstance(out, np.memmap):
                view = out.view(Mapped)
                view._kind = kind
                return view
            reads.bytes[kind] += Path(f).stat().st_size  # a whole .npy or .npz read
            return out

        np.fromfile, np.load = fromfile, load


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dir", default=None)
    parser.add_argument("--memory", default="400MiB")
    parser.add_argument("--tile-size", type=float, default=None)
    parser.add_argument("--pair", nargs=2, metavar=("A", "B"), default=None)
    args = parser.parse_args()
    from bench_m3c2_time import pairs

    folder = Path(args.dir or tempfile.mkdtemp(prefix="work-bytes-"))
    folder.mkdir(parents=True, exist_ok=True)
    a, b = args.pair if args.pair else pairs(folder)["IGN"][:2]
    work = folder / "work"
    import shutil

    shutil.rmtree(work, ignore_errors=True)
    reads = Reads(work.parent / "work")
    reads.install()
    import lidar_sig as ls

    execution = ls.Execution(memory=args.memory, workers=1, tile_size=args.tile_size)
    cm = ls.changes(a, b, pipeline=ls.Pipeline(progress=False), execution=execution, work=work)
    cm.save(folder / "b_change.laz", overwrite=True)  # the per-point change, as --points writes it
    written = Counter()
    for p in work.rglob("*"):
        if p.is_file():
            written[kind_of(p, work.resolve())] += p.stat().st_size
    points = sum(e.n_points for e in (cm.a, cm.b))
    staged = sum(run_points(e) for e in (cm.a, cm.b))
    print(f"epochs: {cm.a.n_points:,} and {cm.b.n_points:,} points, densities "
          f"{', '.join(f'{d:.3g}' for d in cm.density)} points/m², samples "
          f"{', '.join(f'{d:.3g}' for d in getattr(cm, 'sampled', cm.density))}; {cm.timings['units']['units']} work units")
    print(f"{'kind':<28} {'written B/point':>16} {'read B/point':>13}")
    for _, name in KINDS + NAMED + (("other", "other"),):
        if written[name] or reads.bytes[name]:
            print(f"{name:<28} {written[name] / staged:>16.1f} {reads.bytes[name] / staged:>13.1f}")
    print(f"{'all':<28} {sum(written.values()) / staged:>16.1f} {sum(reads.bytes.values()) / staged:>13.1f}"
          f"   (per staged point of both epochs: {staged:,}; {points:,} in the files)")
    cm.close()


def run_points(epoch):
    """The points an epoch's tiled run staged and kept."""
    return sum(r["n"] - r["n_excluded"] for r in epoch.run.records.values())


if __name__ == "__main__":
    main()
