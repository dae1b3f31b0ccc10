"""The provider's algorithms, one per job of the ``lidar-sig`` command: each gathers its
parameters into the command's arguments, runs it (:mod:`.command`), and hands its outputs to
QGIS: layers added to the project in their own styles, tables of the numbers it printed as JSON."""
import json
import re
import shlex
from pathlib import Path

from qgis.core import (QgsCoordinateReferenceSystem, QgsFeature, QgsField, QgsFields, QgsProcessing,
                       QgsProcessingAlgorithm, QgsProcessingContext, QgsProcessingException,
                       QgsProcessingLayerPostProcessorInterface, QgsProcessingOutputNumber, QgsProcessingOutputString,
                       QgsProcessingParameterEnum, QgsProcessingParameterFeatureSink,
                       QgsProcessingParameterFile, QgsProcessingParameterFileDestination, QgsProcessingParameterNumber,
                       QgsProcessingParameterRasterDestination, QgsProcessingParameterString,
                       QgsProcessingParameterVectorDestination, QgsProcessingUtils, QgsProviderRegistry, QgsWkbTypes)
from qgis.PyQt.QtCore import QVariant

from . import command
from .provider import executable_setting

CLOUDS = "Point clouds (*.laz *.las *.ply *.pcd *.xyz *.txt *.pts *.csv);;All files (*.*)"
CLOUDS_OR_ARCHIVES = ("Point clouds and signature archives (*.laz *.las *.ply *.pcd *.xyz *.txt *.pts *.csv *.h5 "
                      "*.hdf5);;All files (*.*)")
CLOUD_OUTPUTS = "LAZ files (*.laz);;LAS files (*.las);;PLY files (*.ply);;CSV files (*.csv)"
ARCHIVES = "Signature archives (*.h5 *.hdf5)"
HTML = "HTML files (*.html)"
#: A destination that is no file: a provider's URI ("ogr:dbname=...", "postgres:...", "memory:"; a
#: Windows drive is one letter).
NOT_A_FILE = re.compile(r"^[A-Za-z]{2,}:|dbname=")


def offered(kind):
    """The names of the ``kind`` ("descriptors", "strategies" or "metrics") that the lidar-sig
    run by the provider offers, in its order (:func:`command.listing`): a plugin installed
    beside lidar_sig shows up here; [] when lidar-sig cannot be run (a job's run says why)."""
    try:
        executable = command.find_executable(executable_setting())
    except command.CommandError:
        return []
    return list(command.listing(executable).get(kind, {}))


def choice(name, description, options):
    """A parameter that picks one of ``options`` by name (a script gives the name, e.g.
    ``"STRATEGY": "optimal"``), not set by default: the command then uses its own default."""
    return QgsProcessingParameterEnum(name, description, options, allowMultiple=False, defaultValue=None,
                                      optional=True, usesStaticStrings=True)


class DefaultStyle(QgsProcessingLayerPostProcessorInterface):
    """Draws a loaded output in the style it carries: the ``.qml`` beside a GeoTIFF, the default
    row of a GeoPackage's ``layer_styles`` (Processing loads its outputs without them)."""

    def postProcessLayer(self, layer, context, feedback):  # noqa: N802 - QGIS's name
        message, loaded = layer.loadDefaultStyle()
        if loaded:
            layer.triggerRepaint()
        elif feedback is not None:
            feedback.pushInfo(f"{layer.name()}: no style of its own ({message})")


#: The post-processors given to QGIS, by layer path: one per layer (QGIS takes each over and
#: deletes it once used: a shared one crashed the second layer), kept alive here until then.
_STYLERS = {}


