"""The provider's algorithms, one per job of the ``lidar-sig`` command: each gathers its
parameters into the command's arguments, runs it (:mod:`.command`), checks that it wrote every
output, and hands its outputs to QGIS: layers added to the project in their own styles and
order, tables of the numbers it printed as JSON."""
import json
import re
import shlex
from pathlib import Path

from qgis.core import (QgsCoordinateReferenceSystem, QgsEditorWidgetSetup, QgsFeature, QgsField, QgsFields,
                       QgsLayerTree, QgsProcessing, QgsProcessingAlgorithm, QgsProcessingContext, QgsProcessingException,
                       QgsProcessingLayerPostProcessorInterface, QgsProcessingOutputNumber, QgsProcessingOutputString,
                       QgsProcessingParameterBoolean, QgsProcessingParameterCrs, QgsProcessingParameterEnum,
                       QgsProcessingParameterExtent,
                       QgsProcessingParameterFeatureSink,
                       QgsProcessingParameterFile, QgsProcessingParameterFileDestination, QgsProcessingParameterNumber,
                       QgsProcessingParameterRasterDestination, QgsProcessingParameterString,
                       QgsProcessingParameterVectorDestination, QgsProcessingUtils, QgsProviderRegistry, QgsRasterLayer,
                       QgsVectorLayer, QgsWkbTypes)
from qgis.PyQt.QtCore import QVariant

from . import command
from .resources import help_url, icon, icon_path
from .settings import executable_setting

#: What the formats hold, as ``lidar-sig plugins --json`` says (lidar_sig.io.formats).
POINTS, SIGNATURE = "points", "signature"
HTML = "HTML files (*.html)"
ALL_FILES = "All files (*.*)"
#: A destination that is no file: a provider's URI ("ogr:dbname=...", "postgres:...", "memory:"; a
#: Windows drive is one letter).
NOT_A_FILE = re.compile(r"^[A-Za-z]{2,}:|dbname=")
#: Where the executable is set, for messages.
SETTING = "Settings > Options > Processing > Providers > lidar_sig"

#: The jobs that read clouds, which take an area of interest (--aoi).
AREA_JOBS = ("saliency", "signature", "compare", "changes", "catalog", "resilience")


def offered(kind):
    """{key: description} of the ``kind`` ("descriptors", "strategies" or "metrics") that the
    lidar-sig run by the provider offers, in its order (:func:`command.listing`): a plugin
    installed beside lidar_sig shows up here; {} when lidar-sig cannot be run (a job's run says
    why)."""
    try:
        executable = command.find_executable(executable_setting())
    except command.CommandError:
        return {}
    return dict(command.listing(executable).get(kind, {}))


def extensions(*holding, written=False):
    """The extensions of the formats that the lidar-sig run by the provider reads (or, with
    ``written``, writes) holding any of ``holding`` ("points", "signature"), in its order: a
    format a plugin adds shows up here."""
    out = []
    for facts in offered("formats").values():
        if set(holding) & set(facts.get("holds", ())) and (not written or facts.get("writes")):
            out += [ext for ext in facts.get("extensions", ()) if ext not in out]
    return out


def file_filter(title, *holding):
    """A file dialog's filter of the files holding any of ``holding``, and of all files."""
    found = extensions(*holding)
    return f"{title} ({' '.join('*' + e for e in found)});;{ALL_FILES}" if found else ALL_FILES


def clouds():
    return file_filter("Point clouds", POINTS)


def clouds_or_archives():
    return file_filter("Point clouds and signature archives", POINTS, SIGNATURE)


def archives():
    found = extensions(SIGNATURE)
    return f"Signature archives ({' '.join('*' + e for e in found)})" if found else ALL_FILES


def cloud_outputs():
    """One filter per extension of the point-cloud formats lidar-sig writes, the first its default."""
    return ";;".join(f"{e[1:].upper()} files (*{e})" for e in extensions(POINTS, written=True)) or ALL_FILES


def metric_names():
    """{name shown: the command's key} of the metrics offered (``delta_KL``: ``kl``), the key
    where lidar-sig gives no name."""
    return {value.get("name") or key: key for key, value in offered("metrics").items()}


def choice(name, description, options):
    """A parameter that picks one of ``options`` by name (a script gives the name, e.g.
    ``"STRATEGY": "optimal"``), not set by default: the command then uses its own default."""
    return QgsProcessingParameterEnum(name, description, list(options), allowMultiple=False, defaultValue=None,
                                      optional=True, usesStaticStrings=True)


def asks_temporary(value):
    """Whether an output's parameter value (a path, or a layer definition whose sink holds one)
    asks QGIS for a temporary output: decided from what was asked, as the path QGIS made of it
    may lie anywhere its settings say."""
    sink = getattr(value, "sink", None)
    if sink is not None:
        value = sink.staticValue()
    return str(value or "") == QgsProcessing.TEMPORARY_OUTPUT


