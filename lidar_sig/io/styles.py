"""QGIS layer styles (QML, the XML of a ``.qml`` file and of a GeoPackage's ``layer_styles``): a
raster band drawn as a single-band pseudocolour with its legend, and polygon layers drawn by
rules with optional labels.

QGIS opens ``name.tif`` with ``name.qml`` beside it in that style, and a GeoPackage layer with
the style its ``layer_styles`` table marks as default. Only what differs from QGIS's defaults is
written; QGIS 3.x fills in the rest (tests/test_qgis.py opens them in QGIS).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING
from xml.sax.saxutils import quoteattr

if TYPE_CHECKING:
    import os
    from pathlib import Path

_HEAD = "<!DOCTYPE qgis PUBLIC 'http://mrcc.com/qgis.dtd' 'SYSTEM'>\n"


def _colour(rgb, alpha=255):
    return ",".join(str(int(round(c))) for c in (*rgb, alpha))


def _hex(rgb):
    return "#" + "".join(f"{int(round(c)):02x}" for c in rgb)


def raster_qml(band, stops, *, ramp="interpolated", nodata=None):
    """A single-band pseudocolour style of ``band`` (1-based): ``stops`` [(value, (r, g, b),
    label)], ascending, each an entry of the legend. ``ramp`` says how values between stops are
    drawn: "interpolated" (linearly between the stops), "exact" (each value its own colour:
    discrete codes) or "discrete" (classes: a value takes the colour of the first stop it does
    not exceed; the last stop may be ``inf``). No-data pixels stay transparent, or take the
    colour ``nodata`` (RGB)."""
    values = [float(v) for v, _, _ in stops]
    kind = {"interpolated": "INTERPOLATED", "exact": "EXACT", "discrete": "DISCRETE"}[ramp]
    items = "".join(f"<item value={quoteattr(repr(v))} label={quoteattr(label)} color={quoteattr(_hex(rgb))} "
                    'alpha="255"/>' for v, (_, rgb, label) in zip(values, stops))
    finite = [v for v in values if math.isfinite(v)]
    lo, hi = min(finite), max(finite)
    return (_HEAD + '<qgis styleCategories="Symbology"><pipe>'
            f'<rasterrenderer type="singlebandpseudocolor" band="{int(band)}" opacity="1" alphaBand="-1" '
            f'classificationMin={quoteattr(repr(lo))} classificationMax={quoteattr(repr(hi))} '
            f'nodataColor={quoteattr(_colour(nodata) if nodata is not None else "")}>'
            "<rasterTransparency/><minMaxOrigin><limits>None</limits><extent>WholeRaster</extent>"
            "<statAccuracy>Exact</statAccuracy></minMaxOrigin>"
            f'<rastershader><colorrampshader colorRampType="{kind}" classificationMode="1" clip="0" '
            f'minimumValue={quoteattr(repr(lo))} maximumValue={quoteattr(repr(hi))}>{items}'
            '<rampLegendSettings useContinuousLegend="0"/></colorrampshader>'
            "</rastershader></rasterrenderer>"
            '<brightnesscontrast brightness="0" contrast="0"/><huesaturation saturation="0" grayscaleMode="0"/>'
            '<rasterresampler maxOversampling="2"/></pipe><blendMode>0</blendMode></qgis>\n')


@dataclass(frozen=True)
class Rule:
    """One rule of a polygon style: features matching the QGIS expression ``filter`` are drawn
    with a fill (``fill`` RGB, ``fill_alpha`` 0-255; ``pattern`` "solid", "no" or a hatch such
    as "b_diagonal") and an outline (``outline`` RGB, ``width`` mm, ``line`` "solid", "dash" or
    "dot"), with a light ``halo`` (RGB) twice as wide beneath the outline when given, so that a
    dark outline shows on dark fills too; ``label`` is its legend entry."""

    label: str
    filter: str
    outline: tuple
    width: float = 0.26
    line: str = "solid"
    fill: tuple = (255, 255, 255)
    fill_alpha: int = 0
    pattern: str = "no"
    halo: tuple | None = None


def equal(**values):
    """The QGIS expression that each field equals its value (``"coverage" = 'appeared' AND
    "changed" = 1``), for a :class:`Rule`'s filter; :func:`matches` tells the same in Python."""
    return " AND ".join(f'"{k}" = ' + (f"'{v}'" if isinstance(v, str) else repr(v)) for k, v in values.items())


