"""Sets of tiles named by one text: a glob pattern of tiles (``"2019/*.laz"``) or a virtual point
cloud file (``.vpc``: a STAC ItemCollection, one feature per tile, as QGIS and PDAL write it).
Used wherever a set of tiles is taken: a change map's epoch, the inputs of a tiled run."""
from __future__ import annotations

import contextlib
import json
import os
from pathlib import Path

from ..base.errors import LidarSigError

#: Characters that make a text a glob pattern of tiles.
GLOB = set("*?[")


def tile_list(source: str | os.PathLike[str]) -> list[Path] | None:
    """The tiles ``source`` names, or None where it names one file or a folder: the files a
    glob pattern matches (sorted; point-cloud extensions only), or the data assets a ``.vpc``
    file lists (each asset's ``href`` relative to the file)."""
    from .formats import POINTS, extensions

    cloud_extensions = extensions(POINTS)  # the installed formats', made when first asked for

    text = str(source)
    if text.lower().endswith(".vpc"):
        return _vpc_paths(Path(text))
    if GLOB & set(text) and not os.path.exists(text):
        import glob

        paths = sorted(Path(p) for p in glob.glob(text) if Path(p).suffix.lower() in cloud_extensions
                       and Path(p).is_file())
        if not paths:
            raise LidarSigError(f"matches no point-cloud file ({', '.join(cloud_extensions)}); check the pattern, "
                                "and quote it so that the shell does not expand it", path=text)
        return paths
    return None


def _vpc_paths(path: Path) -> list[Path]:
    """The tiles a virtual point cloud file lists (:func:`tile_list`), each once."""
    from ..base.errors import special_file
    from .remote import is_url

    if special_file(path):  # a FIFO or a device would be waited on: refused before it is opened
        raise LidarSigError(f"is {special_file(path)}, not a regular file; give a .vpc file", path=path)
    if os.path.isdir(path):  # os.path: False, not OSError, for a name too long
        raise LidarSigError("is a folder; give a .vpc file, or the folder itself as the set of tiles", path=path)
    hrefs = [href for href, _ in _features(lambda: path.read_text(encoding="utf-8-sig"), path)]
    if not hrefs:
        raise LidarSigError("lists no tile; give a .vpc file that lists the epoch's tiles", path=path)
    paths, seen = [], {}
    for k, href in enumerate(hrefs):
        if not isinstance(href, str) or not href:
            raise LidarSigError(f"gives tile {k + 1} an href that is not a path ({type(href).__name__}); give each "
                                "tile's href as its path or file:// URL", path=path)
        if is_url(href):  # read by the commands and jobs (lidar_sig.io.clip), not as a path
            raise LidarSigError(f"lists {href}, a URL; give the .vpc to a command or job (they read URLs by range "
                                "requests), or download the tiles", path=path)
        local = _local(href)
        p = local if local.is_absolute() else path.parent / local
        key = os.path.normpath(p)
        if key in seen:  # the same tile listed twice would count its points twice
            raise LidarSigError(f"lists {href} twice (tiles {seen[key] + 1} and {k + 1}); list each tile once",
                                path=path)
        seen[key] = k
        paths.append(p)
    for p in paths:
        if os.path.isdir(p):
            raise LidarSigError(f"lists {p}, which is a folder; list the tile files themselves", path=path)
    missing = [p for p in paths if not os.path.isfile(p)]
    if missing:
        raise LidarSigError(f"lists {missing[0]}, which does not exist ({len(missing)} of {len(paths)} tiles "
                            "missing); give the .vpc beside its tiles, as it was written", path=path)
    return paths


def vpc_tiles(source: str) -> list[tuple[str, tuple | None]]:
    """(href, bounds) of each tile a ``.vpc`` (a path or an ``http(s)://`` URL) lists: an href
    that is a URL is kept, a relative one is resolved against the .vpc's own place (its folder,
    or its URL); bounds are the feature's ``proj:bbox`` (x0, y0, x1, y1, CRS from ``proj:epsg``
    or ``proj:wkt2``), None when it does not give them."""
    from urllib.parse import urljoin

    from .remote import fetch, is_url

    found = []
    for k, (href, props) in enumerate(_features(lambda: fetch(source).decode("utf-8-sig") if is_url(source)
                                                else Path(source).read_text(encoding="utf-8-sig"), source)):
        if not isinstance(href, str) or not href:
            raise LidarSigError(f"gives tile {k + 1} an href that is not a path or URL ({type(href).__name__}); "
                                "give each tile's href as its path or URL", path=source)
        if not is_url(href) and not Path(href).is_absolute():
            href = urljoin(source, href) if is_url(source) else str(Path(source).parent / href)
        found.append((href, _proj_bounds(props if isinstance(props, dict) else {})))
    if not found:
        raise LidarSigError("lists no tile; give a .vpc file that lists the epoch's tiles", path=source)
    return found


