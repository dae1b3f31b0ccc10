"""QGIS, headless, driven as a GIS analyst would drive it: the lidar_sig plugin installed from its
zip, the Processing algorithms run, the outputs opened and drawn. Run by tests/test_qgis.py with
Debian's Python (``/usr/bin/python3``, where python3-qgis lives) and QT_QPA_PLATFORM=offscreen:

    /usr/bin/python3 tests/qgis_driver.py TASK ARGS.json

TASK is one of ``algorithms``, ``changes``, ``temporary``, ``dialog``, ``nothing``, ``cancel``, ``resume``,
``errors``, ``compare``, ``jobs``, ``shades`` and ``open``; ARGS the JSON of its arguments (paths).
The last line printed is ``RESULT <json>``: what QGIS saw.
"""
import json
import os
import sys
from contextlib import contextmanager
from pathlib import Path

PROCESSING_PLUGINS = "/usr/share/qgis/python/plugins"


def start(plugins, profile):
    """QGIS without its interface, a throwaway profile (its temporary outputs in it), Processing,
    and the plugin from the folder ``plugins`` (where its zip was unpacked) loaded as QGIS loads
    a plugin."""
    from qgis.core import QgsApplication

    QgsApplication.setPrefixPath("/usr", True)
    app = QgsApplication([], False, profile)
    app.initQgis()
    sys.path.append(PROCESSING_PLUGINS)
    from processing.core.Processing import Processing
    from processing.core.ProcessingConfig import ProcessingConfig

    Processing.initialize()
    temporary = Path(profile) / "temporary outputs"  # in the test's folder, not left in /tmp
    temporary.mkdir(parents=True, exist_ok=True)
    ProcessingConfig.setSettingValue(ProcessingConfig.TEMP_PATH, str(temporary))
    sys.path.insert(0, plugins)
    import lidar_sig_provider

    plugin = lidar_sig_provider.classFactory(None)
    plugin.initProcessing()
    return app, plugin


def recording_feedback(cancel_at=None, percent=0):
    """A QgsProcessingFeedback that records what the algorithm says: progress values, stage
    texts, log lines, errors; with ``cancel_at``, it cancels once that stage has started and
    reached ``percent``."""
    from qgis.core import QgsProcessingFeedback

    class Recorder(QgsProcessingFeedback):
        def __init__(self):
            super().__init__()
            self.stages, self.progress, self.log = [], [], []
            self.progressChanged.connect(self.progress.append)

        def setProgressText(self, text):  # noqa: N802 - QGIS's names
            self.stages.append(text)
            super().setProgressText(text)
            self.cancel_now(0)

        def setProgress(self, value):  # noqa: N802
            super().setProgress(value)
            self.cancel_now(value)

        def cancel_now(self, value):
            if cancel_at and self.stages and self.stages[-1] == cancel_at and value >= percent:
                self.cancel()

        def reportError(self, text, fatalError=False):  # noqa: N802, N803
            self.log.append(("error", text))
            super().reportError(text, fatalError)

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
            "POINTS": args.get("points"), "REPORT": args.get("report"), "CELL": args.get("cell", 0),
            "OPTIONS": args.get("options", "")}


@contextmanager
def stderr_into(path):
    """This process's stderr, where GDAL prints its errors, written to the file ``path`` while
    inside (the command's stderr is read by the provider, not here)."""
    sys.stderr.flush()
    saved = os.dup(2)
    with open(path, "w") as fh:
        os.dup2(fh.fileno(), 2)
    try:
        yield
    finally:
        sys.stderr.flush()
        os.dup2(saved, 2)
        os.close(saved)


def gdal_errors(path):
    """The lines of a captured stderr that GDAL printed as errors or warnings."""
    return [line for line in Path(path).read_text(errors="replace").splitlines()
            if line.startswith(("ERROR", "Warning"))]


def layer_order(project):
    """The sources of the project's layers in its layer tree, top first: the order QGIS draws them."""
    return [node.layer().source() for node in project.layerTreeRoot().findLayers()]