class LidarSigAlgorithm(QgsProcessingAlgorithm):
    """A job of the ``lidar-sig`` command. A subclass sets ``job``, ``label``, ``group_name``
    and ``help`` and defines :meth:`parameters` and :meth:`arguments`, and :meth:`results`
    when the command's JSON gives outputs."""

    job = ""
    label = ""
    group_name = ""
    help = ""

    def name(self):
        return self.job

    def displayName(self):  # noqa: N802 - QGIS's names from here on
        return self.label

    def group(self):
        return self.group_name

    def groupId(self):
        return self.group_name.lower().replace(" ", "_")

    def shortHelpString(self):
        return (self.help + "<p>Runs <code>lidar-sig " + self.job + "</code> (the executable set in Settings &gt; "
                "Options &gt; Processing &gt; Providers &gt; lidar_sig, or lidar-sig on PATH); its progress and notes "
                "appear in this log, Cancel stops it with nothing half-written.</p>")

    def createInstance(self):
        return type(self)()

    def initAlgorithm(self, config=None):
        self.parameters()
        options = QgsProcessingParameterString("OPTIONS", "More options of lidar-sig " + self.job + " (as on the "
                                               "command line, e.g. --classes paper)", optional=True)
        options.setFlags(options.flags() | options.FlagAdvanced)
        self.addParameter(options)

    def parameters(self):
        """Add the job's parameters."""
        raise NotImplementedError

    def arguments(self, parameters, context):
        """The command's arguments after ``lidar-sig``."""
        raise NotImplementedError

    def results(self, parameters, context, feedback, finished):
        """The algorithm's outputs from the finished run."""
        return {}

    def processAlgorithm(self, parameters, context, feedback):
        argv = [str(a) for a in self.arguments(parameters, context)]
        argv += shlex.split(self.parameterAsString(parameters, "OPTIONS", context) or "")
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
        except command.CommandError as exc:  # the command's one line, naming the file and the fix
            raise QgsProcessingException(exc.message) from None
        if finished.stdout and not finished.stdout.lstrip().startswith("{"):
            for line in finished.stdout.splitlines():
                feedback.pushInfo(line)
        return self.results(parameters, context, feedback, finished)

    # -- helpers -------------------------------------------------------------------------------

    def add_file(self, name, description, file_filter=CLOUDS, *, optional=False, folder=False):
        behavior = QgsProcessingParameterFile.Folder if folder else QgsProcessingParameterFile.File
        self.addParameter(QgsProcessingParameterFile(name, description, behavior=behavior,
                                                     fileFilter="" if folder else file_filter, optional=optional))

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

    def styled(self, path, context):
        """Have the layer Processing loads from ``path`` drawn in its own style."""
        if path and context.willLoadLayerOnCompletion(path):
            _STYLERS[path] = DefaultStyle()
            context.layerToLoadOnCompletionDetails(path).setPostProcessor(_STYLERS[path])

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

    def table(self, parameters, name, context, fields, rows):
        """Write ``rows`` (dicts) into the feature sink ``name`` with ``fields`` [(name, QVariant
        type)]: a table without geometry. Returns its id."""
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
        return dest


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

    def parameters(self):
        self.add_file("INPUT", "Point cloud")
        self.addParameter(choice("DESCRIPTOR", "Descriptor (not set: lidar-sig's default)", offered("descriptors")))
        self.addParameter(choice("STRATEGY", "Scales combined by (not set: lidar-sig's default)",
                                 offered("strategies")))
        self.addParameter(QgsProcessingParameterString("K", "Neighbourhood sizes k, e.g. 20,30,40 (empty: the "
                                                       "strategy's default)", optional=True))
        self.addParameter(QgsProcessingParameterFileDestination("OUTPUT", "Point cloud with saliency",
                                                                CLOUD_OUTPUTS))

    def arguments(self, parameters, context):
        args = ["saliency", self.path(parameters, "INPUT", context), "-o",
                self.parameterAsFileOutput(parameters, "OUTPUT", context), "--overwrite"]
        for name, option in (("DESCRIPTOR", "--descriptor"), ("STRATEGY", "--strategy")):
            picked = self.parameterAsEnumString(parameters, name, context)
            args += [option, picked] if picked else []
        k = self.parameterAsString(parameters, "K", context)
        return args + (["--k", k] if k else [])

    def results(self, parameters, context, feedback, finished):
        output = self.parameterAsFileOutput(parameters, "OUTPUT", context)
        self.load_points(output, Path(output).stem, context, feedback)
        return {"OUTPUT": output}


