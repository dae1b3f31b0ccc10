"""The QGIS face (issue 32): the Processing provider installed from its zip (qgis/build_plugin.py)
into QGIS running headless (Debian's qgis and python3-qgis, QT_QPA_PLATFORM=offscreen; its
Python is Debian's, not this one), its algorithms listed and run as an analyst runs them, the
outputs drawn in their styles, a run cancelled and errors turned into QgsProcessingExceptions
(tests/qgis_driver.py does the QGIS side). Pictures of the map as QGIS draws it are kept where
LIDAR_SIG_SCREENSHOTS points, as the report's are. The parts of the provider that need no QGIS
(reading the command's lines, running and cancelling it) are tested here with this Python."""
import ast
import importlib.util
import json
import os
import shutil
import signal
import sqlite3
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

from command_line import run
from conftest import IGN, ROOT, SAMPLES, need_data

QGIS_PYTHON = "/usr/bin/python3"
DRIVER = ROOT / "tests" / "qgis_driver.py"
LIDAR_SIG = Path(sys.executable).with_name("lidar-sig")  # the command the provider runs
TILES = ("test_data_77055_627755_LA93_IGN69.laz", "test_data_77060_627755_LA93_IGN69.laz")
ALIGNED = SAMPLES / "epoch2_aligned.laz"
#: The provider's algorithms, one per job of the command.
JOBS = ("saliency", "signature", "compare", "changes", "catalog", "similar", "outliers")


