"""An area of interest (issue 49): the clouds clipped to it before anything is computed, reading
only what it needs: tiles outside it are not opened beyond their header, COPC files are queried
by its bounds, locally or from a web server by range requests."""
import functools
import http.server
import json
import os
import threading

import laspy
import numpy as np
import pytest

import lidar_sig as ls
from command_line import run
from conftest import DATA, SAMPLES

COPC = DATA / "copc" / "test_data_77050_627755.copc.laz"
pytestmark = pytest.mark.skipif(not (SAMPLES / "epoch1.laz").exists(), reason="data_samples/ not written")


def _write_part(las, keep, path):
    part = laspy.LasData(header=las.header, points=las.points[keep])
    part.write(path)


@pytest.fixture(scope="module")
def tiled_epochs(tmp_path_factory):
    """Each sample epoch cut into a west and an east tile at the same x; the east tile of A
    damaged (its points cut off mid-file); an area inside the west tiles."""
    folder = tmp_path_factory.mktemp("tiled")
    one = laspy.read(SAMPLES / "epoch1.laz")
    cut = float(np.median(one.x))
    dirs = []
    for name in ("epoch1", "epoch2"):
        las = laspy.read(SAMPLES / f"{name}.laz")
        d = folder / name
        d.mkdir()
        _write_part(las, np.asarray(las.x) < cut, d / "west.laz")
        _write_part(las, np.asarray(las.x) >= cut, d / "east.laz")
        dirs.append(d)
    east = dirs[0] / "east.laz"
    east.write_bytes(east.read_bytes()[: east.stat().st_size // 2])  # damaged: its points cut off
    y0, y1 = float(one.header.mins[1]), float(one.header.maxs[1])
    x0 = float(one.header.mins[0])
    area = (x0 + 2.0, y0 + 2.0, cut - 1.0, y1 - 2.0)
    return dirs, area, folder


def test_a_change_map_of_an_area_skips_a_damaged_tile_outside_it_and_is_the_map_of_the_clipped_epochs(tiled_epochs):
    dirs, area, folder = tiled_epochs
    with pytest.raises(ls.LidarSigError, match="east.laz"):  # without the area, the damaged tile stops the run
        ls.changes(*dirs, pipeline=ls.Pipeline(progress=False))
    mapped = ls.changes(*dirs, aoi=",".join(f"{v!r}" for v in area), cell=5.0, pipeline=ls.Pipeline(progress=False))
    assert mapped.reading.skipped == ["east.laz", "east.laz"]  # A's damaged tile and B's: their headers only
    assert mapped.reading.files == 2
    clipped = []
    for name in ("epoch1", "epoch2"):  # clipped beforehand, by hand
        las = laspy.read(SAMPLES / f"{name}.laz")
        x, y = np.asarray(las.x), np.asarray(las.y)
        inside = (x >= area[0]) & (x <= area[2]) & (y >= area[1]) & (y <= area[3])
        clipped.append(folder / f"{name}_clipped.laz")
        _write_part(las, inside, clipped[-1])
    assert mapped.reading.kept == sum(laspy.open(p).header.point_count for p in clipped)
    expected = ls.changes(*clipped, cell=5.0, pipeline=ls.Pipeline(progress=False))
    assert int(expected.table["valid"].sum()) >= 8
    assert (mapped.grid.rows, mapped.grid.cols, mapped.cell) == (expected.grid.rows, expected.grid.cols, expected.cell)
    for name in expected.table.dtype.names:
        got, want = mapped.table[name], expected.table[name]
        if want.dtype.kind == "f":
            np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-12, equal_nan=True, err_msg=name)
        else:
            np.testing.assert_array_equal(got, want, err_msg=name)


def test_an_area_as_a_polygon_file_in_another_crs_is_reprojected(tmp_path):
    import pyproj

    las = laspy.read(COPC)
    x0, y0 = float(las.header.mins[0]) + 5, float(las.header.mins[1]) + 5
    triangle = np.array([[x0, y0], [x0 + 20, y0], [x0, y0 + 20], [x0, y0]])
    to_lonlat = pyproj.Transformer.from_crs("EPSG:2154", "EPSG:4326", always_xy=True)
    lon, lat = to_lonlat.transform(triangle[:, 0], triangle[:, 1])
    geojson = tmp_path / "area.geojson"
    geojson.write_text(json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {}, "geometry": {"type": "Polygon",
                                                           "coordinates": [list(map(list, zip(lon, lat)))]}}]}))
    from lidar_sig.io.aoi import area_of
    from lidar_sig.io.geopackage import Layer, write_geopackage

    gpkg = tmp_path / "area.gpkg"
    write_geopackage(gpkg, [Layer("area", pyproj.CRS("EPSG:2154").to_wkt(), [(triangle, {"name": "a"})])])
    x, y = np.asarray(las.x), np.asarray(las.y)
    inside = (x - x0 >= 0) & (y - y0 >= 0) & ((x - x0) + (y - y0) <= 20)
    for path in (geojson, gpkg):
        area = area_of(path).in_crs(pyproj.CRS("EPSG:2154").to_wkt())
        got = area.contains(x, y)
        near_edge = ((np.abs((x - x0) + (y - y0) - 20) < 0.05) | (np.abs(x - x0) < 0.05)
                     | (np.abs(y - y0) < 0.05))  # reprojected edges are within millimetres
        assert np.array_equal(got[~near_edge], inside[~near_edge]), path.name
        assert 0 < got.sum() < len(x)