class SignatureAlgorithm(LidarSigAlgorithm):
    job = "signature"
    label = "Signature of a point cloud"
    group_name = "Point clouds"
    help = ("<p>The cloud's signature: its points placed in the saliency triangle by (Cl, Cs, Cp) and counted per "
            "class, kept in an HDF5 archive (compared later without the cloud), with the picture Sas and a "
            "report on request.</p>")

    def parameters(self):
        self.add_file("INPUT", "Point cloud")
        self.addParameter(QgsProcessingParameterFileDestination("OUTPUT", "Signature archive", ARCHIVES))
        self.addParameter(QgsProcessingParameterFileDestination("PNG", "Picture of Sas", "PNG files (*.png)",
                                                                optional=True, createByDefault=False))
        self.add_report()

    def arguments(self, parameters, context):
        args = ["signature", self.path(parameters, "INPUT", context), "-o",
                self.parameterAsFileOutput(parameters, "OUTPUT", context), "--overwrite"]
        for name, option in (("PNG", "--png"), ("REPORT", "--report")):
            path = self.parameterAsFileOutput(parameters, name, context)
            args += [option, path] if path else []
        return args

    def results(self, parameters, context, feedback, finished):
        return {name: self.parameterAsFileOutput(parameters, name, context) or None
                for name in ("OUTPUT", "PNG", "REPORT")}


class CompareAlgorithm(LidarSigAlgorithm):
    job = "compare"
    label = "Compare two point clouds"
    group_name = "Point clouds"
    help = ("<p>The seven metrics between the signatures of A and B (clouds or signature archives), each placed "
            "against the values the project measured between a tile and the same land resampled, the adjacent "
            "tile and another city; as a table, and a report on request.</p>")

    def parameters(self):
        self.add_file("A", "A: point cloud or signature archive", CLOUDS_OR_ARCHIVES)
        self.add_file("B", "B: point cloud or signature archive", CLOUDS_OR_ARCHIVES)
        self.add_report()
        self.addParameter(QgsProcessingParameterFeatureSink("METRICS", "Metrics", QgsProcessing.TypeVector))

    def arguments(self, parameters, context):
        args = ["compare", self.path(parameters, "A", context), self.path(parameters, "B", context), "--json",
                "--overwrite"]
        report = self.parameterAsFileOutput(parameters, "REPORT", context)
        return args + (["--report", report] if report else [])

    def results(self, parameters, context, feedback, finished):
        data = _json(finished)
        for warning in data.get("warnings", []):
            feedback.pushWarning(warning)
        scale = data.get("scale", {})
        rows = [{"key": k, "metric": scale.get(k, {}).get("name", k), "value": data.get(k),
                 "like": scale.get(k, {}).get("like"), "on_scale": scale.get(k, {}).get("says")} for k in scale]
        table = self.table(parameters, "METRICS", context, [("key", QVariant.String), ("metric", QVariant.String),
                                                             ("value", QVariant.Double), ("like", QVariant.String),
                                                             ("on_scale", QVariant.String)], rows)
        return {"METRICS": table, "REPORT": self.parameterAsFileOutput(parameters, "REPORT", context) or None}


# -- change maps ----------------------------------------------------------------------------------