def legend_texts(layer):
    """The texts of the layer's entries in the Layers panel's legend, as QGIS makes them from
    its style: a raster's band title and classes, a vector layer's rules."""
    from qgis.core import QgsLayerTreeLayer
    from qgis.PyQt.QtCore import Qt

    node = QgsLayerTreeLayer(layer)
    legend = layer.legend()
    if legend is None:
        return []
    return [item.data(Qt.DisplayRole) for item in legend.createLayerTreeModelLegendNodes(node)]


def describe(layer):
    """What a loaded layer is and how QGIS draws it."""
    from qgis.core import QgsMapLayerType

    out = {"name": layer.name(), "source": layer.source(), "valid": layer.isValid(), "legend_texts": legend_texts(layer),
           "crs": layer.crs().authid()}
    if layer.type() == QgsMapLayerType.RasterLayer:
        renderer = layer.renderer()
        out.update(kind="raster", renderer=renderer.type(), bands=layer.bandCount())
        if renderer.type() == "singlebandpseudocolor":
            items = renderer.shader().rasterShaderFunction().colorRampItemList()
            out.update(band=renderer.band(), legend=[[i.value, i.label, i.color.name()] for i in items])
    elif layer.type() == QgsMapLayerType.VectorLayer:
        renderer = layer.renderer()  # None for a table without geometry
        out.update(kind="vector", renderer=renderer.type() if renderer else None, features=layer.featureCount(),
                   labels=layer.labelsEnabled(), crs=layer.crs().authid())
        if renderer is not None and renderer.type() == "RuleRenderer":
            out["rules"] = [rule.label() for rule in renderer.rootRule().children()]
        names = layer.fields().names()
        out["aliases"] = {f.name(): f.alias() for f in layer.fields() if f.alias()}
        out["precision"] = {name: layer.editorWidgetSetup(k).config().get("Precision") for k, name in enumerate(names)
                            if layer.editorWidgetSetup(k).type() == "Range"}
        if "coverage" in names and "points_a" in names:
            out["cells"] = [{k: f[k] for k in ("row", "col", "coverage", "points_a", "points_b")}
                            for f in layer.getFeatures()]
        if renderer is not None and renderer.type() == "RuleRenderer" and "row" in names:
            out["matched"] = matched_cells(layer, renderer.rootRule().children())
        if "significant" in names and "row" in names:
            out["significant"] = sorted([f["row"], f["col"]] for f in layer.getFeatures() if f["significant"] == 1)
    return out


def matched_cells(layer, rules):
    """{rule's legend label: sorted [row, col] of the cells its filter draws}, evaluated by
    QGIS's own expression engine on the layer's features."""
    from qgis.core import QgsExpression, QgsExpressionContext, QgsExpressionContextUtils

    context = QgsExpressionContext()
    context.appendScopes(QgsExpressionContextUtils.globalProjectLayerScopes(layer))
    found = {}
    for rule in rules:
        expression = QgsExpression(rule.filterExpression())
        expression.prepare(context)
        cells = []
        for feature in layer.getFeatures():
            context.setFeature(feature)
            if expression.evaluate(context):
                cells.append([feature["row"], feature["col"]])
        found[rule.label()] = sorted(cells)
    return found


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
    title.setText("lidar_sig change map in QGIS: each cell's distance from its level of detection, and the "
                  "cells above it (outlined where they changed)")
    title.attemptMove(QgsLayoutPoint(8, 4, QgsUnitTypes.LayoutMillimeters))
    title.attemptResize(QgsLayoutSize(280, 10, QgsUnitTypes.LayoutMillimeters))
    layout.addLayoutItem(title)
    item = QgsLayoutItemMap(layout)
    item.attemptMove(QgsLayoutPoint(8, 16, QgsUnitTypes.LayoutMillimeters))
    item.attemptResize(QgsLayoutSize(170, 156, QgsUnitTypes.LayoutMillimeters))
    item.setLayers(layers)  # top first
    extent = layers[-1].extent()
    extent.scale(1.05)
    item.setExtent(extent)
    layout.addLayoutItem(item)
    legend = QgsLayoutItemLegend(layout)
    legend.setLinkedMap(item)
    legend.setTitle("Legend")
    legend.setWrapString("; ")  # the parts of a long band description, each on its line
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
            "help_text": {a.id(): a.shortHelpString() for a in algs},
            "labels": {a.id(): {p.name(): p.description() for p in a.parameterDefinitions()} for a in algs},
            "help_url": {a.id(): a.helpUrl() for a in algs},
            "icons": {a.id(): [not a.icon().isNull(), a.svgIconPath()] for a in [provider, *algs]},
            "options": {a.id(): a.parameterDefinition("OPTIONS").description() for a in algs},
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
    drawn = None
    if args.get("picture"):  # the layers as the project draws them
        drawn = picture(project, project.layerTreeRoot().layerOrder(), args["picture"])
    return {"results": {k: v for k, v in results.items() if isinstance(v, (str, int, float, type(None)))},
            "loaded": loaded, "order": layer_order(project), "alone": alone, "picture": drawn,
            "stages": feedback.stages, "progress": feedback.progress, "log": feedback.log}


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


