"""GeoPackage files of polygons with attributes (OGC GeoPackage 1.2 vector features), written with
the standard library's sqlite3: GDAL, QGIS and ArcGIS open them as layers.

A GeoPackage is an SQLite database with ``application_id`` 'GPKG' and ``user_version`` 10200,
the tables ``gpkg_spatial_ref_sys`` (CRSs), ``gpkg_contents`` (the layers) and
``gpkg_geometry_columns``, and one table per layer whose geometry column holds GeoPackageBinary
blobs: the "GP" header (version, flags, SRS id, envelope) followed by the geometry as
well-known binary (WKB). Written atomically (:mod:`lidar_sig.io.atomic`).
"""
from __future__ import annotations

import sqlite3
import struct

import numpy as np

from ..errors import LidarSigError
from .atomic import atomic_output

APPLICATION_ID = 0x47504B47  # "GPKG"
USER_VERSION = 10200  # GeoPackage 1.2.0: read by every GDAL since 2.2 (the tables are the same in 1.4)
#: SRS ids the specification requires, and the first id given to a CRS without an EPSG code.
UNDEFINED_CARTESIAN, UNDEFINED_GEOGRAPHIC, CUSTOM_SRS = -1, 0, 100000
_WGS84 = ('GEOGCS["WGS 84",DATUM["WGS_1984",SPHEROID["WGS 84",6378137,298.257223563]],PRIMEM["Greenwich",0],'
          'UNIT["degree",0.0174532925199433],AXIS["Latitude",NORTH],AXIS["Longitude",EAST],AUTHORITY["EPSG","4326"]]')

_SCHEMA = """
CREATE TABLE gpkg_spatial_ref_sys (srs_name TEXT NOT NULL, srs_id INTEGER PRIMARY KEY, organization TEXT NOT NULL,
  organization_coordsys_id INTEGER NOT NULL, definition TEXT NOT NULL, description TEXT);
CREATE TABLE gpkg_contents (table_name TEXT NOT NULL PRIMARY KEY, data_type TEXT NOT NULL, identifier TEXT UNIQUE,
  description TEXT DEFAULT '', last_change DATETIME NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ','now')),
  min_x DOUBLE, min_y DOUBLE, max_x DOUBLE, max_y DOUBLE, srs_id INTEGER,
  CONSTRAINT fk_gc_r_srs_id FOREIGN KEY (srs_id) REFERENCES gpkg_spatial_ref_sys(srs_id));
CREATE TABLE gpkg_geometry_columns (table_name TEXT NOT NULL, column_name TEXT NOT NULL,
  geometry_type_name TEXT NOT NULL, srs_id INTEGER NOT NULL, z TINYINT NOT NULL, m TINYINT NOT NULL,
  CONSTRAINT pk_geom_cols PRIMARY KEY (table_name, column_name), CONSTRAINT uk_gc_table_name UNIQUE (table_name),
  CONSTRAINT fk_gc_tn FOREIGN KEY (table_name) REFERENCES gpkg_contents(table_name),
  CONSTRAINT fk_gc_srs FOREIGN KEY (srs_id) REFERENCES gpkg_spatial_ref_sys (srs_id));
"""


def polygon_blob(ring, srs_id):
    """GeoPackageBinary of a polygon with one ring (K, 2), closed here: the header (magic "GP",
    version 0, flags: little-endian, envelope [minx, maxx, miny, maxy]), then WKB Polygon."""
    ring = np.asarray(ring, np.float64).reshape(-1, 2)
    if len(ring) and not np.array_equal(ring[0], ring[-1]):
        ring = np.vstack([ring, ring[:1]])
    (x0, y0), (x1, y1) = ring.min(axis=0), ring.max(axis=0)
    flags = 0b0000_0011  # envelope kind 1 (bits 1-3), little-endian (bit 0)
    header = b"GP" + struct.pack("<BBi4d", 0, flags, int(srs_id), x0, x1, y0, y1)
    wkb = struct.pack("<BIII", 1, 3, 1, len(ring)) + ring.astype("<f8").tobytes()
    return header + wkb


def srs_record(crs, used):
    """(srs_id, name, organization, code, definition) of a CRS (WKT or None); ``used`` the ids
    taken so far (a CRS without an EPSG code gets the next custom id)."""
    if not crs:
        return UNDEFINED_CARTESIAN, "Undefined cartesian SRS", "NONE", -1, "undefined"
    import pyproj

    parsed = pyproj.CRS.from_user_input(crs)
    if parsed.is_compound:  # footprints are plan view: the horizontal member
        parsed = parsed.sub_crs_list[0]
    code = parsed.to_epsg(min_confidence=70)
    try:
        definition = parsed.to_wkt("WKT1_GDAL")
    except pyproj.exceptions.CRSError:
        definition = parsed.to_wkt()
    if code is not None:
        return int(code), parsed.name, "EPSG", int(code), definition
    srs_id = max([CUSTOM_SRS - 1, *used]) + 1
    return srs_id, parsed.name, "NONE", srs_id, definition