def missing(path):
    """Whether the output file ``path`` (a layer's source may end in ``|layername=...``) is not
    there; a destination that is no file (a database table QGIS wrote) is not checked."""
    return bool(path) and not NOT_A_FILE.search(path) and not Path(path.split("|")[0]).exists()


class LoadOrder:
    """The layers one run adds to the project, top first (the cells above the change map).
    Processing adds a run's layers in the order of their paths, each on top of the others, so
    the opaque raster could hide the cells; once each is added, the run's layers that share its
    group of the layer tree are put back in this order where the topmost of them was."""

    def __init__(self, paths):
        self.paths = [p for p in paths if p]
        self.ids = {}

    def place(self, path, layer, project):
        """Note that ``layer`` (from ``path``) was added to ``project``, and order the run's
        layers added so far (each moved as a copy of its node, then the node removed: QGIS keeps
        a layer in the project while a node shows it)."""
        self.ids[path] = layer.id()
        node = project.layerTreeRoot().findLayer(layer.id()) if project is not None else None
        if node is None or node.parent() is None:
            return
        parent = node.parent()
        wanted = [self.ids[p] for p in self.paths if p in self.ids]  # top first
        here = {child.layerId(): (index, child) for index, child in enumerate(parent.children())
                if QgsLayerTree.isLayer(child) and child.layerId() in wanted}
        if len(here) < 2:
            return
        top = min(index for index, _ in here.values())
        for k, layer_id in enumerate(layer_id for layer_id in wanted if layer_id in here):
            parent.insertChildNode(top + k, here[layer_id][1].clone())
        for _, child in here.values():
            parent.removeChildNode(child)


class StyledLayer(QgsProcessingLayerPostProcessorInterface):
    """Draws a loaded output in the style it carries (the ``.qml`` beside a GeoTIFF, the default
    row of a GeoPackage's ``layer_styles``: Processing loads its outputs without them) and puts
    it in its place among the run's layers (:class:`LoadOrder`)."""

    def __init__(self, path, order):
        super().__init__()
        self.path, self.order = path, order

    def postProcessLayer(self, layer, context, feedback):  # noqa: N802 - QGIS's name
        message, loaded = layer.loadDefaultStyle()
        if loaded:
            layer.triggerRepaint()
        elif feedback is not None:
            feedback.pushInfo(f"{layer.name()}: no style of its own ({message})")
        self.order.place(self.path, layer, context.project())


#: The post-processors given to QGIS, by layer path: one per layer (QGIS takes each over and
#: deletes it once used: a shared one crashed the second layer), kept alive here until then.
_STYLERS = {}