def load_command_module():
    """qgis/lidar_sig_provider/command.py, which imports no QGIS, as a module of this Python."""
    spec = importlib.util.spec_from_file_location("lidar_sig_provider_command",
                                                  ROOT / "qgis" / "lidar_sig_provider" / "command.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


command = load_command_module()


# -- without QGIS: the command's lines, its run, its cancel ---------------------------------------

def test_the_provider_reads_the_command_s_lines():
    assert command.read_line("lidar-sig: progress: saliency (c3dcm multiscale): 37%\n") == \
        ("progress", ("saliency (c3dcm multiscale)", 37))
    assert command.read_line("lidar-sig: progress: reading a b.laz: 100%") == ("progress", ("reading a b.laz", 100))
    assert command.read_line("lidar-sig: note: 28% of the points ...") == ("note", "28% of the points ...")
    assert command.read_line("lidar-sig: error: a.laz: no such file; check the path") == \
        ("error", "a.laz: no such file; check the path")
    assert command.read_line("lidar-sig: interrupted (SIGTERM); outputs not written")[0] == "interrupted"
    assert command.read_line("wrote a.laz") == ("other", "wrote a.laz")
    env = command.child_environment({"PYTHONHOME": "/qgis/python", "PATH": "/bin", "LIDAR_SIG_PROGRESS": "none"})
    assert env == {"PATH": "/bin", "LIDAR_SIG_PROGRESS": "lines"}


def _needs_command():
    if not LIDAR_SIG.exists():
        pytest.skip(f"the lidar-sig command is not installed beside {sys.executable} (pip install -e .)")


def test_a_run_reports_progress_and_notes_and_an_error_names_the_file(tmp_path):
    _needs_command()
    seen = []
    done = command.run([str(LIDAR_SIG), "saliency", str(SAMPLES / "epoch2.laz"), "-o", str(tmp_path / "a.laz")],
                       on_progress=lambda stage, percent: seen.append((stage, percent)))
    assert done.stdout.startswith(str(SAMPLES / "epoch2.laz")) and (tmp_path / "a.laz").exists()
    assert ("saliency (c3dcm multiscale)", 100) in seen and seen[0] == ("reading epoch2.laz", 0)
    with pytest.raises(command.CommandError) as err:
        command.run([str(LIDAR_SIG), "saliency", str(tmp_path / "nope.laz"), "-o", str(tmp_path / "b.laz")])
    assert err.value.status == 2 and err.value.message == f"{tmp_path / 'nope.laz'}: no such file; check the path"


def test_a_cancelled_run_is_stopped_with_sigterm_and_leaves_nothing(tmp_path):
    _needs_command()
    stages = []

    def cancelled():  # once the saliency's neighbourhoods are being searched
        return "neighbourhoods" in stages

    with pytest.raises(command.Cancelled) as err:
        command.run([str(LIDAR_SIG), "changes", str(SAMPLES / "epoch1.laz"), str(SAMPLES / "epoch2_aligned.laz"),
                     "-o", str(tmp_path / "map.tif"), "--cells", str(tmp_path / "cells.gpkg")],
                    on_progress=lambda stage, percent: stages.append(stage), cancelled=cancelled)
    assert err.value.status == 128 + signal.SIGTERM
    assert "interrupted (SIGTERM)" in err.value.message and "outputs not written" in err.value.message
    assert list(tmp_path.iterdir()) == []


def test_the_plugin_zip_holds_the_provider_its_metadata_and_the_license(tmp_path):
    done = subprocess.run([sys.executable, str(ROOT / "qgis" / "build_plugin.py"), "--output",
                           str(tmp_path / "plugin.zip")], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    with zipfile.ZipFile(tmp_path / "plugin.zip") as z:
        names = set(z.namelist())
        metadata = z.read("lidar_sig_provider/metadata.txt").decode()
    assert {"lidar_sig_provider/__init__.py", "lidar_sig_provider/metadata.txt", "lidar_sig_provider/provider.py",
            "lidar_sig_provider/algorithms.py", "lidar_sig_provider/command.py", "lidar_sig_provider/LICENSE"} <= names
    assert not any("__pycache__" in n for n in names)
    import lidar_sig

    assert f"version={lidar_sig.__version__}\n" in metadata and "hasProcessingProvider=yes" in metadata
    assert list(tmp_path.iterdir()) == [tmp_path / "plugin.zip"]
    # an icon for the provider and each algorithm; each command's page, which Help opens
    assert {f"lidar_sig_provider/icons/{name}.svg" for name in ("lidar_sig", *JOBS)} <= names
    assert {f"lidar_sig_provider/help/{job}.html" for job in JOBS} <= names
    with zipfile.ZipFile(tmp_path / "plugin.zip") as z:
        page = z.read("lidar_sig_provider/help/changes.html").decode()
        icon = z.read("lidar_sig_provider/icons/changes.svg").decode()
    assert "<h1><code>lidar-sig changes</code>: where epochs differ" in page
    assert "<pre><code>$ lidar-sig changes" in page
    assert '<a href="../changes.md' not in page  # a page not in the plugin keeps only its link's text
    assert icon.startswith("<svg") and icon.rstrip().endswith("</svg>")


def test_the_provider_and_its_algorithms_do_not_import_each_other():
    folder = ROOT / "qgis" / "lidar_sig_provider"

    def imports(name):
        tree = ast.parse((folder / f"{name}.py").read_text())
        return {node.module for node in ast.walk(tree) if isinstance(node, ast.ImportFrom) and node.level == 1}

    assert "provider" not in imports("algorithms") and "algorithms" in imports("provider")
    assert "settings" in imports("algorithms") and "settings" in imports("provider")


# -- in QGIS ------------------------------------------------------------------------------------

def qgis_missing():
    """Why QGIS cannot run here, or None."""
    if not Path(QGIS_PYTHON).exists():
        return f"{QGIS_PYTHON} is not here"
    probe = subprocess.run([QGIS_PYTHON, "-c", "import qgis.core"], capture_output=True, text=True)
    if probe.returncode != 0:
        return "QGIS is not installed (Debian: apt-get install qgis python3-qgis)"
    if not Path("/usr/share/qgis/python/plugins/processing").is_dir():
        return "QGIS's Processing plugin is not installed (Debian: apt-get install qgis)"
    if not LIDAR_SIG.exists():
        return f"the lidar-sig command is not installed beside {sys.executable} (pip install -e .)"
    return None


@pytest.fixture(scope="module")
def qgis(tmp_path_factory):
    """``qgis(task, **args)``: the driver's result of ``task`` in a fresh headless QGIS with the
    plugin installed from its zip, ``lidar-sig`` (this environment's) on its PATH."""
    why = qgis_missing()
    if why:
        pytest.skip(why)
    top = tmp_path_factory.mktemp("qgis")
    done = subprocess.run([sys.executable, str(ROOT / "qgis" / "build_plugin.py"), "--output",
                           str(top / "lidar_sig_provider.zip")], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    plugins = top / "plugins"
    with zipfile.ZipFile(top / "lidar_sig_provider.zip") as z:  # as QGIS's "Install from ZIP" unpacks it
        z.extractall(plugins)
    env = dict(os.environ, QT_QPA_PLATFORM="offscreen", PATH=f"{LIDAR_SIG.parent}{os.pathsep}{os.environ['PATH']}",
               XDG_RUNTIME_DIR=str(top))
    calls = []

    def call(task, **args):
        calls.append(task)
        args.update(plugins=str(plugins), profile=str(top / f"profile{len(calls)}"))
        path = top / f"args{len(calls)}.json"
        path.write_text(json.dumps({k: str(v) if isinstance(v, Path) else v for k, v in args.items()}))
        done = subprocess.run([QGIS_PYTHON, str(DRIVER), task, str(path)], capture_output=True, text=True,
                              env=env, timeout=900, cwd=top)
        found = [line for line in done.stdout.splitlines() if line.startswith("RESULT ")]
        assert found, f"status {done.returncode}\n{done.stdout[-3000:]}\n{done.stderr[-3000:]}"
        return json.loads(found[-1][len("RESULT "):])
    return call


@pytest.fixture(scope="module")
def epochs(tmp_path_factory):
    """Two IGN tiles and the same two tiles edited (benchmarks/edited_epoch.py: a building removed,
    trees cut, a box building added, 80% kept and moved), as LAZ files."""
    need_data(IGN)
    sys.path.insert(0, str(ROOT / "benchmarks"))
    from edited_epoch import edit, write_las

    from lidar_sig.change_map import read_epoch

    top = tmp_path_factory.mktemp("epochs")
    one = read_epoch([IGN / name for name in TILES])
    two, edits = edit(one)
    write_las(one, top / "epoch1.laz")
    write_las(two, top / "epoch2.laz")
    return top / "epoch1.laz", top / "epoch2.laz", edits


def test_the_provider_loads_and_lists_one_algorithm_per_job(qgis):
    found = qgis("algorithms")
    assert found["provider"] == "lidar_sig"
    assert found["algorithms"] == sorted(f"lidarsig:{job}" for job in JOBS)
    assert all(found["help"].values()) and found["groups"] == ["Change maps", "Point clouds", "Survey catalogues"]
    assert {"EPOCH_A", "EPOCH_B", "OUTPUT", "CELLS", "POINTS", "REPORT", "OPTIONS"} <= \
        set(found["parameters"]["lidarsig:changes"])
    assert "METRICS" in found["parameters"]["lidarsig:compare"]
    # the names offered are the installed command's (a plugin's too), not a list of the provider's
    offered = json.loads(run("plugins", "--json").stdout)
    assert found["choices"]["lidarsig:saliency:DESCRIPTOR"] == list(offered["descriptors"])
    assert found["choices"]["lidarsig:saliency:STRATEGY"] == list(offered["strategies"])
    # the metrics by the names the legends and the help use (delta_KL), run by the command's keys (kl)
    assert found["choices"]["lidarsig:changes:SCORE"] == [m["name"] for m in offered["metrics"].values()]
    assert "delta_KL" in found["choices"]["lidarsig:changes:SCORE"]
    assert "kl" not in found["choices"]["lidarsig:changes:SCORE"]
    # icons, and Help opening the command's page in the plugin
    assert all(valid and Path(svg).is_file() and svg.endswith(".svg") for valid, svg in found["icons"].values())
    assert len({svg for _, svg in found["icons"].values()}) == len(JOBS) + 1
    for job in JOBS:
        url = found["help_url"][f"lidarsig:{job}"]
        assert url.startswith("file://") and url.endswith(f"/lidar_sig_provider/help/{job}.html")
        assert Path(url[len("file://"):]).is_file()
        # the More options example, in the help, names --classes only where the command takes it
        takes = "--classes" in run(job, "--help").stdout
        assert ("--classes" in found["help_text"][f"lidarsig:{job}"]) == takes, job


#: The most characters of a parameter's label: the changes dialog's 13 parameters and their
#: browse buttons fit a window 1,000 px wide (the detail is in the help beside them).
LABEL_MOST = 40


def test_every_dialog_label_is_short_and_its_detail_is_in_the_help(qgis):
    found = qgis("algorithms")
    for algorithm, labels in found["labels"].items():
        for name, label in labels.items():
            assert len(label) <= LABEL_MOST, (algorithm, name, label)
    changes = found["labels"]["lidarsig:changes"]
    assert changes["SCORE"] == "Ranking metric"  # was "Metric that ranks the cells (not set: delta_KL, or ...)"
    assert "not set, delta_KL, or delta_FV without comparable classes" in found["help_text"]["lidarsig:changes"]
    # a CRS for clouds without one, wherever clouds are read
    for job in ("saliency", "signature", "compare", "changes", "catalog"):
        assert found["labels"][f"lidarsig:{job}"]["CRS"] == "CRS of clouds without one", job
    # compare: the table first, the optional report after it
    compare = list(found["labels"]["lidarsig:compare"])
    assert compare.index("METRICS") < compare.index("REPORT")


def lod_ratio_band(path):
    """The number of the change map's band lod_ratio, from its description, its values and
    those of band 3 (significant)."""
    import rasterio

    with rasterio.open(path) as src:
        band = 1 + next(k for k, d in enumerate(src.descriptions) if d.startswith("lod_ratio:"))
        return band, src.read(band), src.read(3)


def test_changes_in_qgis_loads_the_map_and_the_cells_above_it_in_their_styles(qgis, epochs, tmp_path):
    a, b, edits = epochs
    shots = Path(os.environ["LIDAR_SIG_SCREENSHOTS"]) if os.environ.get("LIDAR_SIG_SCREENSHOTS") else None
    picture = tmp_path / "qgis_change_map.png"
    # "map.tif" sorts after "cells.gpkg": Processing adds the map last, on top, unless put back;
    # 10 m cells, so that the edits span cells at several distances from their levels
    found = qgis("changes", a=a, b=b, map=tmp_path / "map.tif", cells=tmp_path / "cells.gpkg",
                 points=tmp_path / "later.laz", picture=picture, cell=10)
    # the command's own answer for the same epochs
    done = run("changes", a, b, "--cell", "10", "--json", "--top", "100000", "-q")
    assert done.returncode == 0, done.stderr
    info = json.loads(done.stdout)
    significant = sorted([c["row"], c["col"]] for c in info["top"] if c["significant"])
    assert len(significant) >= 3  # each of the three edits in one cell or more
    assert found["results"]["SIGNIFICANT"] == len(significant)
    assert found["results"]["COMPARED"] == info["grid"]["valid"]
    loaded = {Path(layer["source"].split("|")[0]).name: layer for layer in found["loaded"]}
    raster, cells = loaded["map.tif"], loaded["cells.gpkg"]
    band, _, _ = lod_ratio_band(tmp_path / "map.tif")
    # the map drawn as one band, how far each cell lies from its level, never as bands 1-3 in RGB
    assert raster["valid"] and raster["renderer"] == "singlebandpseudocolor" and raster["band"] == band
    assert raster["legend"][0][1] == "under 0.25 x its level of detection"
    import rasterio

    with rasterio.open(tmp_path / "map.tif") as src:
        assert raster["bands"] == src.count  # every band the file holds is there to pick
    assert found["results"]["CHANGED"] == info["grid"]["changed"]
    assert [item[0] for item in raster["legend"]][2:4] == [1.0, 2.0]  # the break: at the level of detection
    assert cells["valid"] and cells["renderer"] == "RuleRenderer" and cells["labels"]
    assert cells["rules"][0].startswith("changed significantly") and cells["crs"] == "EPSG:2154"
    assert cells["significant"] == significant  # the cells layer's significant cells are the command's
    # the cells lie above the map, whatever order Processing added them in
    order = [Path(source.split("|")[0]).name for source in found["order"]]
    assert order.index("cells.gpkg") < order.index("map.tif")
    # each file opened by itself draws the same way
    assert found["alone"]["map"]["renderer"] == "singlebandpseudocolor" and found["alone"]["map"]["band"] == band
    assert found["alone"]["cells"]["renderer"] == "RuleRenderer"
    # progress and the command line in the Processing log
    assert "cell metrics" in found["stages"] and "level of detection" in found["stages"]
    assert max(found["progress"]) == 100 and any(0 < p < 100 for p in found["progress"])
    assert any(kind == "command" and "lidar-sig changes" in text for kind, text in found["log"])
    assert not any(kind == "error" for kind, _ in found["log"])
    assert (tmp_path / "later.laz").exists() and (tmp_path / "map.qml").exists()
    # the picture of the project as QGIS draws it: the edited cells in warm colours, outlined
    # near black above the raster; the others grey
    assert found["picture"] is True
    import cv2

    image = cv2.imread(str(picture))[:, :, ::-1].astype(int)
    assert image.shape[1] > 1500
    inside = image[110:1000, 60:1040]  # the map item of the print layout (8-178 mm x 16-172 mm at 150 dpi)

    def near(rgb):
        return int(np.all(np.abs(inside - rgb) < 24, axis=2).sum())

    warm = sum(near(rgb) for rgb in ([254, 217, 118], [253, 141, 60], [240, 59, 32], [189, 0, 38], [103, 0, 13]))
    assert warm > 4000 * len(significant), warm  # cells of ~90 x 90 px
    assert near([20, 20, 20]) > 300 * len(significant), near([20, 20, 20])  # their outlines, above the map
    assert near([240, 240, 240]) + near([212, 212, 212]) > 100000  # the many cells far below their level
    if shots is not None:  # keep the artefact where CI or a person looks
        shots.mkdir(parents=True, exist_ok=True)
        shutil.copy(picture, shots / "qgis_change_map.png")


@pytest.fixture(scope="module")
def unchanged(epochs, tmp_path_factory):
    """The first epoch resampled as a second survey of unchanged land: 80% of the points kept,
    everything moved 0.3 m (as the edited epoch, without its edits)."""
    from edited_epoch import KEEP, SHIFT, write_las

    from lidar_sig.change_map import read_epoch
    from lidar_sig.method.cloud import PointCloud

    one = read_epoch([epochs[0]])
    keep = np.random.default_rng(5).random(len(one.xyz)) < KEEP
    two = PointCloud(np.round(one.xyz[keep] + np.asarray(SHIFT), 3), one.labels[keep], path="resampled",
                     crs=one.crs, units=one.units)
    path = tmp_path_factory.mktemp("unchanged") / "resampled.laz"
    write_las(two, path)
    return path


def test_a_change_map_in_work_units_shows_their_progress_in_qgis_and_the_one_block_answer(qgis, epochs, tmp_path):
    # More options asking for tiles map the epochs in work units (docs/changes.md, "At survey
    # scale"), as a survey above the memory budget is: QGIS shows the tiles' and the units'
    # progress, loads the map and the cells, and counts what the map of one block counts
    a, b, _ = epochs
    found = qgis("changes", a=a, b=b, map=tmp_path / "map.tif", cells=tmp_path / "cells.gpkg", cell=10,
                 options="--tile-size 60 --workers 2")
    assert {"tiles", "work units"} <= set(found["stages"]), found["stages"]
    assert found["progress"] and max(found["progress"]) == 100
    done = run("changes", a, b, "--cell", "10", "--json", "--top", "0", "-q")
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout)["work_units"] is None  # the command alone: one block
    one_block = json.loads(done.stdout)["grid"]
    assert found["results"]["COMPARED"] == one_block["valid"]
    assert found["results"]["SIGNIFICANT"] == one_block["significant"] >= 3
    assert found["results"]["CHANGED"] == one_block["changed"]
    loaded = {Path(layer["source"].split("|")[0]).name: layer for layer in found["loaded"]}
    assert loaded["map.tif"]["valid"] and loaded["cells.gpkg"]["valid"]


def test_every_algorithm_with_temporary_outputs_returns_files_that_exist(qgis, epochs, unchanged, tmp_path):
    a, b, _ = epochs
    catalogue = tmp_path / "samples.h5"
    assert run("catalog", SAMPLES, "-o", catalogue, "--workers", "1", "-q").returncode == 0
    out = tmp_path / "out"
    out.mkdir()
    found = qgis("temporary", cloud=SAMPLES / "epoch1.laz", a=a, b=b, same=unchanged, folder=SAMPLES,
                 catalogue=catalogue, out=out)
    outputs = {"saliency": {"OUTPUT"}, "signature": {"OUTPUT", "PNG", "REPORT"}, "compare": {"METRICS", "REPORT"},
               "changes": {"OUTPUT", "CELLS", "POINTS", "REPORT"}, "no change": {"OUTPUT", "CELLS"},
               "catalog": {"OUTPUT"}, "similar": {"OUTPUT"}, "outliers": {"OUTPUT", "REPORT"},
               "model": {"similar:similar tiles"}}
    assert set(found) == {f"{name} {how}" for name in outputs for how in ("run", "load")}
    for name, done in found.items():
        assert set(done["exist"]) == outputs[name.rsplit(" ", 1)[0]], name  # a path for every output ...
        assert all(done["exist"].values()), (name, done["results"])  # ... and a file there
        assert done["errors"] == [] and done["gdal"] == [], name  # nothing "not correctly generated"
    # processing.run loads nothing; runAndLoadResults loads the layers, styled, the cells above the map
    assert all(found[f"{name} run"]["loaded"] == [] for name in outputs)
    for name in ("changes", "no change"):
        cells, raster = found[f"{name} load"]["loaded"]  # top first
        later = "epoch2.laz" if name == "changes" else "resampled.laz"
        assert (cells["name"], raster["name"]) == (f"Cells epoch1.laz → {later}", f"Change epoch1.laz → {later}")
        assert raster["renderer"] == "singlebandpseudocolor" and raster["band"] == 18 and raster["bands"] == 20
        assert cells["renderer"] == "RuleRenderer" and cells["labels"]
        assert raster["source"] == found[f"{name} load"]["results"]["OUTPUT"]
    assert found["no change load"]["loaded"][0]["significant"] == []
    [tiles] = found["outliers load"]["loaded"]
    assert tiles["renderer"] == "RuleRenderer" and tiles["rules"][0] == "stands out (score 3.5 or more)"
    assert tiles["name"] == "Outlier scores of samples.h5"
    # similar tiles: their footprints, on the map, named by the query
    [similar] = found["similar load"]["loaded"]
    assert similar["name"] == "Tiles like epoch1.laz" and similar["renderer"] == "RuleRenderer"
    assert similar["crs"] == "EPSG:2154" and similar["labels"]
    assert similar["aliases"]["kl"] == "delta_KL" and similar["precision"]["distance"] == 4
    # the model's similar read the catalogue its catalog wrote: the two other sample tiles
    [table] = found["model load"]["loaded"]
    assert table["features"] == 2 and [layer["features"] for layer in found["similar load"]["loaded"]] == [2]
    # the metrics' table: named by the clouds, its values shown rounded
    [metrics] = found["compare load"]["loaded"]
    assert metrics["name"] == "Metrics epoch1.laz → epoch1.laz" and metrics["precision"]["value"] == 4


def test_the_dialog_s_default_run_loads_a_map_without_change_styled_below_its_cells(qgis, epochs, unchanged,
                                                                                   tmp_path):
    # as the dialog runs it: temporary outputs, a background task, then its loading of the layers
    found = qgis("dialog", a=epochs[0], b=unchanged, out=tmp_path)
    assert found["ok"] and found["results"]["SIGNIFICANT"] == found["results"]["CHANGED"] == 0
    assert all(found["exist"].values())
    assert set(found["exist"]) == {"OUTPUT", "CELLS"}
    cells, raster = found["loaded"]  # top first
    assert cells["source"].split("|")[0] == found["results"]["CELLS"] and cells["renderer"] == "RuleRenderer"
    assert raster["source"] == found["results"]["OUTPUT"] and raster["renderer"] == "singlebandpseudocolor"
    assert raster["band"] == 18 and cells["significant"] == []
    assert found["errors"] == [] and found["gdal"] == []  # no "band 3: dfMax should be strictly greater than dfMin"


#: The most characters of a legend's title or entry (issue 48): the Layers panel's width, a print layout's legend.
LEGEND_MOST = 60


def test_the_dialog_s_layers_read_at_a_glance_named_by_their_epochs_in_the_crs_given(qgis, epochs, tmp_path):
    # issue 48, as the dialog runs it (temporary outputs, a background task, then its loading):
    # two epochs whose headers carry no CRS, the CRS given in the dialog
    from test_given_crs import without_crs

    from lidar_sig.metrics import METRICS

    a, b = without_crs(epochs[0], tmp_path / "2019.laz"), without_crs(epochs[1], tmp_path / "2023.laz")
    found = qgis("dialog", a=a, b=b, out=tmp_path, parameters={"CRS": "EPSG:2154", "CELL": 10})
    assert found["ok"] and found["errors"] == [] and found["gdal"] == []
    cells, raster = found["loaded"]  # top first
    # named by their epochs: two runs no longer give two identical pairs
    assert (cells["name"], raster["name"]) == ("Cells 2019.laz → 2023.laz", "Change 2019.laz → 2023.laz")
    # the CRS given reaches both layers
    assert cells["crs"] == raster["crs"] == "EPSG:2154"
    # the cells' fields by the metrics' names, their numbers rounded
    assert {m.key: cells["aliases"][m.key] for m in METRICS} == {m.key: m.name for m in METRICS}
    assert all(cells["precision"][m.key] == 4 for m in METRICS) and cells["precision"]["lod_ratio"] == 2
    # short legend titles and entries
    for layer in (cells, raster):
        assert layer["legend_texts"], layer["name"]
        for text in (layer["name"], *layer["legend_texts"]):
            assert len(text) <= LEGEND_MOST, text
    assert raster["legend_texts"][0].startswith(f"Band {raster['band']}: lod_ratio")
    # every rule listed draws a cell: none listed without a feature
    assert cells["rules"] and all(cells["matched"][rule] for rule in cells["rules"]), cells["matched"]
    # no sliver cell at the surveys' edges: the map has some, the layer draws none
    done = run("changes", a, b, "--cell", "10", "--crs", "EPSG:2154", "--json", "--top", "0", "-q")
    assert done.returncode == 0, done.stderr
    info = json.loads(done.stdout)
    sliver = 0.05 * info["min_points"]  # a few points of a cell the survey's edge barely enters
    drawn = cells["cells"]
    few = [c for c in drawn if c["coverage"] == "too few points"]
    assert info["coverage"]["cells"]["too few points"] > len(few)  # slivers in the map, left out of the layer
    assert not [c for c in drawn if c["points_a"] < sliver and c["points_b"] < sliver]
    assert len(drawn) == len(cells["cells"]) == cells["features"]


def test_a_command_that_wrote_nothing_or_bad_options_fail_in_one_line(qgis, tmp_path):
    found = qgis("nothing", a=SAMPLES / "epoch1.laz", b=ALIGNED, folder=SAMPLES, out=tmp_path,
                 map=tmp_path / "map.tif", cells=tmp_path / "cells.gpkg")
    for name, output, what in (("changes --help", "map.tif", "Change map"), ("catalog --help", "c.h5", "Catalogue"),
                               ("signature --help", "s.h5", "Signature archive"),
                               ("changes /bin/true", "map.tif", "Change map"),
                               ("saliency /bin/true", "a.laz", "Point cloud with saliency")):
        message = found[name]
        assert message is not None, name  # not a success
        assert message.startswith(f"{tmp_path / output}: lidar-sig {name.split()[0]} ended without writing"), message
        assert f"({what})" in message and "More options" in message and "\n" not in message, message
    assert found["a quote"].startswith("More options '--classes \"paper' cannot be read (no closing quotation)")
    assert "\n" not in found["a quote"] and "Traceback" not in found["a quote"]
    assert found["files"] == []


def test_a_cancelled_catalogue_can_be_resumed_with_its_file_not_as_a_temporary_output(qgis, tmp_path):
    folder = need_data(IGN)
    found = qgis("resume", folder=folder, catalogue=tmp_path / "survey.h5", percent=50)
    assert found["file"].startswith("cancelled: lidar-sig: interrupted (SIGTERM)")
    assert found["file"].endswith(f"kept in {tmp_path / 'survey.h5.work'}; to reuse it, run again with the same "
                                  "output and Resume ticked")
    # ticked, the run passes --resume and the command reuses the tiles the cancelled run finished
    assert any(kind == "command" and text.endswith(" --resume") for kind, text in found["resumed"]["log"])
    assert any(kind == "info" and "reused from the work folder" in text for kind, text in found["resumed"]["log"])
    assert found["resumed"]["exists"]
    assert "--resume" not in found["temporary"] and "a temporary output cannot be resumed" in found["temporary"]


def test_qgis_draws_every_map_in_the_same_colours_for_the_same_distance_from_its_level(qgis, tmp_path):
    # two maps with different highest scores, and a map with no change (epoch 1 against itself)
    maps = {"8 m": ("--cell", "8"), "16 m": ("--cell", "16"), "no change": ("--cell", "8")}
    paths, cells = {}, {}
    for name, options in maps.items():
        paths[name] = tmp_path / f"{name.replace(' ', '_')}.tif"
        later = SAMPLES / "epoch1.laz" if name == "no change" else ALIGNED
        done = run("changes", SAMPLES / "epoch1.laz", later, *options, "-o", paths[name], "-q")
        assert done.returncode == 0, done.stderr
        _, ratio, significant = lod_ratio_band(paths[name])
        cells[name] = {(r, c): (float(ratio[r, c]), significant[r, c] == 1)
                       for r, c in zip(*np.nonzero(ratio != -9999.0))}
    from lidar_sig.reporting.change_scale import CHANGE_SCALE

    def on_the_scale(ratio):
        """The colour the one scale of change gives a distance from the level, as QGIS writes it."""
        return "#%02x%02x%02x" % tuple(int(v) for v in CHANGE_SCALE.colours[CHANGE_SCALE.class_of([ratio])[0]])

    values = sorted({ratio for found in cells.values() for ratio, _ in found.values()})
    found = qgis("shades", maps=[str(p) for p in paths.values()], values=values, pixels=9)
    drawn = {True: set(), False: set()}
    for name, path in paths.items():
        seen = found[str(path)]
        assert seen["gdal"] == [], seen["gdal"]  # no "band 3: dfMax should be strictly greater than dfMin"
        for (r, c), (ratio, significant) in cells[name].items():
            # each map's style gives each of its cells' distances the colour of the one scale (its legend
            # lists the scale's classes that its cells fall in), and QGIS draws the cell so
            assert seen["values"][repr(ratio)] == seen["cells"][f"{r},{c}"] == on_the_scale(ratio), (name, ratio)
            drawn[significant].add(seen["cells"][f"{r},{c}"])
    assert not drawn[True] & drawn[False]  # a significant cell never looks like one that is not
    assert len(drawn[True]) >= 2 and all(int(c[1:3], 16) > int(c[5:7], 16) for c in drawn[True])  # warm
    assert all(c[1:3] == c[3:5] == c[5:7] for c in drawn[False])  # greys
    assert not any(significant for _, significant in cells["no change"].values())
    assert {found[str(paths["no change"])]["cells"][f"{r},{c}"] for r, c in cells["no change"]} <= drawn[False]


def test_cancelling_in_qgis_stops_the_command_and_leaves_no_output(qgis, epochs, tmp_path):
    a, b, _ = epochs
    found = qgis("cancel", a=a, b=b, map=tmp_path / "map.tif", cells=tmp_path / "cells.gpkg",
                 report=tmp_path / "r.html", stage="cell metrics")
    assert found["canceled"] and found["stages"][-1] == "cell metrics"
    assert found["exception"].startswith("cancelled: lidar-sig: interrupted (SIGTERM)")
    assert found["files"] == []  # no output, no temporary file


def test_a_bad_input_and_a_missing_command_are_processing_exceptions_naming_the_fix(qgis, tmp_path):
    bad = tmp_path / "broken.laz"
    bad.write_text("not a LAS file")
    found = qgis("errors", a=bad, b=SAMPLES / "epoch1.laz", map=tmp_path / "map.tif", cells=tmp_path / "cells.gpkg")
    assert found["bad input"].startswith(f"{bad}: ") and "\n" not in found["bad input"]
    assert found["no command"].startswith("lidar-sig was not found on PATH; install it (pip install lidar-sig) or set")
    assert found["a table"].startswith("ogr:dbname=") and "choose Save to File... and give a .gpkg file" in \
        found["a table"]
    assert found["files"] == ["broken.laz"]


def test_compare_in_qgis_gives_the_metrics_as_a_table_on_the_project_s_scale(qgis):
    found = qgis("compare", a=SAMPLES / "epoch1.laz", b=SAMPLES / "epoch2.laz")
    assert found["fields"][-5:] == ["key", "metric", "value", "like", "on_scale"]  # after a GeoPackage's fid
    from lidar_sig.metrics import METRICS

    assert [r["metric"] for r in found["rows"]] == [m.name for m in METRICS]
    done = run("compare", SAMPLES / "epoch1.laz", SAMPLES / "epoch2.laz", "--json")
    info = json.loads(done.stdout)
    for row in found["rows"]:
        assert row["value"] == pytest.approx(info[row["key"]], rel=1e-12)
        assert row["on_scale"] == info["scale"][row["key"]]["says"]


def test_the_other_jobs_run_in_qgis_as_their_commands_do(qgis, tmp_path):
    import laspy

    out = tmp_path / "out"
    out.mkdir()
    found = qgis("jobs", cloud=SAMPLES / "epoch1.laz", folder=SAMPLES, out=out)
    assert {"cloud_sal.laz", "cloud.h5", "cloud.png", "survey.h5", "tiles.gpkg", "qc.html"} <= set(found["files"])
    assert "OptimalScale" in laspy.read(out / "cloud_sal.laz").point_format.extra_dimension_names  # strategy optimal
    assert "saliency (c3dcm optimal)" in found["saliency"]["stages"] and "tiles" in found["catalog"]["stages"]
    assert any(kind == "info" and "3 tiles (3 added)" in line for kind, line in found["catalog"]["log"])
    # similar: the query's own tile left out, the two others best first, as the command lists them
    done = run("similar", SAMPLES / "epoch1.laz", out / "survey.h5", "--top", "2", "--json")
    expected = [[r["rank"], r["name"], pytest.approx(r["distance"], rel=1e-12)]
                for r in json.loads(done.stdout)["results"]]
    assert found["similar"]["rows"] == expected and "epoch1.laz" not in [r[1] for r in expected]
    assert found["outliers"]["results"]["STANDING_OUT"] == 1
    assert found["outliers"]["results"]["VERDICT"].startswith("1 tile stands out")


#: The cells of a series' second interval (epoch2_aligned.laz to itself), named by it.
SECOND = "cells_epoch2_aligned_to_epoch2_aligned"


def test_qgis_opens_the_change_map_and_the_geopackages_in_their_styles_by_themselves(qgis, tmp_path):
    cat = tmp_path / "samples.h5"
    assert run("catalog", SAMPLES, "-o", cat, "--workers", "1", "-q").returncode == 0
    assert run("outliers", cat, "-o", tmp_path / "tiles.gpkg", "-q").returncode == 0
    done = run("changes", SAMPLES / "epoch1.laz", SAMPLES / "epoch2_aligned.laz", SAMPLES / "epoch2_aligned.laz",
               "--cell", "8", "-o", tmp_path / "series.tif", "--cells", tmp_path / "series.gpkg", "-q")
    assert done.returncode == 0, done.stderr
    found = qgis("open", rasters=[str(tmp_path / "series.tif")],
                 vectors=[str(tmp_path / "tiles.gpkg"), f"{tmp_path / 'series.gpkg'}|layername={SECOND}"])
    series = found[str(tmp_path / "series.tif")]
    import rasterio

    with rasterio.open(tmp_path / "series.tif") as written:  # "when", the last band, drawn
        assert series["renderer"] == "singlebandpseudocolor" and series["band"] == series["bands"] == written.count
        assert written.descriptions[-1].startswith("when")
    assert [item[1].split(":")[0] for item in series["legend"]] == ["0", "1", "2"]
    tiles = found[str(tmp_path / "tiles.gpkg")]
    assert tiles["renderer"] == "RuleRenderer" and tiles["rules"][0] == "stands out (score 3.5 or more)"
    # a series' layers named by their intervals
    assert found[f"{tmp_path / 'series.gpkg'}|layername={SECOND}"]["renderer"] == "RuleRenderer"
    with sqlite3.connect(tmp_path / "series.gpkg") as db:
        assert [r[0] for r in db.execute("SELECT table_name FROM gpkg_geometry_columns ORDER BY table_name")] == \
            ["cells_epoch1_to_epoch2_aligned", SECOND]


def test_the_cells_style_draws_land_appeared_inside_the_other_survey_as_changed_and_not_its_edge(qgis, tmp_path):
    # issue 38: QGIS's own expression engine, on the cells layer opened by itself in its style
    import sqlite3

    from test_change_coverage import holed

    (a, b), _ = holed(tmp_path)
    done = run("changes", a, b, "--cell", "8", "--cells", tmp_path / "cells.gpkg", "-q")
    assert done.returncode == 0, done.stderr
    with sqlite3.connect(tmp_path / "cells.gpkg") as db:
        rows = db.execute("SELECT row, col, changed, coverage FROM cells").fetchall()
    changed = {(r, c) for r, c, ch, _ in rows if ch == 1}
    edges = {(r, c) for r, c, ch, state in rows if state in ("appeared", "vanished") and ch == 0}
    assert any(state == "appeared" for r, c, ch, state in rows if (r, c) in changed) and edges
    layer = qgis("open", vectors=[str(tmp_path / "cells.gpkg")])[str(tmp_path / "cells.gpkg")]
    matched = layer["matched"]
    said_changed = [label for label in matched if label.startswith("changed") or label.endswith(": changed")]
    said_edge = [label for label in matched if label.endswith(": not counted")]
    assert {tuple(c) for label in said_changed for c in matched[label]} == changed
    assert {tuple(c) for label in said_edge for c in matched[label]} == edges
