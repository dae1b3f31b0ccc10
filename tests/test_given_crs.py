"""--crs (crs=): the CRS of clouds whose header carries none (issue 48; the AHN3 crop is one),
reaching every output layer; a cloud that carries another CRS refused in one line."""
import json
import os
import sqlite3

import laspy
import pytest

from command_line import run
from conftest import SAMPLES
from robustness.helpers import assert_one_line_error

RD_NEW = "EPSG:28992"


def without_crs(source, path):
    """``source`` written to ``path`` without its CRS records (as the AHN3 crop comes)."""
    las = laspy.read(source)
    for record in [v for v in las.header.vlrs if "Geo" in type(v).__name__ or "Coordinate" in type(v).__name__]:
        las.header.vlrs.remove(record)
    las.write(path)
    assert laspy.read(path).header.parse_crs() is None
    return path


@pytest.fixture(scope="module")
def bare(tmp_path_factory):
    top = tmp_path_factory.mktemp("bare")
    return (without_crs(SAMPLES / "epoch1.laz", top / "a.laz"),
            without_crs(SAMPLES / "epoch2_aligned.laz", top / "b.laz"))


def test_a_crs_given_reaches_the_geotiff_and_the_geopackage(bare, tmp_path):
    import rasterio

    a, b = bare
    done = run("changes", a, b, "--crs", RD_NEW, "--cell", "8", "-o", tmp_path / "m.tif", "--cells",
               tmp_path / "c.gpkg", "--json", "-q")
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout)["crs"] == "Amersfoort / RD New"
    with rasterio.open(tmp_path / "m.tif") as src:
        assert src.crs.to_epsg() == 28992
    with sqlite3.connect(tmp_path / "c.gpkg") as db:
        assert db.execute("SELECT srs_id FROM gpkg_geometry_columns").fetchall() == [(28992,)]
    # without it, the layers have none
    done = run("changes", a, b, "--cell", "8", "-o", tmp_path / "n.tif", "--json", "-q")
    assert done.returncode == 0 and json.loads(done.stdout)["crs"] is None
    assert "LIDAR_SIG_CRS" not in os.environ


def test_the_other_commands_take_it_and_a_catalogue_keeps_it(bare, tmp_path):
    a, b = bare
    done = run("compare", a, b, "--crs", RD_NEW, "--json")
    assert done.returncode == 0, done.stderr
    folder = tmp_path / "tiles"
    folder.mkdir()
    for path in bare:
        (folder / path.name).write_bytes(path.read_bytes())
    done = run("catalog", folder, "-o", tmp_path / "c.h5", "--crs", RD_NEW, "--workers", "2", "--json", "-q")
    assert done.returncode == 0, done.stderr
    [crs] = json.loads(done.stdout)["crs"]  # the catalogue records it
    assert "Amersfoort" in crs
    for job, out in (("signature", "s.h5"), ("saliency", "s.laz")):
        done = run(job, a, "-o", tmp_path / out, "--crs", RD_NEW, "-q")
        assert done.returncode == 0, (job, done.stderr)


def test_a_cloud_in_another_crs_or_a_crs_that_is_none_is_refused_in_one_line(bare, tmp_path):
    # epoch1.laz carries Lambert-93 (EPSG:2154): a CRS given for clouds without one would misname it
    done = run("changes", SAMPLES / "epoch1.laz", bare[1], "--crs", RD_NEW, "-o", tmp_path / "m.tif")
    assert_one_line_error(done, "epoch1.laz", "carries the CRS RGF93")
    assert "--crs" in done.stderr and list(tmp_path.iterdir()) == []
    done = run("compare", *bare, "--crs", "not-a-crs")
    assert_one_line_error(done, "--crs 'not-a-crs' is not a CRS", "EPSG:28992")
    done = run("signature", bare[0], "-o", tmp_path / "s.h5", "--crs", "EPSG:4326")
    assert_one_line_error(done, "EPSG:4326 is geographic", "projected CRS")
    # the same CRS given to a cloud that carries it: nothing to refuse
    done = run("compare", SAMPLES / "epoch1.laz", bare[1], "--crs", "EPSG:2154", "--json")
    assert done.returncode == 0, done.stderr


def test_python_jobs_take_crs(bare, tmp_path):
    from lidar_sig.jobs import changes

    done = changes(list(bare), output=tmp_path / "m.tif", crs=RD_NEW, cell=8)
    assert "Amersfoort" in done.changes.settings()["crs"]


def test_clouds_crs_names_the_crs_of_clouds_read_within_it_and_only_there(bare):
    import lidar_sig as ls
    from lidar_sig.method.crs import clouds_crs, crs_name

    with clouds_crs(RD_NEW):
        inside = ls.read(bare[0])
    assert crs_name(inside.crs) == "Amersfoort / RD New" and inside.units.known
    assert ls.read(bare[0]).crs is None  # outside, the header's own: none