class LidarSigAlgorithm(QgsProcessingAlgorithm):
    """A job of the ``lidar-sig`` command. A subclass sets ``job``, ``label``, ``group_name``,
    ``help`` and ``more_example`` and defines :meth:`parameters` and :meth:`arguments`, and
    :meth:`results` when the command's JSON gives outputs."""

    job = ""
    label = ""
    group_name = ""
    help = ""
    #: Options of this job's command a user may add in More options, as an example ("": none).
    more_example = "--classes paper --k 10,20,30"

    def name(self):
        return self.job

    def displayName(self):  # noqa: N802 - QGIS's names from here on
        return self.label

    def group(self):
        return self.group_name

    def groupId(self):
        return self.group_name.lower().replace(" ", "_")

    def icon(self):
        return icon(self.job)

    def svgIconPath(self):
        return icon_path(self.job)

    def helpUrl(self):
        return help_url(self.job)

    #: Notes on the parameters, in the help: the detail that the dialog's short labels leave out.
    notes = ""

    def shortHelpString(self):
        example = f", e.g. <code>{self.more_example}</code>" if self.more_example else ""
        return (self.help + self.notes + f"<p><b>More options</b> (advanced): any other option of lidar-sig "
                f"{self.job}, as on the command line{example}.</p><p>Runs <code>lidar-sig {self.job}</code> (the "
                "executable set in Settings &gt; "
                "Options &gt; Processing &gt; Providers &gt; lidar_sig, or lidar-sig on PATH); its progress and notes "
                "appear in this log, Cancel stops it with nothing half-written. Help opens the command's page "
                f"(docs/commands/{self.job}.md).</p>")

    def createInstance(self):
        return type(self)()

    def initAlgorithm(self, config=None):
        self.parameters()
        if self.job in AREA_JOBS:  # --aoi: the clouds clipped to the extent (in its CRS) first
            self.addParameter(QgsProcessingParameterExtent("AOI", "Area of interest",
                                                           optional=True))
        options = QgsProcessingParameterString("OPTIONS", "More options (as on the command line)", optional=True)
        options.setFlags(options.flags() | options.FlagAdvanced)
        self.addParameter(options)

    def parameters(self):
        """Add the job's parameters."""
        raise NotImplementedError

    def arguments(self, parameters, context, outputs):
        """The command's arguments after ``lidar-sig``; ``outputs`` are :meth:`destinations`."""
        raise NotImplementedError

    def results(self, parameters, context, feedback, finished, outputs):
        """The algorithm's outputs from the finished run: by default the files it wrote."""
        return dict(outputs)

    def processAlgorithm(self, parameters, context, feedback):
        outputs = self.destinations(parameters, context)
        argv = [str(a) for a in self.arguments(parameters, context, outputs)] + self.area(parameters, context) \
            + self.more_options(parameters, context)
        try:
            executable = command.find_executable(executable_setting())
        except command.CommandError as exc:
            raise QgsProcessingException(exc.message) from None
        feedback.pushCommandInfo(" ".join(shlex.quote(a) for a in [executable, *argv]))
        stage = [None]

        def progress(name, percent):
            if name != stage[0]:
                stage[0] = name
                feedback.setProgressText(name)
            feedback.setProgress(percent)

        try:
            finished = command.run([executable, *argv], on_progress=progress, on_note=feedback.pushWarning,
                                   on_line=feedback.pushConsoleInfo, cancelled=feedback.isCanceled)
        except command.Cancelled as exc:
            raise QgsProcessingException(self.cancelled(exc.message, outputs, parameters)) from None
        except command.CommandError as exc:  # the command's one line, naming the file and the fix
            raise QgsProcessingException(exc.message) from None
        if finished.stdout and not finished.stdout.lstrip().startswith("{"):
            for line in finished.stdout.splitlines():
                feedback.pushInfo(line)
        self.check_written(outputs)
        results = self.results(parameters, context, feedback, finished, outputs)
        destinations = {d.name() for d in self.destinationParameterDefinitions()}
        self.check_written({k: v for k, v in results.items() if k in destinations and isinstance(v, str)})
        return results

    # -- helpers -------------------------------------------------------------------------------

    def area(self, parameters, context):
        """``--aoi "XMIN,YMIN,XMAX,YMAX [CRS]"`` from the extent parameter, or nothing."""
        if self.job not in AREA_JOBS or not parameters.get("AOI"):
            return []
        rect = self.parameterAsExtent(parameters, "AOI", context)
        if rect.isNull():
            return []
        crs = self.parameterAsExtentCrs(parameters, "AOI", context)
        text = f"{rect.xMinimum()!r},{rect.yMinimum()!r},{rect.xMaximum()!r},{rect.yMaximum()!r}"
        return ["--aoi", text + (f" [{crs.authid() or crs.toWkt()}]" if crs.isValid() else "")]

    def destinations(self, parameters, context):
        """{name: path, or None where an optional output is not asked for} of every file the
        command writes, asked of QGIS once per run, for the command and the results alike: each
        ask of a temporary output makes a new path. A layer's ask also has QGIS load it once the
        run ends."""
        found = {}
        for definition in self.destinationParameterDefinitions():
            name, kind = definition.name(), definition.type()
            if kind in ("rasterDestination", "vectorDestination"):
                found[name] = self.layer_file(parameters, name, context) or None
            elif kind == "fileDestination":
                found[name] = self.parameterAsFileOutput(parameters, name, context) or None
        return found

    def check_written(self, outputs):
        """Refuse a run that did not write an output it returns ({name: path}): a command that
        printed only its help (More options ``--help``) or an executable that is not lidar-sig."""
        for name, path in outputs.items():
            if missing(path):
                what = self.parameterDefinition(name).description()
                raise QgsProcessingException(f"{path}: lidar-sig {self.job} ended without writing this output "
                                             f"({what}); check More options (--help, for one, only prints help) and "
                                             f"that the executable set in {SETTING} is lidar-sig")

    def more_options(self, parameters, context):
        """The words of More options, split as a shell does; an unbalanced quote is refused in
        one line."""
        text = self.parameterAsString(parameters, "OPTIONS", context) or ""
        try:
            return shlex.split(text)
        except ValueError as exc:  # "No closing quotation", "No escaped character"
            why = str(exc)[:1].lower() + str(exc)[1:]
            raise QgsProcessingException(f"More options {text!r} cannot be read ({why}); close the quote, or put a "
                                         "backslash before a quote meant as a character") from None

    def cancelled(self, message, outputs, parameters=None):
        """The message of a cancelled run. Where the command says its work is kept "for
        --resume", say how this algorithm can reuse it: through its Resume parameter with the
        same output file, not with a temporary output (a new path each run), and not at all
        where it has no such parameter."""
        if " for --resume" not in message:
            return message
        if self.parameterDefinition("RESUME") is None:
            return message.replace(" for --resume", " for the command's --resume (this algorithm starts over)")
        if asks_temporary((parameters or {}).get("OUTPUT")):
            return message.replace(" for --resume", ", but a temporary output cannot be resumed: save the output to a "
                                   "file to resume an interrupted run")
        return message.replace(" for --resume", "; to reuse it, run again with the same output and Resume ticked")

    def add_file(self, name, description, files=None, *, optional=False, folder=False):
        behavior = QgsProcessingParameterFile.Folder if folder else QgsProcessingParameterFile.File
        self.addParameter(QgsProcessingParameterFile(name, description, behavior=behavior,
                                                     fileFilter="" if folder else files or clouds(), optional=optional))

    def add_crs(self):
        """The CRS of clouds whose header carries none (--crs): it reaches every output layer."""
        self.addParameter(QgsProcessingParameterCrs("CRS", "CRS of clouds without one", optional=True))

    def crs_arguments(self, parameters, context):
        """``--crs`` and the CRS asked, by its authority id (EPSG:28992) or else its WKT; none when not set."""
        crs = self.parameterAsCrs(parameters, "CRS", context) if self.parameterDefinition("CRS") else None
        if crs is None or not crs.isValid():
            return []
        return ["--crs", crs.authid() or crs.toWkt()]

    def add_report(self):
        self.addParameter(QgsProcessingParameterFileDestination("REPORT", "Report (HTML)", HTML, optional=True,
                                                                createByDefault=False))

    def layer_file(self, parameters, name, context):
        """A layer destination's file: the command writes files, so a database table or a layer
        inside a GeoPackage (QGIS's "ogr:dbname=... table=...") is refused, saying so."""
        destination = self.parameterAsOutputLayer(parameters, name, context)
        if NOT_A_FILE.search(destination):
            raise QgsProcessingException(f"{destination}: lidar-sig writes files; choose Save to File... and give a "
                                         f"{'.tif' if name == 'OUTPUT' and self.job == 'changes' else '.gpkg'} file")
        return destination

    def path(self, parameters, name, context):
        """A file parameter's path, or None where it is empty."""
        value = self.parameterAsString(parameters, name, context)
        return value or None

    def styled(self, paths, context, names=None):
        """Have the layers Processing loads from ``paths`` (top first) drawn in their own styles
        and in this order. A raster is opened here in its style and handed to Processing, which
        takes it from the context's layer store: opened by Processing, without its style, a
        change map would first be set up as bands 1-3 in red, green and blue, whose histograms
        GDAL refuses on a constant band ("band 3: dfMax should be strictly greater than dfMin"
        where no cell is significant). ``names`` ({path: layer name}) name the layers."""
        order = LoadOrder(paths)
        for path in order.paths:
            if context.willLoadLayerOnCompletion(path):
                details = context.layerToLoadOnCompletionDetails(path)
                if (names or {}).get(path):
                    details.name = names[path]
                if details.layerTypeHint == QgsProcessingUtils.LayerHint.Raster:
                    layer = QgsRasterLayer(path, details.name, "gdal")  # its .qml read as it opens
                    if layer.isValid():
                        context.temporaryLayerStore().addMapLayer(layer)
                _STYLERS[path] = StyledLayer(path, order)
                details.setPostProcessor(_STYLERS[path])

    def load_points(self, path, name, context, feedback):
        """Add the point cloud ``path`` to the project when this QGIS reads LAS (its PDAL provider)."""
        if not path or not path.lower().endswith((".las", ".laz")) or context.project() is None:
            return
        if "pdal" not in QgsProviderRegistry.instance().providerList():
            feedback.pushInfo(f"{path}: this QGIS reads no LAS/LAZ files (it has no PDAL provider); open it in "
                              "CloudCompare, or in a QGIS built with PDAL")
            return
        details = QgsProcessingContext.LayerDetails(name, context.project(), name,
                                                    QgsProcessingUtils.LayerHint.PointCloud)
        context.addLayerToLoadOnCompletion(path, details)

    def table(self, parameters, name, context, fields, rows, *, title=None, aliases=None, decimals=4):
        """Write ``rows`` (dicts) into the feature sink ``name`` with ``fields`` [(name, QVariant
        type)]: a table without geometry, its fields shown by ``aliases`` ({field: name}) and
        its numbers with ``decimals`` decimals (kept whole in the file), loaded named ``title``.
        Returns its id."""
        qfields = QgsFields()
        for field_name, kind in fields:
            qfields.append(QgsField(field_name, kind))
        sink, dest = self.parameterAsSink(parameters, name, context, qfields, QgsWkbTypes.NoGeometry,
                                          QgsCoordinateReferenceSystem())
        if sink is None:
            raise QgsProcessingException(self.invalidSinkError(parameters, name))
        for row in rows:
            feature = QgsFeature(qfields)
            for field_name, _ in fields:
                value = row.get(field_name)
                feature[field_name] = value if value is not None else None
            sink.addFeature(feature)
        del sink  # written and closed: its style can now be stored beside it
        doubles = [field_name for field_name, kind in fields if kind == QVariant.Double]
        save_display(dest, aliases or {}, {field_name: decimals for field_name in doubles})
        self.styled([dest], context, {dest: title})
        return dest