class ChangesAlgorithm(LidarSigAlgorithm):
    job = "changes"
    label = "Change map of two epochs"
    group_name = "Change maps"
    help = ("<p>Where two epochs of the same area differ, without registration: per-cell signature metrics on a "
            "grid of the CRS, each cell with a level of detection that says whether it changed significantly. "
            "The change map (a Cloud-Optimized GeoTIFF drawn as a colour ramp of the score) and the cells "
            "(outlined where they changed significantly, hatched where only one epoch has points) are added to "
            "the project; the later epoch's points with their cell's change on request.</p>"
            "<p>An epoch is a point-cloud file; from a script, also a folder of tiles.</p>")

    def parameters(self):
        self.add_file("EPOCH_A", "Earlier epoch")
        self.add_file("EPOCH_B", "Later epoch")
        self.addParameter(QgsProcessingParameterNumber("CELL", "Cell size (m; 0: chosen from the densities)",
                                                       QgsProcessingParameterNumber.Double, 0.0, minValue=0.0))
        self.addParameter(QgsProcessingParameterNumber("MIN_POINTS", "Fewest points per cell and epoch (0: chosen "
                                                       "from the densities)", QgsProcessingParameterNumber.Integer,
                                                       0, minValue=0))
        self.addParameter(choice("SCORE", "Metric that ranks the cells (not set: delta_KL, or delta_FV without "
                                 "comparable classes)", offered("metrics")))
        self.addParameter(QgsProcessingParameterNumber("CONFIDENCE", "Confidence of the level of detection",
                                                       QgsProcessingParameterNumber.Double, 0.95, minValue=0.5,
                                                       maxValue=0.9999))
        self.addParameter(QgsProcessingParameterRasterDestination("OUTPUT", "Change map"))
        self.addParameter(QgsProcessingParameterVectorDestination("CELLS", "Cells", QgsProcessing.TypeVectorPolygon))
        self.addParameter(QgsProcessingParameterFileDestination("POINTS", "Later epoch's points with their cell's "
                                                                "change", CLOUD_OUTPUTS, optional=True,
                                                                createByDefault=False))
        self.add_report()
        self.addOutput(QgsProcessingOutputNumber("COMPARED", "Cells compared"))
        self.addOutput(QgsProcessingOutputNumber("SIGNIFICANT", "Cells changed significantly"))

    def arguments(self, parameters, context):
        args = ["changes", self.path(parameters, "EPOCH_A", context), self.path(parameters, "EPOCH_B", context),
                "-o", self.layer_file(parameters, "OUTPUT", context),
                "--cells", self.layer_file(parameters, "CELLS", context),
                "--json", "--top", "0", "--overwrite",
                "--confidence", repr(self.parameterAsDouble(parameters, "CONFIDENCE", context))]
        cell = self.parameterAsDouble(parameters, "CELL", context)
        args += ["--cell", repr(cell)] if cell > 0 else []
        fewest = self.parameterAsInt(parameters, "MIN_POINTS", context)
        args += ["--min-points", str(fewest)] if fewest > 0 else []
        score = self.parameterAsEnumString(parameters, "SCORE", context)
        args += ["--score", score] if score else []
        for name, option in (("POINTS", "--points"), ("REPORT", "--report")):
            path = self.parameterAsFileOutput(parameters, name, context)
            args += [option, path] if path else []
        return args

    def results(self, parameters, context, feedback, finished):
        data = _json(finished)
        for warning in data.get("warnings", []):
            feedback.pushWarning(warning)
        output = self.parameterAsOutputLayer(parameters, "OUTPUT", context)
        cells = self.parameterAsOutputLayer(parameters, "CELLS", context)
        points = self.parameterAsFileOutput(parameters, "POINTS", context) or None
        for path in (output, cells):
            self.styled(path, context)
        self.load_points(points, "later epoch with change", context, feedback)
        grid = data["grid"]
        feedback.pushInfo(f"{grid['valid']} cells compared, {grid['significant']} changed significantly "
                          f"(score {data['score']}, cells of {data['cell_m']:g} m)")
        return {"OUTPUT": output, "CELLS": cells, "POINTS": points,
                "REPORT": self.parameterAsFileOutput(parameters, "REPORT", context) or None,
                "COMPARED": grid["valid"], "SIGNIFICANT": grid["significant"]}


# -- survey catalogues ----------------------------------------------------------------------------

class CatalogAlgorithm(LidarSigAlgorithm):
    job = "catalog"
    label = "Catalogue of a survey's tiles"
    group_name = "Survey catalogues"
    help = ("<p>One signature per LAS/LAZ tile of a folder, in a catalogue for Similar tiles and Outlier tiles. An "
            "existing catalogue grows: new and changed tiles are computed, the others kept. Tiles that copy one "
            "another (the same file, or the same points as COPC) are said in the log.</p>")

    def parameters(self):
        self.add_file("INPUT", "Folder of LAS/LAZ tiles", folder=True)
        self.addParameter(QgsProcessingParameterFileDestination("OUTPUT", "Catalogue", ARCHIVES))
        self.addParameter(QgsProcessingParameterNumber("WORKERS", "Processes (0: every core)",
                                                       QgsProcessingParameterNumber.Integer, 0, minValue=0))

    def arguments(self, parameters, context):
        args = ["catalog", self.path(parameters, "INPUT", context), "-o",
                self.parameterAsFileOutput(parameters, "OUTPUT", context)]
        workers = self.parameterAsInt(parameters, "WORKERS", context)
        return args + (["--workers", str(workers)] if workers > 0 else [])

    def results(self, parameters, context, feedback, finished):
        return {"OUTPUT": self.parameterAsFileOutput(parameters, "OUTPUT", context)}