@pytest.mark.parametrize("aoi, said", [
    ("1,2,3", "--aoi '1,2,3' is not four numbers"),
    ("10,0,5,1", "with XMIN < XMAX"),
    ("0,0,1,1", "misses every cloud"),
    ("0,0,1,1 [EPSG:99999]", "unknown CRS"),
    ("empty.geojson", "holds no polygon"),
])
def test_a_bad_area_is_one_line(tmp_path, aoi, said):
    (tmp_path / "empty.geojson").write_text('{"type": "FeatureCollection", "features": []}')
    done = run("saliency", COPC, "-o", tmp_path / "out.laz", "--aoi", aoi, cwd=tmp_path)
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and said in lines[0], done.stderr
    assert not (tmp_path / "out.laz").exists()


class _Server:
    """A local web server of a folder, on 127.0.0.1, that honours Range requests (or not) and
    counts the bytes of the files it sends."""

    def __init__(self, folder, ranges=True, failures=0):
        server = self
        self.sent = 0
        self.failures = failures  # requests answered 503 first (a server busy for a moment)

        class Handler(http.server.SimpleHTTPRequestHandler):
            def __init__(self, *args, **kwargs):
                super().__init__(*args, directory=str(folder), **kwargs)

            def log_message(self, *args):
                pass

            def do_GET(self):
                path = self.translate_path(self.path)
                if server.failures > 0:
                    server.failures -= 1
                    return self.send_error(503)
                if not os.path.isfile(path):
                    return self.send_error(404)
                data = open(path, "rb").read()
                asked = self.headers.get("Range")
                if ranges and asked and asked.startswith("bytes="):
                    a, b = asked[6:].split("-")
                    a, b = int(a), min(int(b) if b else len(data) - 1, len(data) - 1)
                    body = data[a:b + 1]
                    self.send_response(206)
                    self.send_header("Content-Range", f"bytes {a}-{b}/{len(data)}")
                else:
                    body = data
                    self.send_response(200)
                self.send_header("Content-Length", str(len(body)))
                self.end_headers()
                self.wfile.write(body)
                server.sent += len(body)

        self.httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.url = f"http://127.0.0.1:{self.httpd.server_address[1]}"
        threading.Thread(target=self.httpd.serve_forever, daemon=True).start()

    def close(self):
        self.httpd.shutdown()
        self.httpd.server_close()


@pytest.fixture
def served(tmp_path):
    folder = tmp_path / "www"
    folder.mkdir()
    for name in ("a.copc.laz", "b.copc.laz"):
        (folder / name).write_bytes(COPC.read_bytes())
    server = _Server(folder)
    yield server, folder
    server.close()


def _small_area():
    h = laspy.open(COPC).header
    x0, y0 = float(h.mins[0]), float(h.mins[1])
    return (x0 + 2, y0 + 2, x0 + 8, y0 + 8)


def test_saliency_of_a_copc_url_in_an_area_fetches_fewer_bytes_than_the_file(served, tmp_path):
    server, folder = served
    area = _small_area()
    out = tmp_path / "s.laz"
    done = run("saliency", f"{server.url}/a.copc.laz", "-o", out, "--aoi", ",".join(map(str, area)), "--json")
    assert done.returncode == 0, done.stderr
    las = laspy.read(out)
    x, y = np.asarray(las.x), np.asarray(las.y)
    assert len(las) > 100
    assert x.min() >= area[0] and x.max() <= area[2] and y.min() >= area[1] and y.max() <= area[3]
    read = json.loads(done.stdout)["aoi"]
    assert 0 < server.sent < COPC.stat().st_size
    assert read["bytes_fetched"] == server.sent and read["copc_nodes"] >= 1
    assert read["points_kept"] == len(las)


def test_changes_of_two_copc_urls_in_an_area_writes_only_points_of_it(served, tmp_path):
    server, folder = served
    area = _small_area()
    points = tmp_path / "b.laz"
    done = run("changes", f"{server.url}/a.copc.laz", f"{server.url}/b.copc.laz", "--aoi", ",".join(map(str, area)),
               "--points", points, "--cell", "2", "--json")
    assert done.returncode == 0, done.stderr
    las = laspy.read(points)
    x, y = np.asarray(las.x), np.asarray(las.y)
    assert x.min() >= area[0] and x.max() <= area[2] and y.min() >= area[1] and y.max() <= area[3]
    assert 0 < server.sent < 2 * COPC.stat().st_size
    assert json.loads(done.stdout)["aoi"]["bytes_fetched"] == server.sent