def save_display(source, aliases, decimals):
    """Store in the layer ``source`` (a GeoPackage table) the default style that shows its fields
    by ``aliases`` ({field: name}) and their numbers with ``decimals`` ({field: digits}: the
    Range widget's precision, which the attribute table and the identify results use)."""
    if not source or NOT_A_FILE.search(source.split("|")[0]):
        return
    layer = QgsVectorLayer(source, "table", "ogr")
    if not layer.isValid() or not layer.dataProvider().isSaveAndLoadStyleToDatabaseSupported():
        return
    for field_name, alias in aliases.items():
        index = layer.fields().indexOf(field_name)
        if index >= 0:
            layer.setFieldAlias(index, alias)
    for field_name, digits in decimals.items():
        index = layer.fields().indexOf(field_name)
        if index >= 0:
            layer.setEditorWidgetSetup(index, QgsEditorWidgetSetup("Range", {"Precision": digits, "Style": "SpinBox",
                                                                            "AllowNull": True}))
    layer.saveStyleToDatabase("default", "fields shown by name, numbers rounded (lidar_sig)", True, "")


def _json(finished):
    try:
        return json.loads(finished.stdout)
    except ValueError:
        raise QgsProcessingException("lidar-sig printed no JSON; check that it is lidar_sig 0.1 or later") from None


