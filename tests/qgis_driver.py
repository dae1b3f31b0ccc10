"""QGIS, headless, driven as a GIS analyst would drive it: the lidar_sig plugin installed from its
zip, the Processing algorithms run, the outputs opened and drawn. Run by tests/test_qgis.py with
Debian's Python (``/usr/bin/python3``, where python3-qgis lives) and QT_QPA_PLATFORM=offscreen:

    /usr/bin/python3 tests/qgis_driver.py TASK ARGS.json

TASK is one of ``algorithms``, ``changes``, ``cancel``, ``errors``, ``compare``, ``jobs`` and ``open``; ARGS
the JSON of its arguments (paths). The last line printed is ``RESULT <json>``: what QGIS saw.
"""
import json
import os
import sys
from pathlib import Path

PROCESSING_PLUGINS = "/usr/share/qgis/python/plugins"


def start(plugins, profile):
    """QGIS without its interface, a throwaway profile, Processing, and the plugin from the folder
    ``plugins`` (where its zip was unpacked) loaded as QGIS loads a plugin."""
    from qgis.core import QgsApplication

    QgsApplication.setPrefixPath("/usr", True)
    app = QgsApplication([], False, profile)
    app.initQgis()
    sys.path.append(PROCESSING_PLUGINS)
    from processing.core.Processing import Processing

    Processing.initialize()
    sys.path.insert(0, plugins)
    import lidar_sig_provider

    plugin = lidar_sig_provider.classFactory(None)
    plugin.initProcessing()
    return app, plugin


def recording_feedback(cancel_at=None):
    """A QgsProcessingFeedback that records what the algorithm says: progress values, stage
    texts, log lines; with ``cancel_at``, it cancels once that stage has started."""
    from qgis.core import QgsProcessingFeedback

    class Recorder(QgsProcessingFeedback):
        def __init__(self):
            super().__init__()
            self.stages, self.progress, self.log = [], [], []
            self.progressChanged.connect(self.progress.append)

        def setProgressText(self, text):  # noqa: N802 - QGIS's names
            self.stages.append(text)
            super().setProgressText(text)
            if cancel_at and text == cancel_at:
                self.cancel()

        def pushInfo(self, text):  # noqa: N802
            self.log.append(("info", text))
            super().pushInfo(text)

        def pushWarning(self, text):  # noqa: N802
            self.log.append(("warning", text))
            super().pushWarning(text)

        def pushCommandInfo(self, text):  # noqa: N802
            self.log.append(("command", text))
            super().pushCommandInfo(text)

        def pushConsoleInfo(self, text):  # noqa: N802
            self.log.append(("console", text))
            super().pushConsoleInfo(text)

    return Recorder()


def changes_parameters(args):
    return {"EPOCH_A": args["a"], "EPOCH_B": args["b"], "OUTPUT": args["map"], "CELLS": args["cells"],
            "POINTS": args.get("points"), "REPORT": args.get("report")}


def describe(layer):
    """What a loaded layer is and how QGIS draws it."""
    from qgis.core import QgsMapLayerType

    out = {"name": layer.name(), "source": layer.source(), "valid": layer.isValid()}
    if layer.type() == QgsMapLayerType.RasterLayer:
        renderer = layer.renderer()
        out.update(kind="raster", renderer=renderer.type(), bands=layer.bandCount())
        if renderer.type() == "singlebandpseudocolor":
            items = renderer.shader().rasterShaderFunction().colorRampItemList()
            out.update(band=renderer.band(), legend=[[i.value, i.label, i.color.name()] for i in items])
    elif layer.type() == QgsMapLayerType.VectorLayer:
        renderer = layer.renderer()
        out.update(kind="vector", renderer=renderer.type(), features=layer.featureCount(),
                   labels=layer.labelsEnabled(), crs=layer.crs().authid())
        if renderer.type() == "RuleRenderer":
            out["rules"] = [rule.label() for rule in renderer.rootRule().children()]
        names = layer.fields().names()
        if "significant" in names and "row" in names:
            out["significant"] = sorted([f["row"], f["col"]] for f in layer.getFeatures() if f["significant"] == 1)
    return out