def chain_model():
    """A Processing model as a user draws it in the Model Designer: catalog of a folder, then
    similar of a query against that catalogue (an intermediate file, a temporary output), the
    similar tiles its output."""
    from qgis.core import (QgsProcessingModelAlgorithm, QgsProcessingModelChildAlgorithm,
                           QgsProcessingModelChildParameterSource, QgsProcessingModelOutput,
                           QgsProcessingModelParameter, QgsProcessingParameterFile)

    source = QgsProcessingModelChildParameterSource
    model = QgsProcessingModelAlgorithm("catalog then similar", "tests")
    for name, behavior in (("folder", QgsProcessingParameterFile.Folder), ("query", QgsProcessingParameterFile.File)):
        model.addModelParameter(QgsProcessingParameterFile(name, name, behavior=behavior),
                                QgsProcessingModelParameter(name))
    catalog = QgsProcessingModelChildAlgorithm("lidarsig:catalog")
    catalog.setChildId("catalog")
    catalog.addParameterSources("INPUT", [source.fromModelParameter("folder")])
    catalog.addParameterSources("WORKERS", [source.fromStaticValue(1)])
    model.addChildAlgorithm(catalog)
    similar = QgsProcessingModelChildAlgorithm("lidarsig:similar")
    similar.setChildId("similar")
    similar.addParameterSources("QUERY", [source.fromModelParameter("query")])
    similar.addParameterSources("CATALOGUE", [source.fromChildOutput("catalog", "OUTPUT")])
    similar.addParameterSources("TOP", [source.fromStaticValue(2)])
    output = QgsProcessingModelOutput("similar tiles")
    output.setChildId("similar")
    output.setChildOutputName("OUTPUT")
    similar.setModelOutputs({"similar tiles": output})
    model.addChildAlgorithm(similar)
    return model