# -- point clouds ---------------------------------------------------------------------------------

class SaliencyAlgorithm(LidarSigAlgorithm):
    job = "saliency"
    label = "Saliency of a point cloud"
    group_name = "Point clouds"
    help = ("<p>Per-point saliency: how line-like (Cl), surface-like (Cs) and point-like (Cp) each point's "
            "surroundings are, their entropy Egeom and the geometric class, written with every attribute of the "
            "input (LAS extra dimensions; PLY and CSV scalar fields, named for CloudCompare).</p>")
    notes = ("<p><b>Descriptor</b>, <b>Scales combined by</b>: not set, lidar-sig's default. <b>Neighbourhood sizes "
             "k</b>: e.g. 20,30,40; empty, the strategy's default. <b>CRS of clouds without one</b>: the CRS of a "
             "cloud whose header carries none (--crs); a cloud in another CRS is refused.</p>")

    def parameters(self):
        self.add_file("INPUT", "Point cloud")
        self.addParameter(choice("DESCRIPTOR", "Descriptor", offered("descriptors")))
        self.addParameter(choice("STRATEGY", "Scales combined by", offered("strategies")))
        self.addParameter(QgsProcessingParameterString("K", "Neighbourhood sizes k", optional=True))
        self.add_crs()
        self.addParameter(QgsProcessingParameterFileDestination("OUTPUT", "Point cloud with saliency",
                                                                cloud_outputs()))

    def arguments(self, parameters, context, outputs):
        args = ["saliency", self.path(parameters, "INPUT", context), "-o", outputs["OUTPUT"], "--overwrite",
                *self.crs_arguments(parameters, context)]
        for name, option in (("DESCRIPTOR", "--descriptor"), ("STRATEGY", "--strategy")):
            picked = self.parameterAsEnumString(parameters, name, context)
            args += [option, picked] if picked else []
        k = self.parameterAsString(parameters, "K", context)
        return args + (["--k", k] if k else [])

    def results(self, parameters, context, feedback, finished, outputs):
        self.load_points(outputs["OUTPUT"], Path(outputs["OUTPUT"]).stem, context, feedback)
        return dict(outputs)


class SignatureAlgorithm(LidarSigAlgorithm):
    job = "signature"
    label = "Signature of a point cloud"
    group_name = "Point clouds"
    help = ("<p>The cloud's signature: its points placed in the saliency triangle by (Cl, Cs, Cp) and counted per "
            "class, kept in an HDF5 archive (compared later without the cloud), with the picture Sas and a "
            "report on request.</p>")
    notes = ("<p><b>CRS of clouds without one</b>: the CRS of a cloud whose header carries none (--crs), kept in "
             "the archive; a cloud in another CRS is refused.</p>")

    def parameters(self):
        self.add_file("INPUT", "Point cloud")
        self.add_crs()
        self.addParameter(QgsProcessingParameterFileDestination("OUTPUT", "Signature archive", archives()))
        self.addParameter(QgsProcessingParameterFileDestination("PNG", "Picture of Sas", "PNG files (*.png)",
                                                                optional=True, createByDefault=False))
        self.add_report()

    def arguments(self, parameters, context, outputs):
        args = ["signature", self.path(parameters, "INPUT", context), "-o", outputs["OUTPUT"], "--overwrite",
                *self.crs_arguments(parameters, context)]
        for name, option in (("PNG", "--png"), ("REPORT", "--report")):
            args += [option, outputs[name]] if outputs[name] else []
        return args


