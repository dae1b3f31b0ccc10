"""The QGIS face (issue 32): the Processing provider installed from its zip (qgis/build_plugin.py)
into QGIS running headless (Debian's qgis and python3-qgis, QT_QPA_PLATFORM=offscreen; its
Python is Debian's, not this one), its algorithms listed and run as an analyst runs them, the
outputs drawn in their styles, a run cancelled and errors turned into QgsProcessingExceptions
(tests/qgis_driver.py does the QGIS side). Pictures of the map as QGIS draws it are kept where
LIDAR_SIG_SCREENSHOTS points, as the report's are. The parts of the provider that need no QGIS
(reading the command's lines, running and cancelling it) are tested here with this Python."""
import importlib.util
import json
import os
import shutil
import signal
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
    assert found["algorithms"] == sorted(f"lidarsig:{job}" for job in ("saliency", "signature", "compare", "changes",
                                                                         "catalog", "similar", "outliers"))
    assert all(found["help"].values()) and found["groups"] == ["Change maps", "Point clouds", "Survey catalogues"]
    assert {"EPOCH_A", "EPOCH_B", "OUTPUT", "CELLS", "POINTS", "REPORT", "OPTIONS"} <= \
        set(found["parameters"]["lidarsig:changes"])
    assert "METRICS" in found["parameters"]["lidarsig:compare"]
    # the names offered are the installed command's (a plugin's too), not a list of the provider's
    offered = json.loads(run("plugins", "--json").stdout)
    assert found["choices"]["lidarsig:saliency:DESCRIPTOR"] == list(offered["descriptors"])
    assert found["choices"]["lidarsig:saliency:STRATEGY"] == list(offered["strategies"])
    assert found["choices"]["lidarsig:changes:SCORE"] == list(offered["metrics"])


def test_changes_in_qgis_loads_the_map_and_the_cells_in_their_styles(qgis, epochs, tmp_path):
    a, b, edits = epochs
    shots = Path(os.environ["LIDAR_SIG_SCREENSHOTS"]) if os.environ.get("LIDAR_SIG_SCREENSHOTS") else None
    picture = tmp_path / "qgis_change_map.png"
    found = qgis("changes", a=a, b=b, map=tmp_path / "map.tif", cells=tmp_path / "cells.gpkg",
                 points=tmp_path / "later.laz", picture=picture)
    # the command's own answer for the same epochs
    done = run("changes", a, b, "--json", "--top", "100000", "-q")
    assert done.returncode == 0, done.stderr
    info = json.loads(done.stdout)
    significant = sorted([c["row"], c["col"]] for c in info["top"] if c["significant"])
    assert len(significant) == 3  # the three edits (docs/changes.md; tests/test_change_lod.py)
    assert found["results"]["SIGNIFICANT"] == 3 and found["results"]["COMPARED"] == info["grid"]["valid"]
    loaded = {Path(layer["source"].split("|")[0]).name: layer for layer in found["loaded"]}
    raster, cells = loaded["map.tif"], loaded["cells.gpkg"]
    assert raster["valid"] and raster["renderer"] == "singlebandpseudocolor" and raster["band"] == 1
    import rasterio

    with rasterio.open(tmp_path / "map.tif") as written:  # every band of the file, the score drawn
        assert raster["legend"][0][1] == "0: delta_KL as unchanged land" and raster["bands"] == written.count
    assert cells["valid"] and cells["renderer"] == "RuleRenderer" and cells["labels"]
    assert cells["rules"][0] == "changed significantly" and cells["crs"] == "EPSG:2154"
    assert cells["significant"] == significant  # the cells layer's significant cells are the command's
    # each file opened by itself draws the same way
    assert found["alone"]["map"]["renderer"] == "singlebandpseudocolor" and found["alone"]["map"]["band"] == 1
    assert found["alone"]["cells"]["renderer"] == "RuleRenderer"
    # progress and the command line in the Processing log
    assert "cell metrics" in found["stages"] and "level of detection" in found["stages"]
    assert max(found["progress"]) == 100 and any(0 < p < 100 for p in found["progress"])
    assert any(kind == "command" and "lidar-sig changes" in text for kind, text in found["log"])
    assert (tmp_path / "later.laz").exists() and (tmp_path / "map.qml").exists()
    # the picture of the map as QGIS draws it: the ramp's darkest red where the top cell is
    assert found["picture"] is True
    import cv2

    image = cv2.imread(str(picture))[:, :, ::-1]
    assert image.shape[1] > 1500
    dark_red = np.all(np.abs(image.astype(int) - [128, 0, 38]) < 30, axis=2).sum()
    assert dark_red > 500, dark_red  # the highest score's colour and the significant cells' outline
    if shots is not None:  # keep the artefact where CI or a person looks
        shots.mkdir(parents=True, exist_ok=True)
        shutil.copy(picture, shots / "qgis_change_map.png")


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


def test_qgis_opens_the_change_map_and_the_geopackages_in_their_styles_by_themselves(qgis, tmp_path):
    cat = tmp_path / "samples.h5"
    assert run("catalog", SAMPLES, "-o", cat, "--workers", "1", "-q").returncode == 0
    assert run("outliers", cat, "-o", tmp_path / "tiles.gpkg", "-q").returncode == 0
    done = run("changes", SAMPLES / "epoch1.laz", SAMPLES / "epoch2_aligned.laz", SAMPLES / "epoch2_aligned.laz",
               "--cell", "8", "-o", tmp_path / "series.tif", "--cells", tmp_path / "series.gpkg", "-q")
    assert done.returncode == 0, done.stderr
    found = qgis("open", rasters=[str(tmp_path / "series.tif")],
                 vectors=[str(tmp_path / "tiles.gpkg"), f"{tmp_path / 'series.gpkg'}|layername=cells_2"])
    series = found[str(tmp_path / "series.tif")]
    import rasterio

    with rasterio.open(tmp_path / "series.tif") as written:  # "when", the last band, drawn
        assert series["renderer"] == "singlebandpseudocolor" and series["band"] == series["bands"] == written.count
        assert written.descriptions[-1].startswith("when")
    assert [item[1].split(":")[0] for item in series["legend"]] == ["0", "1", "2"]
    tiles = found[str(tmp_path / "tiles.gpkg")]
    assert tiles["renderer"] == "RuleRenderer" and tiles["rules"][0] == "stands out (score 3.5 or more)"
    assert found[f"{tmp_path / 'series.gpkg'}|layername=cells_2"]["renderer"] == "RuleRenderer"