def temporary(args):
    """Every algorithm that writes, every output "[Create temporary layer]" as the dialog proposes,
    through processing.run and processing.runAndLoadResults; then the model catalog -> similar.
    For each run: its results, which returned paths exist, the layers it added to the project
    (in the order drawn, top first), the errors Processing reported and what GDAL printed."""
    from qgis.core import QgsProject

    import processing

    temp = "TEMPORARY_OUTPUT"
    runs = {
        "saliency": ("lidarsig:saliency", {"INPUT": args["cloud"], "OUTPUT": temp}),
        "signature": ("lidarsig:signature", {"INPUT": args["cloud"], "OUTPUT": temp, "PNG": temp, "REPORT": temp}),
        "compare": ("lidarsig:compare", {"A": args["cloud"], "B": args["cloud"], "METRICS": temp, "REPORT": temp}),
        "changes": ("lidarsig:changes", {"EPOCH_A": args["a"], "EPOCH_B": args["b"], "OUTPUT": temp, "CELLS": temp,
                                         "POINTS": temp, "REPORT": temp}),
        "no change": ("lidarsig:changes", {"EPOCH_A": args["a"], "EPOCH_B": args["same"], "OUTPUT": temp,
                                           "CELLS": temp}),
        "catalog": ("lidarsig:catalog", {"INPUT": args["folder"], "OUTPUT": temp, "WORKERS": 1}),
        "similar": ("lidarsig:similar", {"QUERY": args["cloud"], "CATALOGUE": args["catalogue"], "TOP": 2,
                                         "OUTPUT": temp}),
        "outliers": ("lidarsig:outliers", {"CATALOGUE": args["catalogue"], "OUTPUT": temp, "REPORT": temp}),
        "model": (chain_model(), {"folder": args["folder"], "query": args["cloud"], "similar:similar tiles": temp}),
    }
    project = QgsProject.instance()
    found = {}
    for name, (algorithm, parameters) in runs.items():
        for how, run in (("run", processing.run), ("load", processing.runAndLoadResults)):
            before = set(project.mapLayers())
            feedback = recording_feedback()
            captured = Path(args["out"]) / f"stderr {name} {how}.txt"
            with stderr_into(captured):
                results = run(algorithm, dict(parameters), feedback=feedback)
            paths = {k: v for k, v in results.items() if isinstance(v, str) and v.startswith("/")}
            added = [node.layer() for node in project.layerTreeRoot().findLayers() if node.layerId() not in before]
            found[f"{name} {how}"] = {
                "results": {k: v for k, v in results.items() if isinstance(v, (str, int, float, type(None)))},
                "exist": {k: os.path.exists(v.split("|")[0]) for k, v in paths.items()},
                "loaded": [describe(layer) for layer in added], "errors": [t for k, t in feedback.log if k == "error"],
                "gdal": gdal_errors(captured)}
    return found


def dialog(args):
    """changes run as the Processing dialog runs it by default: every output "[Create temporary
    layer]", the algorithm in a background task, then the dialog's loading of the results. What
    it returned, which files exist, the layers added (top first), errors and GDAL's lines."""
    from qgis.core import (QgsApplication, QgsProcessingAlgRunnerTask, QgsProcessingContext,
                           QgsProcessingOutputLayerDefinition, QgsProject)

    from processing.gui.Postprocessing import handleAlgorithmResults

    project = QgsProject.instance()
    algorithm = QgsApplication.processingRegistry().createAlgorithmById("lidarsig:changes")
    context = QgsProcessingContext()
    context.setProject(project)
    feedback = recording_feedback()
    parameters = {"EPOCH_A": args["a"], "EPOCH_B": args["b"], **args.get("parameters", {}),
                  **{name: QgsProcessingOutputLayerDefinition("TEMPORARY_OUTPUT", project)
                     for name in ("OUTPUT", "CELLS")}}
    done = {}
    captured = Path(args["out"]) / "stderr dialog.txt"
    with stderr_into(captured):
        task = QgsProcessingAlgRunnerTask(algorithm, parameters, context, feedback)
        task.executed.connect(lambda ok, results: done.update(ok=ok, results=results))
        QgsApplication.taskManager().addTask(task)
        while "ok" not in done:
            QgsApplication.processEvents()
        handleAlgorithmResults(algorithm, context, feedback, True, parameters)
    results = {k: v for k, v in done["results"].items() if isinstance(v, (str, int, float, type(None)))}
    return {"ok": done["ok"], "results": results,
            "exist": {k: os.path.exists(v) for k, v in results.items() if isinstance(v, str)},
            "loaded": [describe(node.layer()) for node in project.layerTreeRoot().findLayers()],
            "errors": [text for kind, text in feedback.log if kind == "error"], "gdal": gdal_errors(captured)}