class CompareAlgorithm(LidarSigAlgorithm):
    job = "compare"
    label = "Compare two point clouds"
    group_name = "Point clouds"

    @property
    def help(self):
        """Every metric lidar-sig offers (those of plugins too), counted as it lists them."""
        count = len(offered("metrics"))
        return (f"<p>The {count or 'registered'} metrics between the signatures of A and B (clouds or signature "
                "archives), each placed against the values the project measured between a tile and the same land "
                "resampled, the adjacent tile and another city; as a table, and a report on request.</p>")

    notes = ("<p><b>A</b>, <b>B</b>: a point cloud or a signature archive each. <b>CRS of clouds without one</b>: "
             "the CRS of a cloud whose header carries none (--crs); a cloud in another CRS is refused.</p>")

    def parameters(self):
        self.add_file("A", "A: cloud or signature archive", clouds_or_archives())
        self.add_file("B", "B: cloud or signature archive", clouds_or_archives())
        self.add_crs()
        self.addParameter(QgsProcessingParameterFeatureSink("METRICS", "Metrics", QgsProcessing.TypeVector))
        self.add_report()

    def arguments(self, parameters, context, outputs):
        args = ["compare", self.path(parameters, "A", context), self.path(parameters, "B", context), "--json",
                "--overwrite", *self.crs_arguments(parameters, context)]
        return args + (["--report", outputs["REPORT"]] if outputs["REPORT"] else [])

    def results(self, parameters, context, feedback, finished, outputs):
        data = _json(finished)
        for warning in data.get("warnings", []):
            feedback.pushWarning(warning)
        scale = data.get("scale", {})
        rows = [{"key": k, "metric": scale.get(k, {}).get("name", k), "value": data.get(k),
                 "like": scale.get(k, {}).get("like"), "on_scale": scale.get(k, {}).get("says")} for k in scale]
        names = " → ".join(Path(self.parameterAsString(parameters, k, context)).name for k in ("A", "B"))
        table = self.table(parameters, "METRICS", context, [("key", QVariant.String), ("metric", QVariant.String),
                                                             ("value", QVariant.Double), ("like", QVariant.String),
                                                             ("on_scale", QVariant.String)], rows,
                           title=f"Metrics {names}", aliases={"key": "key (the command's)", "like": "most like",
                                                              "on_scale": "on the project's scale"})
        return {"METRICS": table, "REPORT": outputs["REPORT"]}


# -- change maps ----------------------------------------------------------------------------------