def picture(project, layers, path):
    """The map of ``layers`` as QGIS draws it, with its legend, as a PNG: a print layout of one
    map (the extent of the first layer) and a legend, exported at 150 dpi."""
    from qgis.core import (QgsLayoutExporter, QgsLayoutItemLabel, QgsLayoutItemLegend, QgsLayoutItemMap,
                           QgsLayoutPoint, QgsLayoutSize, QgsPrintLayout, QgsUnitTypes)

    layout = QgsPrintLayout(project)
    layout.initializeDefaults()
    page = layout.pageCollection().page(0)
    page.setPageSize(QgsLayoutSize(340, 180, QgsUnitTypes.LayoutMillimeters))
    title = QgsLayoutItemLabel(layout)
    title.setText("lidar_sig change map in QGIS: score (colour ramp) and cells (outlined where significant)")
    title.attemptMove(QgsLayoutPoint(8, 4, QgsUnitTypes.LayoutMillimeters))
    title.attemptResize(QgsLayoutSize(280, 10, QgsUnitTypes.LayoutMillimeters))
    layout.addLayoutItem(title)
    item = QgsLayoutItemMap(layout)
    item.attemptMove(QgsLayoutPoint(8, 16, QgsUnitTypes.LayoutMillimeters))
    item.attemptResize(QgsLayoutSize(170, 156, QgsUnitTypes.LayoutMillimeters))
    item.setLayers(layers)
    extent = layers[-1].extent()
    extent.scale(1.05)
    item.setExtent(extent)
    layout.addLayoutItem(item)
    legend = QgsLayoutItemLegend(layout)
    legend.setLinkedMap(item)
    legend.setTitle("Legend")
    legend.attemptMove(QgsLayoutPoint(184, 16, QgsUnitTypes.LayoutMillimeters))
    layout.addLayoutItem(legend)
    settings = QgsLayoutExporter.ImageExportSettings()
    settings.dpi = 150
    result = QgsLayoutExporter(layout).exportToImage(str(path), settings)
    return result == QgsLayoutExporter.Success


# -- the tasks --------------------------------------------------------------------------------

def algorithms(args):
    from qgis.core import QgsApplication

    provider = QgsApplication.processingRegistry().providerById("lidarsig")
    algs = provider.algorithms()
    return {"provider": provider.name(), "long_name": provider.longName(),
            "algorithms": sorted(a.id() for a in algs),
            "parameters": {a.id(): [p.name() for p in a.parameterDefinitions()] for a in algs},
            "help": {a.id(): bool(a.shortHelpString()) for a in algs},
            "choices": {f"{a.id()}:{p.name()}": p.options() for a in algs for p in a.parameterDefinitions()
                        if p.type() == "enum"},
            "groups": sorted({a.group() for a in algs})}


def changes(args):
    """processing.runAndLoadResults of changes: the outputs in the project, drawn in their
    styles; each file opened again by itself; the picture of the map."""
    from qgis.core import QgsProject, QgsRasterLayer, QgsVectorLayer

    import processing

    feedback = recording_feedback()
    results = processing.runAndLoadResults("lidarsig:changes", changes_parameters(args), feedback=feedback)
    project = QgsProject.instance()
    loaded = [describe(layer) for layer in project.mapLayers().values()]
    alone = {"map": describe(QgsRasterLayer(args["map"], "map alone", "gdal")),
             "cells": describe(QgsVectorLayer(args["cells"], "cells alone", "ogr"))}
    raster = next(layer for layer in project.mapLayers().values() if layer.source() == args["map"])
    cells = next(layer for layer in project.mapLayers().values() if layer.source().startswith(args["cells"]))
    drawn = picture(project, [cells, raster], args["picture"]) if args.get("picture") else None
    return {"results": {k: v for k, v in results.items() if isinstance(v, (str, int, float, type(None)))},
            "loaded": loaded, "alone": alone, "picture": drawn, "stages": feedback.stages,
            "progress": feedback.progress, "log": feedback.log}


def cancel(args):
    """processing.run of changes, cancelled once the cells are being compared."""
    from qgis.core import QgsProcessingException

    import processing

    feedback = recording_feedback(cancel_at=args["stage"])
    try:
        processing.run("lidarsig:changes", changes_parameters(args), feedback=feedback)
    except QgsProcessingException as exc:
        message = str(exc)
    else:
        message = None
    return {"exception": message, "stages": feedback.stages, "canceled": feedback.isCanceled(),
            "files": sorted(os.listdir(Path(args["map"]).parent))}


