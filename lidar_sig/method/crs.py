"""The coordinate reference system of a cloud and the linear units of its coordinates.

Metric scales (radii, cell sizes) are in metres; a survey in feet has its coordinates converted
before the neighbour search (horizontal and vertical units may differ: US surveys often give
US survey feet horizontally and metres vertically). The units come from the CRS: a LAS file's
WKT record, or its GeoTIFF keys (the projected CRS's EPSG code or ProjLinearUnitsGeoKey, the
vertical CRS's code or VerticalUnitsGeoKey). Without a CRS the coordinates are taken as metres,
and results say so.
"""
from __future__ import annotations

import os
from contextlib import contextmanager
from dataclasses import dataclass

from ..base.errors import LidarSigError

#: The environment variable that holds the CRS given for clouds whose header carries none
#: (:func:`clouds_crs`): every process of a run reads it, the processes a run starts too.
GIVEN_CRS = "LIDAR_SIG_CRS"

# GeoTIFF keys (GeoTIFF 1.0 specification, section 6.2)
_PROJECTED_CS = 3072
_PROJ_LINEAR_UNITS = 3076
_VERTICAL_CS = 4096
_VERTICAL_UNITS = 4099
# GeoTIFF/EPSG linear unit codes -> (metres per unit, name)
_UNIT_CODES = {9001: (1.0, "metre"), 9002: (0.3048, "foot"), 9003: (1200.0 / 3937.0, "US survey foot"),
               9036: (1000.0, "kilometre")}


@dataclass(frozen=True)
class Units:
    """Metres per coordinate unit, horizontally (x, y) and vertically (z).

    ``known`` is False when nothing said what the unit is and metres were assumed.
    """

    horizontal: float = 1.0
    vertical: float = 1.0
    name: str = "metre"
    known: bool = False

    @property
    def factors(self):
        """(3,) metres per unit of x, y and z."""
        return (self.horizontal, self.horizontal, self.vertical)

    def describe(self):
        """E.g. ``metre (from the CRS)``, ``US survey foot, vertical metre (from the CRS)`` or
        ``metre (assumed: no CRS)``."""
        if not self.known:
            return "metre (assumed: no CRS)"
        text = self.name
        if self.vertical != self.horizontal:
            text += f", vertical {_unit_name(self.vertical)}"
        return text + " (from the CRS)"


#: Units of a cloud whose CRS is unknown.
ASSUMED_METRES = Units()


def _unit_name(factor):
    for value, name in _UNIT_CODES.values():
        if abs(value - factor) < 1e-12 * value:
            return name
    return f"{factor:g} m"


def units_of(crs, *, path=None):
    """Units of coordinates in ``crs`` (a pyproj CRS, WKT, "EPSG:n", or None for unknown).

    A compound CRS gives the horizontal unit of its first member and the vertical unit of its
    second; a projected CRS alone gives its unit for z too (the LAS convention when no vertical
    CRS is given). A geographic CRS (degrees) is refused: nothing metric can be measured in it.
    """
    if crs is None:
        return ASSUMED_METRES
    import pyproj

    try:
        crs = crs if isinstance(crs, pyproj.CRS) else pyproj.CRS.from_user_input(crs)
    except pyproj.exceptions.CRSError as exc:
        raise LidarSigError(f"cannot read its CRS ({str(exc).splitlines()[0][:100]}); give a valid "
                            "CRS or none", path=path) from None
    members = crs.sub_crs_list if crs.is_compound else [crs]
    horizontal = members[0]
    if horizontal.is_geographic:
        raise LidarSigError(f"its CRS {horizontal.name!r} is geographic (degrees): distances cannot be "
                            "measured in it; reproject the cloud to a projected CRS first", path=path)
    h_axis = horizontal.axis_info[0]
    v_factor = h_axis.unit_conversion_factor
    if len(members) > 1 and members[1].axis_info:
        v_factor = members[1].axis_info[0].unit_conversion_factor
    return Units(h_axis.unit_conversion_factor, v_factor, h_axis.unit_name, True)


def las_crs(header):
    """The pyproj CRS of a LAS header (its WKT record, else its GeoTIFF keys, compound when a
    vertical EPSG code is given), or None when it has none or it cannot be read."""
    import pyproj

    try:
        crs = header.parse_crs()
    except Exception:  # laspy raises several kinds on records it cannot parse
        return None
    if crs is None or crs.is_compound:
        return crs
    vertical = _geokeys(header).get(_VERTICAL_CS, 0)
    if not header.vlrs.get("WktCoordinateSystemVlr") and 1024 <= vertical <= 32766:  # EPSG range
        try:
            v = pyproj.CRS.from_epsg(vertical)
            return pyproj.crs.CompoundCRS(f"{crs.name} + {v.name}", [crs, v])
        except pyproj.exceptions.CRSError:
            return crs
    return crs