class ChangesAlgorithm(LidarSigAlgorithm):
    job = "changes"
    label = "Change map of two epochs"
    group_name = "Change maps"
    help = ("<p>Where two epochs of the same area differ, without registration: per-cell signature metrics on a "
            "grid of the CRS, each cell with a level of detection that says whether it changed significantly. "
            "The change map (a Cloud-Optimized GeoTIFF coloured by how far each cell lies from its level of "
            "detection, in the same colours on every map: greys below the level, yellow to dark red above it) "
            "and, above it, the cells (outlined where they changed significantly, blue or purple where only one "
            "epoch has points) are added to the project; the later epoch's points with their cell's change on "
            "request.</p><p>An epoch is a point-cloud file; from a script, also a folder of tiles. The layers are "
            "named by the epochs (Change A → B, Cells A → B).</p>")
    notes = ("<p><b>Cell size</b> (m): 0, chosen from the densities. <b>Fewest points per cell</b> (in each epoch): "
             "0, chosen from the densities. <b>Sample density</b> (points/m²): a denser epoch's cells take a sample of "
             "its points, whose saliency alone is computed; 0: 5, more for cells under 25 m; a large value takes "
             "every point. <b>Ranking metric</b>: the metric that ranks the cells; not set, "
             "delta_KL, or delta_FV without comparable classes. <b>CRS of clouds without one</b>: the CRS of epochs "
             "whose header carries none (--crs), given to the change map and the cells; an epoch in another CRS is "
             "refused. <b>Later epoch's points with change</b>: its points with their cell's score, level of "
             "detection and significance.</p>")

    def parameters(self):
        self.add_file("EPOCH_A", "Earlier epoch")
        self.add_file("EPOCH_B", "Later epoch")
        self.addParameter(QgsProcessingParameterNumber("CELL", "Cell size (m; 0: automatic)",
                                                       QgsProcessingParameterNumber.Double, 0.0, minValue=0.0))
        self.addParameter(QgsProcessingParameterNumber("MIN_POINTS", "Fewest points per cell (0: automatic)",
                                                       QgsProcessingParameterNumber.Integer, 0, minValue=0))
        self.addParameter(QgsProcessingParameterNumber("SAMPLE_DENSITY", "Sample density (points/m²; 0: automatic)",
                                                       QgsProcessingParameterNumber.Double, 0.0, minValue=0.0))
        self.addParameter(choice("SCORE", "Ranking metric", metric_names()))
        self.addParameter(QgsProcessingParameterNumber("CONFIDENCE", "Confidence of the level of detection",
                                                       QgsProcessingParameterNumber.Double, 0.95, minValue=0.5,
                                                       maxValue=0.9999))
        self.add_crs()
        self.addParameter(QgsProcessingParameterRasterDestination("OUTPUT", "Change map"))
        self.addParameter(QgsProcessingParameterVectorDestination("CELLS", "Cells", QgsProcessing.TypeVectorPolygon))
        self.addParameter(QgsProcessingParameterFileDestination("POINTS", "Later epoch's points with change",
                                                                cloud_outputs(), optional=True,
                                                                createByDefault=False))
        self.add_report()
        self.addOutput(QgsProcessingOutputNumber("COMPARED", "Cells compared"))
        self.addOutput(QgsProcessingOutputNumber("SIGNIFICANT", "Cells changed significantly"))
        self.addOutput(QgsProcessingOutputNumber("CHANGED", "Cells changed (significant, appeared or vanished inside "
                                                            "the other epoch's footprint)"))

    def arguments(self, parameters, context, outputs):
        args = ["changes", self.path(parameters, "EPOCH_A", context), self.path(parameters, "EPOCH_B", context),
                "-o", outputs["OUTPUT"], "--cells", outputs["CELLS"], "--json", "--top", "0", "--overwrite",
                "--confidence", repr(self.parameterAsDouble(parameters, "CONFIDENCE", context)),
                *self.crs_arguments(parameters, context)]
        cell = self.parameterAsDouble(parameters, "CELL", context)
        args += ["--cell", repr(cell)] if cell > 0 else []
        fewest = self.parameterAsInt(parameters, "MIN_POINTS", context)
        args += ["--min-points", str(fewest)] if fewest > 0 else []
        sample = self.parameterAsDouble(parameters, "SAMPLE_DENSITY", context)
        args += ["--sample-density", repr(sample)] if sample > 0 else []
        score = self.parameterAsEnumString(parameters, "SCORE", context)  # the name shown; the command's key
        args += ["--score", metric_names().get(score, score)] if score else []
        for name, option in (("POINTS", "--points"), ("REPORT", "--report")):
            args += [option, outputs[name]] if outputs[name] else []
        return args

    def results(self, parameters, context, feedback, finished, outputs):
        data = _json(finished)
        for warning in data.get("warnings", []):
            feedback.pushWarning(warning)
        epochs = " → ".join(Path(str(data[k])).name for k in ("a", "b"))
        self.styled([outputs["CELLS"], outputs["OUTPUT"]], context,  # the cells above the map
                    {outputs["CELLS"]: f"Cells {epochs}", outputs["OUTPUT"]: f"Change {epochs}"})
        self.load_points(outputs["POINTS"], "later epoch with change", context, feedback)
        grid = data["grid"]
        feedback.pushInfo(f"{grid['valid']} cells compared, {grid['significant']} changed significantly "
                          f"(score {data['score']}, cells of {data['cell_m']:g} m)")
        for line in data.get("answer", []):  # the map's own answer (a lidar-sig older than the plugin has none)
            feedback.pushInfo(line)
        return {**outputs, "COMPARED": grid["valid"], "SIGNIFICANT": grid["significant"],
                "CHANGED": grid.get("changed")}


# -- survey catalogues ----------------------------------------------------------------------------

class CatalogAlgorithm(LidarSigAlgorithm):
    job = "catalog"
    label = "Catalogue of a survey's tiles"
    group_name = "Survey catalogues"
    help = ("<p>One signature per LAS/LAZ tile of a folder, in a catalogue for Similar tiles and Outlier tiles. An "
            "existing catalogue grows: new and changed tiles are computed, the others kept. Tiles that copy one "
            "another (the same file, or the same points as COPC) are said in the log. A run cancelled or "
            "interrupted keeps the tiles it finished: run it again on the same catalogue file with Resume ticked "
            "to reuse them.</p>")
    notes = ("<p><b>Resume an interrupted run</b>: reuse the tiles an interrupted run of the same catalogue "
             "finished (--resume). <b>CRS of clouds without one</b>: the CRS of tiles whose header carries none "
             "(--crs), kept in the catalogue; a tile in another CRS is refused.</p>")

    def parameters(self):
        self.add_file("INPUT", "Folder of LAS/LAZ tiles", folder=True)
        self.addParameter(QgsProcessingParameterFileDestination("OUTPUT", "Catalogue", archives()))
        self.addParameter(QgsProcessingParameterNumber("WORKERS", "Processes (0: every core)",
                                                       QgsProcessingParameterNumber.Integer, 0, minValue=0))
        self.addParameter(QgsProcessingParameterBoolean("RESUME", "Resume an interrupted run", False))
        self.add_crs()

    def arguments(self, parameters, context, outputs):
        args = ["catalog", self.path(parameters, "INPUT", context), "-o", outputs["OUTPUT"],
                *self.crs_arguments(parameters, context)]
        workers = self.parameterAsInt(parameters, "WORKERS", context)
        args += ["--workers", str(workers)] if workers > 0 else []
        return args + (["--resume"] if self.parameterAsBool(parameters, "RESUME", context) else [])