class SimilarAlgorithm(LidarSigAlgorithm):
    job = "similar"
    label = "Similar tiles"
    group_name = "Survey catalogues"
    help = ("<p>The tiles of a catalogue most like a query (a tile of the catalogue, left out of the answer, or "
            "another point cloud), best first, with every metric, as a table.</p>")

    def parameters(self):
        self.add_file("QUERY", "Query: a tile of the catalogue or a point cloud")
        self.add_file("CATALOGUE", "Catalogue", ARCHIVES)
        self.addParameter(QgsProcessingParameterNumber("TOP", "Tiles listed", QgsProcessingParameterNumber.Integer,
                                                       10, minValue=1))
        self.addParameter(QgsProcessingParameterFeatureSink("OUTPUT", "Similar tiles", QgsProcessing.TypeVector))

    def arguments(self, parameters, context):
        return ["similar", self.path(parameters, "QUERY", context), self.path(parameters, "CATALOGUE", context),
                "--top", str(self.parameterAsInt(parameters, "TOP", context)), "--json"]

    def results(self, parameters, context, feedback, finished):
        data = _json(finished)
        fields = [("rank", QVariant.Int), ("name", QVariant.String), ("path", QVariant.String),
                  ("distance", QVariant.Double)] + [(k, QVariant.Double) for k in offered("metrics")]
        return {"OUTPUT": self.table(parameters, "OUTPUT", context, fields, data["results"])}


class OutliersAlgorithm(LidarSigAlgorithm):
    job = "outliers"
    label = "Outlier tiles"
    group_name = "Survey catalogues"
    help = ("<p>Every tile of a catalogue scored by how unlike it is to its neighbours and the survey; a tile "
            "stands out from a score of 3.5. The footprints are added to the project, those that stand out in "
            "red and numbered.</p>")

    def parameters(self):
        self.add_file("CATALOGUE", "Catalogue", ARCHIVES)
        self.addParameter(QgsProcessingParameterNumber("REACH", "Neighbours within (m; 0: a quarter of the median "
                                                       "tile side)", QgsProcessingParameterNumber.Double, 0.0,
                                                       minValue=0.0))
        self.addParameter(QgsProcessingParameterVectorDestination("OUTPUT", "Tiles", QgsProcessing.TypeVectorPolygon))
        self.add_report()
        self.addOutput(QgsProcessingOutputNumber("STANDING_OUT", "Tiles that stand out"))
        self.addOutput(QgsProcessingOutputString("VERDICT", "Verdict"))

    def arguments(self, parameters, context):
        args = ["outliers", self.path(parameters, "CATALOGUE", context), "-o",
                self.layer_file(parameters, "OUTPUT", context), "--json", "--overwrite"]
        reach = self.parameterAsDouble(parameters, "REACH", context)
        args += ["--reach", repr(reach)] if reach > 0 else []
        report = self.parameterAsFileOutput(parameters, "REPORT", context)
        return args + (["--report", report] if report else [])

    def results(self, parameters, context, feedback, finished):
        data = _json(finished)
        output = self.parameterAsOutputLayer(parameters, "OUTPUT", context)
        self.styled(output, context)
        feedback.pushInfo(data["verdict"])
        return {"OUTPUT": output, "REPORT": self.parameterAsFileOutput(parameters, "REPORT", context) or None,
                "STANDING_OUT": data["standing_out"], "VERDICT": data["verdict"]}


ALGORITHMS = (SaliencyAlgorithm, SignatureAlgorithm, CompareAlgorithm, ChangesAlgorithm, CatalogAlgorithm,
              SimilarAlgorithm, OutliersAlgorithm)