def test_a_vpc_of_url_hrefs_resolves_them_against_its_own_url(served, tmp_path):
    server, folder = served
    (folder / "ep.vpc").write_text(json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "assets": {"data": {"href": "a.copc.laz", "roles": ["data"]}}, "properties": {}}]}))
    out = tmp_path / "s.laz"
    done = run("saliency", f"{server.url}/ep.vpc", "-o", tmp_path / "out", "--aoi", ",".join(map(str, _small_area())),
               "--workers", "1")
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "out" / "a.copc.laz").is_file() and not out.exists()


def test_a_server_without_range_requests_is_one_line_with_the_fix(tmp_path):
    folder = tmp_path / "www"
    folder.mkdir()
    (folder / "t.laz").write_bytes((SAMPLES / "epoch1.laz").read_bytes())
    server = _Server(folder, ranges=False)
    try:
        done = run("saliency", f"{server.url}/t.laz", "-o", tmp_path / "s.laz")
    finally:
        server.close()
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "does not answer byte-range requests" in lines[0] and "download it" in lines[0]


def test_a_vpc_feature_outside_the_area_is_not_opened_at_all(tiled_epochs, tmp_path):
    dirs, area, folder = tiled_epochs
    west = laspy.open(dirs[1] / "west.laz").header
    far = [area[2] + 100, area[1], area[2] + 150, area[3]]

    def feature(href, lo, hi):
        return {"type": "Feature", "assets": {"data": {"href": href, "roles": ["data"]}},
                "properties": {"proj:epsg": 2154, "proj:bbox": [lo[0], lo[1], hi[0], hi[1]]}}

    vpc = dirs[1] / "epoch.vpc"
    vpc.write_text(json.dumps({"type": "FeatureCollection", "features": [
        feature("west.laz", west.mins, west.maxs), feature("nowhere.laz", far[:2], far[2:])]}))
    done = ls.jobs.saliency(vpc, tmp_path / "out", aoi=area, execution=ls.Execution(workers=1),
                            pipeline=ls.Pipeline(progress=False))
    assert done.reading.skipped == ["nowhere.laz"]  # listed, missing, outside: never looked for
    assert [p.name for p in (tmp_path / "out").iterdir() if p.suffix == ".laz"] == ["west.laz"]
    with pytest.raises(ls.LidarSigError, match="does not exist"):  # without the area, it is looked for
        ls.jobs.saliency(vpc, tmp_path / "out2", execution=ls.Execution(workers=1),
                         pipeline=ls.Pipeline(progress=False))


def test_a_local_vpc_of_urls_given_where_urls_are_not_read_is_one_line(tmp_path):
    from lidar_sig.tiling.sources import expand

    vpc = tmp_path / "remote.vpc"
    vpc.write_text(json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "assets": {"data": {"href": "https://example.org/t.copc.laz"}}, "properties": {}}]}))
    with pytest.raises(ls.LidarSigError, match="a URL; give the .vpc to a command or job"):
        expand([vpc])


def test_a_las_1_4_file_with_evlrs_is_clipped_with_them(tmp_path):
    # the clipped copy's writer took the EVLRs as a plain list and failed ("'list' object has no attribute 'write_to'")
    las = laspy.read(SAMPLES / "epoch1.laz")
    las.evlrs = laspy.vlrs.vlrlist.VLRList([laspy.VLR("lidar_sig_test", 7, "a note", b"kept")])
    las.write(tmp_path / "with_evlr.laz")
    from lidar_sig.io.clip import clip_inputs

    h = las.header
    area = (h.mins[0] + 5, h.mins[1] + 5, h.mins[0] + 25, h.mins[1] + 25)
    with clip_inputs([str(tmp_path / "with_evlr.laz")], area) as clip:
        copy = laspy.read(clip.inputs[0])
        assert [(v.user_id, v.record_id, v.record_data) for v in copy.evlrs] == [("lidar_sig_test", 7, b"kept")]
        assert 0 < len(copy) == clip.reading.kept < len(las)


def test_a_busy_server_is_asked_again_and_a_missing_file_is_one_line(tmp_path, monkeypatch):
    from lidar_sig.io import remote

    monkeypatch.setattr(remote.time, "sleep", lambda seconds: None)  # the waits between attempts
    folder = tmp_path / "www"
    folder.mkdir()
    (folder / "a.copc.laz").write_bytes(COPC.read_bytes())
    server = _Server(folder, failures=2)
    try:
        with remote.RangeFile(f"{server.url}/a.copc.laz") as fh:  # two 503s, then the answer
            assert fh.size == COPC.stat().st_size and fh.read(4) == b"LASF"
        server.failures = remote.RETRIES + 1  # busy beyond the retries
        with pytest.raises(ls.LidarSigError, match="HTTP 503"):
            remote.RangeFile(f"{server.url}/a.copc.laz")
        with pytest.raises(ls.LidarSigError, match="HTTP 404 .*check the URL"):
            remote.RangeFile(f"{server.url}/gone.copc.laz")
    finally:
        server.close()