def matches(values, fields):
    """Whether a feature's ``fields`` ({field: value}) hold every value of ``values``, as the
    filter :func:`equal` makes of them selects it in QGIS."""
    return all(fields.get(k) == v for k, v in values.items())


def _fields(aliases, precision):
    """The QML of fields' aliases ({field: alias}) and of the decimals QGIS shows of numbers
    ({field: digits}: the Range widget's precision, which the attribute table, the identify
    results and the forms show the value with)."""
    if not aliases and not precision:
        return ""
    widgets = "".join(
        f'<field name={quoteattr(name)} configurationFlags="None"><editWidget type="Range"><config><Option type="Map">'
        f'<Option type="int" name="Precision" value="{int(digits)}"/><Option type="QString" name="Style" '
        'value="SpinBox"/><Option type="bool" name="AllowNull" value="true"/></Option></config></editWidget></field>'
        for name, digits in (precision or {}).items())
    names = "".join(f"<alias field={quoteattr(name)} name={quoteattr(alias)}/>"
                    for name, alias in (aliases or {}).items())
    return f"<fieldConfiguration>{widgets}</fieldConfiguration><aliases>{names}</aliases>"


def polygon_qml(rules, *, label_expression=None, aliases=None, precision=None):
    """A rule-based style of a polygon layer: ``rules`` (:class:`Rule`, the legend's order;
    a feature drawn by every rule it matches) and, with ``label_expression`` (a QGIS
    expression, NULL for no label), a label over each polygon; fields shown by their
    ``aliases`` ({field: name}) and numbers with ``precision`` decimals ({field: digits})."""
    entries, symbols = [], []
    for k, r in enumerate(rules):
        entries.append(f'<rule key="rule{k}" symbol="{k}" label={quoteattr(r.label)} filter={quoteattr(r.filter)}/>')
        layers = [] if r.halo is None else [_fill_layer((255, 255, 255), 0, "no", r.halo, "solid", 2 * r.width)]
        layers.append(_fill_layer(r.fill, r.fill_alpha, r.pattern, r.outline, r.line, r.width))
        symbols.append(f'<symbol type="fill" name="{k}" alpha="1" clip_to_extent="1" force_rhr="0">{"".join(layers)}'
                       "</symbol>")
    labels = ""
    if label_expression:
        labels = ('<labeling type="simple"><settings calloutType="simple">'
                  f'<text-style fieldName={quoteattr(label_expression)} isExpression="1" fontSize="9" '
                  'fontSizeUnit="Point" textColor="20,20,20,255" fontWeight="75">'
                  '<text-buffer bufferDraw="1" bufferSize="0.8" bufferSizeUnits="MM" '
                  'bufferColor="255,255,255,255" bufferOpacity="1"/></text-style>'
                  '<placement placement="1" polygonPlacementFlags="2"/>'
                  '<rendering drawLabels="1" obstacle="1" displayAll="1"/></settings></labeling>')
    return (_HEAD + f'<qgis styleCategories="Symbology|Labeling|Fields|Forms" labelsEnabled="{1 if labels else 0}">'
            '<renderer-v2 type="RuleRenderer" symbollevels="0" enableorderby="0" forceraster="0">'
            f'<rules key="root">{"".join(entries)}</rules><symbols>{"".join(symbols)}</symbols></renderer-v2>'
            f"{labels}{_fields(aliases, precision)}<blendMode>0</blendMode><featureBlendMode>0</featureBlendMode>"
            "<layerGeometryType>2</layerGeometryType></qgis>\n")


def _fill_layer(fill, fill_alpha, pattern, outline, line, width):
    options = {"color": _colour(fill, fill_alpha), "style": pattern, "outline_color": _colour(outline),
               "outline_style": line, "outline_width": repr(float(width)), "outline_width_unit": "MM",
               "joinstyle": "miter"}
    props = "".join(f'<Option type="QString" name="{k}" value={quoteattr(v)}/>' for k, v in options.items())
    return f'<layer class="SimpleFill" enabled="1" pass="0" locked="0"><Option type="Map">{props}</Option></layer>'


def style_path(path: str | os.PathLike[str]) -> Path:
    """Where QGIS looks for the default style of the file ``path``: beside it, named alike,
    ending in ``.qml`` (``changes.tif`` -> ``changes.qml``)."""
    from pathlib import Path

    return Path(path).with_suffix(".qml")


def write_style(path, qml, *, overwrite=False):
    """Write the QML text ``qml`` to ``path`` (UTF-8), atomically."""
    from .atomic import atomic_output

    with atomic_output(path, overwrite=overwrite) as tmp:
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write(qml)
