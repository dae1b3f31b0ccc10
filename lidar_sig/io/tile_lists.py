"""Sets of tiles named by one text: a glob pattern of tiles (``"2019/*.laz"``) or a virtual point
cloud file (``.vpc``: a STAC ItemCollection, one feature per tile, as QGIS and PDAL write it).
Used wherever a set of tiles is taken: a change map's epoch, the inputs of a tiled run."""
from __future__ import annotations

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
    from . import CLOUD_EXTENSIONS  # the installed formats', made when first asked for

    text = str(source)
    if text.lower().endswith(".vpc"):
        return _vpc_paths(Path(text))
    if GLOB & set(text) and not Path(text).exists():
        import glob

        paths = sorted(Path(p) for p in glob.glob(text) if Path(p).suffix.lower() in CLOUD_EXTENSIONS
                       and Path(p).is_file())
        if not paths:
            raise LidarSigError(f"matches no point-cloud file ({', '.join(CLOUD_EXTENSIONS)}); check the pattern, "
                                "and quote it so that the shell does not expand it", path=text)
        return paths
    return None


def _vpc_paths(path: Path) -> list[Path]:
    """The tiles a virtual point cloud file lists (:func:`tile_list`), as :func:`vpc_tiles` reads them."""
    from .remote import is_url

    hrefs = [href for href, _ in vpc_tiles(str(path))]
    remote = [h for h in hrefs if is_url(h)]
    if remote:
        raise LidarSigError(f"lists {remote[0]}, a URL; give the .vpc to a command or job (they read URLs by range "
                            "requests), or download the tiles", path=path)
    paths = [Path(h) for h in hrefs]  # relative ones resolved against the .vpc's folder
    missing = [p for p in paths if not p.is_file()]
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

    try:
        text = fetch(source).decode("utf-8-sig") if is_url(source) else Path(source).read_text(encoding="utf-8-sig")
        features = json.loads(text)["features"]
        found = []
        for f in features:
            href = next(a["href"] for a in f["assets"].values() if "data" in a.get("roles", ["data"]))
            if not isinstance(href, str) or not href:
                raise TypeError(f"an href is {type(href).__name__}, not a path or URL")
            if not is_url(href) and not Path(href).is_absolute():
                href = urljoin(source, href) if is_url(source) else str(Path(source).parent / href)
            found.append((href, _proj_bounds(f.get("properties") or {})))
    except FileNotFoundError:
        raise LidarSigError("does not exist; give an existing .vpc file", path=source) from None
    except (OSError, ValueError, KeyError, TypeError, StopIteration, AttributeError) as exc:
        raise LidarSigError(f"cannot be read as a virtual point cloud ({type(exc).__name__}: {exc}); give a .vpc "
                            "file as QGIS or PDAL write it (a STAC ItemCollection of the tiles)", path=source) from None
    if not found:
        raise LidarSigError("lists no tile; give a .vpc file that lists the epoch's tiles", path=source)
    return found


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