def _features(read, where) -> list[tuple[object, object]]:
    """(href, properties) of each feature of a ``.vpc`` whose text ``read()`` gives (decoded
    with utf-8-sig: a byte order mark, which some editors write, is no part of the JSON): the
    href of its data asset, as the file gives it; a LidarSigError naming ``where`` when the text
    is no STAC ItemCollection of tiles."""
    try:
        features = json.loads(read())["features"]
        return [(next(a["href"] for a in f["assets"].values() if "data" in a.get("roles", ["data"])),
                 f.get("properties")) for f in features]
    except LidarSigError:  # a URL that could not be read says so itself
        raise
    except FileNotFoundError:
        raise LidarSigError("does not exist; give an existing .vpc file", path=where) from None
    except RecursionError:  # JSON nested deeper than Python's parser goes
        raise LidarSigError("cannot be read as a virtual point cloud (its JSON is nested too deeply); give a .vpc "
                            "file as QGIS or PDAL write it (a STAC ItemCollection of the tiles)", path=where) from None
    except (OSError, ValueError, KeyError, TypeError, StopIteration, AttributeError) as exc:
        raise LidarSigError(f"cannot be read as a virtual point cloud ({type(exc).__name__}: {exc}); give a .vpc "
                            "file as QGIS or PDAL write it (a STAC ItemCollection of the tiles)", path=where) from None


def _proj_bounds(props: dict) -> tuple | None:
    """(x0, y0, x1, y1, CRS) of a STAC item's projection extension, or None."""
    box = props.get("proj:bbox")
    crs = f"EPSG:{props['proj:epsg']}" if isinstance(props.get("proj:epsg"), int) else props.get("proj:wkt2")
    if not isinstance(box, list) or len(box) not in (4, 6) or not all(isinstance(v, (int, float)) for v in box):
        return None
    if crs is None:
        return None
    x0, y0, x1, y1 = (box[0], box[1], box[3], box[4]) if len(box) == 6 else box
    return float(x0), float(y0), float(x1), float(y1), crs


def _local(href: str) -> Path:
    """The path of a tile's href: a path, or a ``file://`` URL (percent-escapes decoded)."""
    if href.lower().startswith("file:"):
        from urllib.parse import unquote, urlsplit

        parts = urlsplit(href)
        return Path(unquote(parts.path))
    return Path(href)


def check_distinct(files: list[Path]) -> None:
    """Refuse a set that holds one tile twice: the same path, a link to it, a hard link, or a copy
    (the same content under another name), whose points would be counted twice. Only files of
    equal size and equal first bytes (a LAS/LAZ header holds the tile's bounds and counts) are
    read whole, for their SHA-256."""
    from .archive import sha256_of

    by_inode: dict[tuple[int, int], Path] = {}
    candidates: dict[tuple[int, bytes], list[Path]] = {}
    for f in files:
        try:
            st = os.stat(f)
        except OSError:
            continue  # the reader names a file it cannot open
        first = by_inode.setdefault((st.st_dev, st.st_ino), f)
        if first is not f:
            raise LidarSigError(f"is given twice (also as {first}); give each file once", path=f)
        try:
            with open(f, "rb") as fh:
                head = fh.read(HEAD_BYTES)
        except OSError:
            continue
        candidates.setdefault((st.st_size, head), []).append(f)
    for group in candidates.values():
        if len(group) > 1:
            hashes: dict[str, Path] = {}
            for f in group:
                first = hashes.setdefault(sha256_of(f), f)
                if first is not f:
                    raise LidarSigError(f"holds the same content as {first} (a copy of one tile); give each tile "
                                        "once", path=f)


#: Bytes of a file compared before its content is hashed: a LAS/LAZ header and more.
HEAD_BYTES = 4096


def check_apart(outputs: list[str | os.PathLike[str]], inputs: list[object]) -> None:
    """Refuse an output that is one of the ``inputs`` (the same file under any name, a hard link
    too), or that a folder or glob pattern of the inputs would read as one of its tiles on the
    next run (a point-cloud file in that folder, or one the pattern matches): an output never
    replaces an input nor joins it later. ``inputs``: what a job was given (paths, folders,
    patterns, .vpc files, lists of them; anything else is not a file and is passed over)."""
    from .formats import POINTS, extensions

    cloud_extensions = extensions(POINTS)
    given: list[str | os.PathLike[str]] = []
    for x in inputs:
        if isinstance(x, (list, tuple)):
            given += [y for y in x if isinstance(y, (str, os.PathLike))]
        elif isinstance(x, (str, os.PathLike)):
            given.append(x)
    outs = [Path(o) for o in outputs if o]
    existing = {}
    for o in outs:
        with contextlib.suppress(OSError):
            st = os.stat(o)
            existing[(st.st_dev, st.st_ino)] = o
    for source in given:
        text = str(source)
        listed = tile_list(source)
        folder = Path(text) if listed is None and os.path.isdir(text) else None
        files = listed if listed is not None else [Path(text)] if folder is None else []
        for f in files:
            with contextlib.suppress(OSError):
                st = os.stat(f)
                if (st.st_dev, st.st_ino) in existing:
                    raise LidarSigError(f"is the input {f}; an output never replaces an input: give it another "
                                        "name", path=existing[(st.st_dev, st.st_ino)])
        for o in outs:
            if o.suffix.lower() not in cloud_extensions:
                continue  # a folder or pattern of point clouds never reads it
            absolute = Path(os.path.abspath(o))
            inside = folder is not None and absolute.parent.resolve() == folder.resolve()
            matched = (listed is not None and GLOB & set(text) and not text.lower().endswith(".vpc")
                       and absolute.match(os.path.abspath(text)))
            if inside or matched:
                where = f"the folder {text}" if inside else f"the pattern {text}"
                raise LidarSigError(f"would be read as a tile of {where} on the next run; write it outside "
                                    f"{'it' if inside else 'what the pattern matches'}", path=o)