def errors(args):
    """The one-line errors a user meets as QgsProcessingExceptions: a bad input, no lidar-sig to
    run, a destination that is a table in a database rather than a file."""
    from qgis.core import QgsProcessingException

    import processing

    out = {}
    in_a_table = dict(changes_parameters(args), EPOCH_A=args["b"],
                      CELLS=f"ogr:dbname='{Path(args['cells']).with_name('db.gpkg')}' table=\"cells\" (geom)")
    for name, parameters, path in (("bad input", changes_parameters(args), os.environ["PATH"]),
                                   ("no command", changes_parameters(args), "/nonexistent"),
                                   ("a table", in_a_table, os.environ["PATH"])):
        saved = os.environ["PATH"]
        os.environ["PATH"] = path
        try:
            processing.run("lidarsig:changes", parameters, feedback=recording_feedback())
            out[name] = None
        except QgsProcessingException as exc:
            out[name] = str(exc)
        finally:
            os.environ["PATH"] = saved
    out["files"] = sorted(os.listdir(Path(args["map"]).parent))
    return out


def compare(args):
    """processing.run of compare: the metrics as a table."""
    from qgis.core import QgsVectorLayer

    import processing

    results = processing.run("lidarsig:compare", {"A": args["a"], "B": args["b"], "METRICS": "TEMPORARY_OUTPUT"},
                             feedback=recording_feedback())
    table = results["METRICS"]  # a file: the provider writes files only (a GeoPackage table here)
    layer = table if not isinstance(table, str) else QgsVectorLayer(table, "metrics", "ogr")
    return {"fields": layer.fields().names(), "rows": [dict(zip(layer.fields().names(), f.attributes()))
                                                       for f in layer.getFeatures()]}


def jobs(args):
    """processing.run of saliency, signature, catalog, similar and outliers, one after the
    other, as a user runs them on a folder of tiles."""
    from qgis.core import QgsVectorLayer

    import processing

    out = Path(args["out"])
    runs = {
        "saliency": ("lidarsig:saliency", {"INPUT": args["cloud"], "OUTPUT": str(out / "cloud_sal.laz"),
                                           "STRATEGY": "optimal"}),
        "signature": ("lidarsig:signature", {"INPUT": args["cloud"], "OUTPUT": str(out / "cloud.h5"),
                                             "PNG": str(out / "cloud.png")}),
        "catalog": ("lidarsig:catalog", {"INPUT": args["folder"], "OUTPUT": str(out / "survey.h5"), "WORKERS": 1}),
        "similar": ("lidarsig:similar", {"QUERY": args["cloud"], "CATALOGUE": str(out / "survey.h5"), "TOP": 2,
                                         "OUTPUT": "TEMPORARY_OUTPUT"}),
        "outliers": ("lidarsig:outliers", {"CATALOGUE": str(out / "survey.h5"), "OUTPUT": str(out / "tiles.gpkg"),
                                           "REPORT": str(out / "qc.html")}),
    }
    found = {}
    for name, (algorithm, parameters) in runs.items():
        feedback = recording_feedback()
        results = processing.run(algorithm, parameters, feedback=feedback)
        found[name] = {"results": {k: v for k, v in results.items() if isinstance(v, (str, int, float, type(None)))},
                       "stages": feedback.stages, "log": feedback.log}
    table = QgsVectorLayer(found["similar"]["results"]["OUTPUT"], "similar", "ogr")
    found["similar"]["rows"] = [[f["rank"], f["name"], f["distance"]] for f in table.getFeatures()]
    found["files"] = sorted(os.listdir(out))
    return found


def open_alone(args):
    """Files opened by themselves, as a user drags them into QGIS."""
    from qgis.core import QgsRasterLayer, QgsVectorLayer

    out = {}
    for path in args.get("rasters", []):
        out[path] = describe(QgsRasterLayer(path, Path(path).stem, "gdal"))
    for path in args.get("vectors", []):
        out[path] = describe(QgsVectorLayer(path, Path(path).stem, "ogr"))
    return out


TASKS = {"algorithms": algorithms, "changes": changes, "cancel": cancel, "errors": errors, "compare": compare,
         "jobs": jobs, "open": open_alone}


def main(argv):
    task, args = argv[0], json.loads(Path(argv[1]).read_text())
    app, plugin = start(args["plugins"], args["profile"])
    try:
        result = TASKS[task](args)
    finally:
        plugin.unload()
    print("RESULT " + json.dumps(result, default=str), flush=True)
    os._exit(0)  # QGIS's own exit may crash headless after the work is done; the result is out


if __name__ == "__main__":
    main(sys.argv[1:])
