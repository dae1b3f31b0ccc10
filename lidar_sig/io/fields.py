"""The per-point outputs every format writes (docs/method.md, "Point-cloud output"): their values
by name, the names they are written under beside a user's own attributes, and the header comment
that lists them.

LAS/LAZ keeps them as extra dimensions (:mod:`lidar_sig.io.las`), PLY, PCD and text as
attributes or columns (:mod:`lidar_sig.io._table`); every writer takes :class:`Fields` (from
:func:`saliency_fields`, and :func:`change_fields` for a change map's points) and its names from
:func:`output_names`.
"""
from __future__ import annotations

import numpy as np

from ..base.errors import LidarSigError
from ..method.scales import ScaleKind

#: Prefix of our names when the input already has an attribute of the same name that is not ours.
PREFIX = "lidar_sig_"
#: First word of the header comment (PLY, PCD, text) that lists our outputs.
MARKER = "lidar_sig"
#: The per-point change of a change map's later epoch (``changes --points``): each point gets its
#: cell's score (``{score}`` the ranking metric), level of detection and significance; the LAS
#: descriptions (at most 32 bytes), which also mark them as ours.
CHANGE_DESCRIPTIONS = {"ChangeScore": "cell change score ({score})",
                       "ChangeLoD": "cell level of detection of score",
                       "ChangeSignificant": "1 cell changed significantly"}
#: Descriptions of the saliency's outputs (at most 32 bytes, as LAS extra dimensions keep them;
#: they also mark a dimension as ours); OptimalScale's says what its value is, per kind of scales.
SALIENCY_DESCRIPTIONS = {"Cl": "line-type saliency Cl [0,1]", "Cs": "surface-type saliency Cs [0,1]",
                         "Cp": "point-type saliency Cp [0,1]", "Egeom": "geometric entropy [nats]",
                         "GeomClass": "1 line 2 surface 3 point 0 none"}
OPTIMAL_DESCRIPTIONS = {ScaleKind.KNN: "k of minimum-entropy scale", ScaleKind.RADIUS: "index of min-entropy radius"}
#: Outputs written together, each group by one kind of run: a run replaces its own group only.
OUTPUT_GROUPS = ((*SALIENCY_DESCRIPTIONS, "OptimalScale"), tuple(CHANGE_DESCRIPTIONS))


class Fields(dict):
    """Per-point outputs: name -> (N,) values (their dtype is the type they are written in), and
    ``descriptions``, name -> a description of at most 32 bytes (where a format keeps one).
    ``update`` takes another Fields' descriptions with its values."""

    def __init__(self, values=(), descriptions=None):
        super().__init__(values)
        self.descriptions = dict(descriptions or {})

    def update(self, other=(), **kwargs):
        super().update(other, **kwargs)
        self.descriptions.update(getattr(other, "descriptions", {}))


def saliency_fields(saliency, scale_kind=None, scale_values=None):
    """Per-point outputs by their LAS names: Cl, Cs, Cp, Egeom (float32), GeomClass (uint16) and,
    for Optimal-scale, OptimalScale (uint16: the chosen k, or the 1-based radius index; 0 where
    undefined), with their descriptions. Every writer uses these."""
    fields = Fields({"Cl": saliency.cl.astype(np.float32), "Cs": saliency.cs.astype(np.float32),
                     "Cp": saliency.cp.astype(np.float32), "Egeom": saliency.egeom.astype(np.float32),
                     "GeomClass": saliency.geom_class.astype(np.uint16)}, SALIENCY_DESCRIPTIONS)
    if saliency.optimal_scale is not None:
        chosen = saliency.optimal_scale
        kind = ScaleKind(scale_kind) if scale_kind is not None else ScaleKind.RADIUS
        if kind.by_count:
            value = np.where(chosen >= 0, np.asarray(scale_values)[np.maximum(chosen, 0)], 0)
        else:
            value = chosen + 1
        fields["OptimalScale"] = value.astype(np.uint16)
        fields.descriptions["OptimalScale"] = OPTIMAL_DESCRIPTIONS[kind]
    return fields


def change_fields(score, lod, significant, score_name):
    """The per-point change (:data:`CHANGE_DESCRIPTIONS`) as :class:`Fields`: ChangeScore and
    ChangeLoD float32 (NaN where the point's cell was not compared), ChangeSignificant uint16 (1
    where the cell changed significantly, else 0; uint16 because QGIS drops 1-byte extra
    dimensions)."""
    return Fields({"ChangeScore": np.asarray(score, np.float32), "ChangeLoD": np.asarray(lod, np.float32),
                   "ChangeSignificant": np.asarray(significant, np.uint16)},
                  {name: text.format(score=score_name) for name, text in CHANGE_DESCRIPTIONS.items()})


def replaced(previous, fields):
    """The outputs an earlier run wrote (``previous``, names plain or prefixed) that writing
    ``fields`` replaces: every one of a group (the saliency's, the per-point change's) one of
    ``fields`` belongs to. A saliency re-run drops a stale OptimalScale and keeps the change
    map's per-point change; a change map's points keep their saliency."""
    def group(name):
        name = name[len(PREFIX):] if name.startswith(PREFIX) else name
        return next((k for k, names in enumerate(OUTPUT_GROUPS) if name in names), None)

    written = {group(name) for name in fields} - {None}
    return tuple(name for name in previous if group(name) in written)


def output_names(fields, existing, previous=(), *, path=None):
    """Names to write the per-point ``fields`` under, and a note (or None).

    ``existing`` are the attribute names the output already holds, ``previous`` those of them an
    earlier lidar_sig run wrote (the caller drops them: they are replaced). When the input has
    an attribute of its own under one of our names, every field is written as ``lidar_sig_<name>``
    so that nothing of the user's is overwritten.
    """
    own = set(existing) - set(previous)
    clash = [n for n in fields if n in own]
    if not clash:
        return {n: n for n in fields}, None
    names = {n: PREFIX + n for n in fields}
    taken = [v for v in names.values() if v in own]
    if taken:
        raise LidarSigError(f"has its own attributes {', '.join(clash + taken)}, named like lidar_sig's "
                            "outputs; rename them before running", path=path or "input")
    note = (f"the input has its own {', '.join(clash)} (not written by lidar_sig), kept as they are; "
            f"the saliency is written as {', '.join(names.values())}")
    return names, note


def marker(outputs):
    """The header comment naming the attributes a lidar_sig run wrote."""
    from .. import __version__

    return f"{MARKER} {__version__} outputs: {' '.join(outputs)}"


def parse_marker(comments):
    """The output names listed by a :func:`marker` among header ``comments``, else ()."""
    for text in comments:
        words = text.replace(",", " ").split()
        if len(words) > 2 and words[0] == MARKER and words[2] == "outputs:":
            return tuple(words[3:])
    return ()