def _sql_type(values):
    kinds = {type(v) for v in values if v is not None}
    if kinds and kinds <= {int, bool, np.int64}:
        return "INTEGER"
    if kinds and kinds <= {int, float, np.int64, np.float64}:
        return "REAL"
    return "TEXT"


def _value(v):
    if v is None or isinstance(v, (int, float, str)):
        return v if not (isinstance(v, float) and not np.isfinite(v)) else None
    if isinstance(v, (np.integer,)):
        return int(v)
    if isinstance(v, (np.floating,)):
        return float(v) if np.isfinite(v) else None
    if isinstance(v, (list, tuple)):
        return ", ".join(map(str, v))
    return str(v)


def write_geopackage(path, layers, *, overwrite=False):
    """Write ``layers`` to the GeoPackage ``path``: {CRS (WKT or None): [(ring (K, 2), {field:
    value}), ...]}, one layer per CRS, named "tiles" (with one CRS) or "tiles_<EPSG code>". Every
    feature of a layer has the same fields; values are numbers, text or lists (written as
    text)."""
    if not str(path).lower().endswith(".gpkg"):
        raise LidarSigError("a GeoPackage is written as .gpkg", path=path)
    with atomic_output(path, overwrite=overwrite) as tmp:
        con = sqlite3.connect(tmp)
        try:
            con.execute(f"PRAGMA application_id = {APPLICATION_ID}")
            con.execute(f"PRAGMA user_version = {USER_VERSION}")
            con.executescript(_SCHEMA)
            con.executemany("INSERT INTO gpkg_spatial_ref_sys VALUES (?, ?, ?, ?, ?, ?)", [
                ("WGS 84 geodetic", 4326, "EPSG", 4326, _WGS84, "longitude/latitude on the WGS 84 ellipsoid"),
                ("Undefined cartesian SRS", UNDEFINED_CARTESIAN, "NONE", -1, "undefined", "undefined cartesian"),
                ("Undefined geographic SRS", UNDEFINED_GEOGRAPHIC, "NONE", 0, "undefined", "undefined geographic")])
            used = []
            for crs, features in layers.items():
                srs_id, name, org, code, definition = srs_record(crs, used)
                used.append(srs_id)
                if srs_id not in (UNDEFINED_CARTESIAN, 4326):
                    con.execute("INSERT OR IGNORE INTO gpkg_spatial_ref_sys VALUES (?, ?, ?, ?, ?, ?)",
                                (name, srs_id, org, code, definition, name))
                table = "tiles" if len(layers) == 1 else f"tiles_{srs_id if srs_id >= 0 else 'no_crs'}"
                _write_layer(con, table, srs_id, features)
            con.commit()
        except sqlite3.Error as exc:  # a full disk: "database or disk is full"
            full = getattr(exc, "sqlite_errorname", "") == "SQLITE_FULL" or "is full" in str(exc)
            reason = "no space left on the device; free some space or write elsewhere" if full else \
                f"{exc}; check the output folder"
            raise LidarSigError(f"could not be written: {reason}", path=path) from None
        finally:
            con.close()


def _write_layer(con, table, srs_id, features):
    fields = list(features[0][1]) if features else []
    types = {f: _sql_type([attrs.get(f) for _, attrs in features]) for f in fields}
    columns = "".join(f', "{f}" {types[f]}' for f in fields)
    con.execute(f'CREATE TABLE "{table}" (fid INTEGER PRIMARY KEY AUTOINCREMENT NOT NULL, geom POLYGON{columns})')
    marks = ", ".join("?" * (len(fields) + 1))
    names = ", ".join(["geom"] + [f'"{f}"' for f in fields])
    rings = [np.asarray(r, np.float64).reshape(-1, 2) for r, _ in features]
    con.executemany(f'INSERT INTO "{table}" ({names}) VALUES ({marks})',
                    [(polygon_blob(r, srs_id), *[_value(a.get(f)) for f in fields]) for r, (_, a) in
                     zip(rings, features)])
    allxy = np.concatenate(rings) if rings else np.zeros((1, 2))
    (x0, y0), (x1, y1) = allxy.min(axis=0), allxy.max(axis=0)
    con.execute("INSERT INTO gpkg_contents (table_name, data_type, identifier, description, min_x, min_y, max_x, "
                "max_y, srs_id) VALUES (?, 'features', ?, ?, ?, ?, ?, ?, ?)",
                (table, table, "tile footprints (convex hulls) with their scores", float(x0), float(y0), float(x1),
                 float(y1), srs_id))
    con.execute("INSERT INTO gpkg_geometry_columns VALUES (?, 'geom', 'POLYGON', ?, 0, 0)", (table, srs_id))