def nothing(args):
    """Runs whose command writes nothing (More options "--help"; the executable set to
    /bin/true) and More options with an unbalanced quote: the QgsProcessingException each
    raises, and what is left in the output folder."""
    from qgis.core import QgsProcessingException

    from processing.core.ProcessingConfig import ProcessingConfig

    import processing

    out = Path(args["out"])
    cases = {
        "changes --help": ("lidarsig:changes", dict(changes_parameters(args), OPTIONS="--help"), ""),
        "catalog --help": ("lidarsig:catalog", {"INPUT": args["folder"], "OUTPUT": str(out / "c.h5"),
                                                "OPTIONS": "--help"}, ""),
        "signature --help": ("lidarsig:signature", {"INPUT": args["a"], "OUTPUT": str(out / "s.h5"),
                                                    "PNG": str(out / "s.png"), "OPTIONS": "--help"}, ""),
        "changes /bin/true": ("lidarsig:changes", changes_parameters(args), "/bin/true"),
        "saliency /bin/true": ("lidarsig:saliency", {"INPUT": args["a"], "OUTPUT": str(out / "a.laz")}, "/bin/true"),
        "a quote": ("lidarsig:changes", dict(changes_parameters(args), OPTIONS='--classes "paper'), ""),
    }
    found = {}
    for name, (algorithm, parameters, executable) in cases.items():
        ProcessingConfig.setSettingValue("LIDAR_SIG_EXECUTABLE", executable)
        try:
            processing.run(algorithm, parameters, feedback=recording_feedback())
            found[name] = None
        except QgsProcessingException as exc:
            found[name] = str(exc)
        finally:
            ProcessingConfig.setSettingValue("LIDAR_SIG_EXECUTABLE", "")
    found["files"] = sorted(os.listdir(out))
    return found


def resume(args):
    """A catalogue cancelled halfway through its tiles, saved to a file: the message, then the
    same run with Resume ticked (its log); the same cancel with a temporary catalogue."""
    from qgis.core import QgsProcessingException

    import processing

    found = {}
    for name, output, again in (("file", args["catalogue"], True), ("temporary", "TEMPORARY_OUTPUT", False)):
        parameters = {"INPUT": args["folder"], "OUTPUT": output, "WORKERS": 1}
        feedback = recording_feedback(cancel_at="tiles", percent=args["percent"])
        try:
            processing.run("lidarsig:catalog", parameters, feedback=feedback)
            found[name] = None
        except QgsProcessingException as exc:
            found[name] = str(exc)
        if again:
            feedback = recording_feedback()
            results = processing.run("lidarsig:catalog", dict(parameters, RESUME=True), feedback=feedback)
            found["resumed"] = {"log": feedback.log, "exists": os.path.exists(results["OUTPUT"])}
    return found


def shades(args):
    """Change maps opened by themselves in their styles: the colour each style gives a list of
    distances from the level of detection, and the colour QGIS draws at the centre of every
    cell (a picture of ``pixels`` px per cell), by row and column; what GDAL printed."""
    from qgis.core import QgsMapRendererParallelJob, QgsMapSettings, QgsRasterLayer
    from qgis.PyQt.QtCore import QSize
    from qgis.PyQt.QtGui import QColor

    found = {}
    px = args["pixels"]
    for path in args["maps"]:
        captured = Path(path).with_suffix(".stderr.txt")
        with stderr_into(captured):
            layer = QgsRasterLayer(path, Path(path).stem, "gdal")
            shader = layer.renderer().shader().rasterShaderFunction()
            given = {repr(v): QColor(*shader.shade(v)[1:4]).name() for v in args["values"]}
            settings = QgsMapSettings()
            settings.setLayers([layer])
            settings.setExtent(layer.extent())
            settings.setOutputSize(QSize(layer.width() * px, layer.height() * px))
            settings.setBackgroundColor(QColor(255, 255, 255))
            job = QgsMapRendererParallelJob(settings)
            job.start()
            job.waitForFinished()
            image = job.renderedImage()
        cells = {f"{r},{c}": image.pixelColor(c * px + px // 2, r * px + px // 2).name()
                 for r in range(layer.height()) for c in range(layer.width())}
        found[path] = {"renderer": describe(layer), "values": given, "cells": cells, "gdal": gdal_errors(captured)}
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


TASKS = {"algorithms": algorithms, "changes": changes, "temporary": temporary, "dialog": dialog, "nothing": nothing,
         "cancel": cancel, "resume": resume, "errors": errors, "compare": compare, "jobs": jobs, "shades": shades,
         "open": open_alone}


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