class SimilarAlgorithm(LidarSigAlgorithm):
    job = "similar"
    label = "Similar tiles"
    group_name = "Survey catalogues"
    help = ("<p>The tiles of a catalogue most like a query (a tile of the catalogue, left out of the answer, or "
            "another point cloud), best first, with every metric: their footprints (GeoPackage, numbered by "
            "rank) added to the project.</p>")
    notes = "<p><b>Query</b>: a tile of the catalogue (left out of the answer) or a point cloud.</p>"
    more_example = "--metric kl --shortlist 40"

    def parameters(self):
        self.add_file("QUERY", "Query tile or point cloud")
        self.add_file("CATALOGUE", "Catalogue", archives())
        self.addParameter(QgsProcessingParameterNumber("TOP", "Tiles listed", QgsProcessingParameterNumber.Integer,
                                                       10, minValue=1))
        self.addParameter(QgsProcessingParameterVectorDestination("OUTPUT", "Similar tiles",
                                                                  QgsProcessing.TypeVectorPolygon))

    def arguments(self, parameters, context, outputs):
        return ["similar", self.path(parameters, "QUERY", context), self.path(parameters, "CATALOGUE", context),
                "--top", str(self.parameterAsInt(parameters, "TOP", context)), "-o", outputs["OUTPUT"], "--json",
                "--overwrite"]

    def results(self, parameters, context, feedback, finished, outputs):
        data = _json(finished)
        query = Path(str(data.get("query", {}).get("name") or self.parameterAsString(parameters, "QUERY", context)))
        self.styled([outputs["OUTPUT"]], context, {outputs["OUTPUT"]: f"Tiles like {query.name}"})
        return dict(outputs)


class OutliersAlgorithm(LidarSigAlgorithm):
    job = "outliers"
    label = "Outlier tiles"
    group_name = "Survey catalogues"
    help = ("<p>Every tile of a catalogue scored by how unlike it is to its neighbours and the survey; a tile "
            "stands out from a score of 3.5. The footprints are added to the project, those that stand out in "
            "red and numbered.</p>")
    notes = "<p><b>Neighbours within</b> (m): 0, a quarter of the median tile side.</p>"
    more_example = ""  # its one other option, --top, changes only what it prints

    def parameters(self):
        self.add_file("CATALOGUE", "Catalogue", archives())
        self.addParameter(QgsProcessingParameterNumber("REACH", "Neighbours within (m; 0: automatic)",
                                                       QgsProcessingParameterNumber.Double, 0.0, minValue=0.0))
        self.addParameter(QgsProcessingParameterVectorDestination("OUTPUT", "Tiles", QgsProcessing.TypeVectorPolygon))
        self.add_report()
        self.addOutput(QgsProcessingOutputNumber("STANDING_OUT", "Tiles that stand out"))
        self.addOutput(QgsProcessingOutputString("VERDICT", "Verdict"))

    def arguments(self, parameters, context, outputs):
        args = ["outliers", self.path(parameters, "CATALOGUE", context), "-o", outputs["OUTPUT"], "--json",
                "--overwrite"]
        reach = self.parameterAsDouble(parameters, "REACH", context)
        args += ["--reach", repr(reach)] if reach > 0 else []
        return args + (["--report", outputs["REPORT"]] if outputs["REPORT"] else [])

    def results(self, parameters, context, feedback, finished, outputs):
        data = _json(finished)
        name = Path(self.parameterAsString(parameters, "CATALOGUE", context)).name
        self.styled([outputs["OUTPUT"]], context, {outputs["OUTPUT"]: f"Outlier scores of {name}"})
        feedback.pushInfo(data["verdict"])
        return {**outputs, "STANDING_OUT": data["standing_out"], "VERDICT": data["verdict"]}


ALGORITHMS = (SaliencyAlgorithm, SignatureAlgorithm, CompareAlgorithm, ChangesAlgorithm, CatalogAlgorithm,
              SimilarAlgorithm, OutliersAlgorithm)
