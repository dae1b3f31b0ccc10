"""Scriptable everywhere (issue 32): every command's --json prints one JSON object on stdout and
nothing else there, which a program parses."""
import json

import pytest

from command_line import run
from conftest import SAMPLES

EPOCH1, EPOCH2 = SAMPLES / "epoch1.laz", SAMPLES / "epoch2.laz"


@pytest.fixture(scope="module")
def catalogue(tmp_path_factory):
    path = tmp_path_factory.mktemp("catalogue") / "samples.h5"
    assert run("catalog", EPOCH1, EPOCH2, "-o", path, "--workers", "1", "-q").returncode == 0
    return path


def _json(*args):
    done = run(*args, "--json")
    assert done.returncode == 0, done.stderr
    assert len(done.stdout.strip().splitlines()) == 1, done.stdout  # one object, nothing else on stdout
    return json.loads(done.stdout)


def test_saliency_json_says_what_it_wrote(tmp_path):
    out = _json("saliency", EPOCH1, "-o", tmp_path / "s.laz")
    assert out["written"] == [str(tmp_path / "s.laz")] and out["complete"] and out["run"]["n_points"] == 41_507


def test_signature_json_says_what_it_wrote_and_the_signature(tmp_path):
    out = _json("signature", EPOCH1, "-o", tmp_path / "s.h5")
    assert out["written"] == [str(tmp_path / "s.h5")] and out["signature"]["points"] == 41_507


def test_compare_json_has_the_metrics_and_both_sides():
    out = _json("compare", EPOCH1, EPOCH2)
    assert 0 < out["l1"] < 2 and out["a"]["points"] == 41_507 and out["written"] == []


def test_resilience_json_has_each_metric_per_fraction():
    out = _json("resilience", EPOCH2, "--fractions", "1,0.5", "--repeats", "1")
    assert out["fractions"] == [1.0, 0.5] and set(out["metrics"]) >= {"bhattacharyya", "fv"}


def test_changes_json_has_the_grid_coverage_and_cells():
    out = _json("changes", EPOCH1, SAMPLES / "epoch2_aligned.laz", "--cell", "16")
    assert out["grid"]["rows"] >= 4 and out["coverage"]["cells"]["compared"] > 0 and out["top"]


def test_catalog_json_lists_the_tiles_it_added(tmp_path):
    out = _json("catalog", EPOCH1, EPOCH2, "-o", tmp_path / "c.h5", "--workers", "1")
    assert out["tiles"] == 2 and len(out["added"]) == 2 and out["complete"]


def test_similar_json_ranks_the_tiles(catalogue):
    out = _json("similar", "epoch1.laz", catalogue)
    assert [r["name"] for r in out["results"]] == ["epoch2.laz"]


def test_outliers_json_scores_every_tile(catalogue):
    out = _json("outliers", catalogue)
    assert sorted(r["name"] for r in out["results"]) == ["epoch1.laz", "epoch2.laz"] and out["written"] == []


@pytest.mark.parametrize("what", ["archive", "catalogue", "cloud"])
def test_info_json_describes_each_kind_of_file(tmp_path, catalogue, what):
    path = {"cloud": EPOCH2, "catalogue": catalogue}.get(what)
    if what == "archive":
        path = tmp_path / "s.h5"
        assert run("signature", EPOCH2, "-o", path, "-q").returncode == 0
    out = _json("info", path)
    assert out["kind"] == what
    if what == "cloud":
        assert out["points"] == 31_354 and out["labels"]["2"] == 19_054 and out["las"]["version"] == "1.4"
    elif what == "archive":
        assert out["signature"]["points"] == 31_354 and out["method"]["descriptor"] == "c3dcm"
    else:
        assert [t["name"] for t in out["tiles"]] == ["epoch1.laz", "epoch2.laz"]


def test_plugins_json_lists_descriptors_and_strategies():
    out = _json("plugins")
    assert {"c3dcm", "t3dvt", "t3dvt-get"} <= set(out["descriptors"]) and set(out["strategies"]) >= {"multiscale"}
    assert out["descriptors"]["c3dcm"]["package"] == "lidar_sig"


def test_sample_json_lists_its_files(tmp_path):
    out = _json("sample", tmp_path / "demo")
    assert [f["points"] for f in out["files"]] == [41_507, 31_354, 31_354] and all(f["written"] for f in out["files"])