def given_crs(crs, *, said="--crs"):
    """``crs`` (an EPSG code such as "EPSG:28992", WKT or any text pyproj reads) as WKT, checked:
    a CRS pyproj cannot read, or a geographic one (degrees), is refused in one line naming
    ``said``."""
    import pyproj

    try:
        parsed = crs if isinstance(crs, pyproj.CRS) else pyproj.CRS.from_user_input(crs)
    except (pyproj.exceptions.CRSError, TypeError) as exc:
        raise LidarSigError(f"{said} {crs!r} is not a CRS ({str(exc).splitlines()[0][:100]}); give one such as "
                            "EPSG:28992") from None
    if (parsed.sub_crs_list[0] if parsed.is_compound else parsed).is_geographic:
        raise LidarSigError(f"{said} {crs} is geographic (degrees), in which distances cannot be measured; give the "
                            "projected CRS the clouds' coordinates are in")
    return parsed.to_wkt()


@contextmanager
def clouds_crs(crs, *, said="--crs"):
    """Within: every cloud read whose header carries no CRS is in ``crs`` (:func:`given_crs`;
    None: nothing changes), and a cloud that carries another CRS is refused
    (:func:`las_units`). Held in :data:`GIVEN_CRS`, so that the processes a run starts read it."""
    if crs is None:
        yield
        return
    wkt = given_crs(crs, said=said)
    saved = os.environ.get(GIVEN_CRS)
    os.environ[GIVEN_CRS] = wkt
    try:
        yield
    finally:
        if saved is None:
            os.environ.pop(GIVEN_CRS, None)
        else:
            os.environ[GIVEN_CRS] = saved


def las_units(header, *, path=None):
    """(CRS as WKT or None, Units) of a LAS header; the CRS given for clouds without one
    (:func:`clouds_crs`) where the header has none, and a header in another CRS refused.

    GeoTIFF unit keys serve where no EPSG code is given (a user-defined projection).
    """
    crs = las_crs(header)
    given = os.environ.get(GIVEN_CRS)
    if given:
        import pyproj

        check_given(crs.to_wkt() if crs is not None else None, given, path)
        crs = crs or pyproj.CRS.from_user_input(given)
    if crs is not None:
        return crs.to_wkt(), units_of(crs, path=path)
    keys = _geokeys(header)
    if _PROJ_LINEAR_UNITS in keys and keys[_PROJ_LINEAR_UNITS] in _UNIT_CODES:
        h, name = _UNIT_CODES[keys[_PROJ_LINEAR_UNITS]]
        v = _UNIT_CODES.get(keys.get(_VERTICAL_UNITS), (h, name))[0]
        return None, Units(h, v, name, True)
    return None, ASSUMED_METRES


def _geokeys(header):
    """GeoTIFF key id -> value (the short values stored in the directory itself)."""
    vlrs = header.vlrs.get("GeoKeyDirectoryVlr")
    if not vlrs:
        return {}
    return {k.id: k.value_offset for k in vlrs[0].geo_keys if k.tiff_tag_location == 0}


def check_given(crs, given, path=None):
    """Refuse a cloud whose own CRS (WKT, or None) is not the CRS ``given`` for clouds without
    one: its coordinates are in its own CRS, which a given CRS would misname."""
    if crs is not None and not same_crs(crs, given):
        raise LidarSigError(f"carries the CRS {crs_name(crs)}, not the one given ({crs_name(given)}); leave out "
                            "--crs (crs=), which is for clouds without a CRS, or reproject the cloud", path=path)


def cloud_in_given_crs(cloud):
    """``cloud`` (a PointCloud read from a format without a CRS, e.g. PLY or text) in the CRS
    given for clouds without one (:func:`clouds_crs`), with that CRS's units; unchanged when
    none is given; a cloud in another CRS refused."""
    given = os.environ.get(GIVEN_CRS)
    if not given:
        return cloud
    check_given(cloud.crs, given, cloud.path)
    if cloud.crs is None:
        cloud.crs = given
        if not cloud.units.known:
            cloud.units = units_of(given, path=cloud.path)
    return cloud


def same_crs(a, b):
    """Whether two CRS (WKT or any text pyproj reads, or None) are the same; two unknown CRS
    are the same (both taken as metres). The same CRS written differently is the same: another
    name, another WKT version, or a legacy WKT's ``TOWGS84`` clause (a bound CRS: it says how to
    reach WGS 84, the coordinates are those of its source CRS)."""
    if a == b:  # the usual case, tiles of one survey: no parsing
        return True
    if a is None or b is None:
        return False
    import pyproj

    return _unbound(pyproj.CRS.from_user_input(a)) == _unbound(pyproj.CRS.from_user_input(b))


def _unbound(crs):
    """The CRS the coordinates are in: a bound CRS's source, each member of a compound CRS so."""
    import pyproj

    if crs.is_bound:
        return _unbound(crs.source_crs)
    if crs.is_compound:
        members = [_unbound(m) for m in crs.sub_crs_list]
        if any(m is not n for m, n in zip(members, crs.sub_crs_list)):
            return pyproj.crs.CompoundCRS(crs.name, members)
    return crs


def crs_name(crs: str | None) -> str | None:
    """The name of a CRS (WKT or any text pyproj reads) for people, e.g. "RGF93 v1 / Lambert-93";
    None without one, the start of the text itself when pyproj cannot read it."""
    if not crs:
        return None
    try:
        import pyproj

        return pyproj.CRS.from_user_input(crs).name
    except Exception:  # an unreadable CRS text is shown as it is
        return str(crs)[:80]
