"""Answers with a scale (issue 32): compare places each metric against the reference values the
project measured (docs/comparison.md), outliers flag the tiles above a documented threshold and
say when none stands out, the catalogue names tiles that copy one another (a tile and its COPC
copy), and similar leaves the query tile out of its answer."""
import json
import math
import re
import shutil

import numpy as np

import pytest

from command_line import run
from conftest import DATA, ROOT, SAMPLES, need_data
from lidar_sig.metrics import METRICS, REFERENCE_CASES

COPC = DATA / "copc" / "test_data_77050_627755.copc.laz"
TILE = DATA / "ign_lidarhd_montpellier" / "test_data_77050_627755_LA93_IGN69.laz"
OTHER = DATA / "ign_lidarhd_montpellier" / "test_data_77055_627755_LA93_IGN69.laz"
CASES = {"80%": "resampled", "60%": "resampled", "adjacent": "adjacent", "other city": "another_place"}


def docs_references():
    """{metric key: {case: (lowest, highest)}} read from docs/comparison.md's table "Defaults,
    figure by figure" (the 7 references; the tile printed apart left out)."""
    text = (ROOT / "docs" / "comparison.md").read_text(encoding="utf-8")
    table = text.split("**Defaults, figure by figure**", 1)[1].split("\n\n", 2)[1]
    values = {m.key: {} for m in METRICS}
    for line in table.splitlines()[2:]:
        cells = [c.strip() for c in line.strip("|").split("|")]
        if cells[0].startswith("*apart:*"):
            break
        case = CASES[cells[0].split(":")[-1].strip()]
        for m, cell in zip(METRICS, cells[1:]):
            values[m.key].setdefault(case, []).append(float(cell))
    return {k: {case: (min(v), max(v)) for case, v in cases.items()} for k, cases in values.items()}


def test_each_metric_carries_the_reference_ranges_the_docs_measured():
    measured = docs_references()
    for m in METRICS:
        assert set(m.references) == {"resampled", "adjacent", "another_place"} <= set(REFERENCE_CASES)
        for case, (low, high) in measured[m.key].items():
            assert m.references[case] == pytest.approx((low, high), abs=1e-12), (m.key, case)


def test_a_value_is_placed_with_its_nearest_reference_case():
    bd = next(m for m in METRICS if m.key == "bhattacharyya")
    assert bd.place(0.0)[0] == "rotated"
    assert bd.place(0.05)[0] == "resampled" and bd.place(0.3)[0] == "adjacent"
    assert bd.place(0.7)[0] == "another_place" and bd.place(0.95)[0] == "beyond"
    # the split: the geometric mean of the highest resampled value and the lowest adjacent one
    split = (0.1967 * 0.2187) ** 0.5
    assert bd.place(split * 0.999)[0] == "resampled" and bd.place(split * 1.001)[0] == "adjacent"
    assert bd.place(0.3)[1] == "like the adjacent tile of the same survey (0.2187-0.5872)"
    ssim = next(m for m in METRICS if m.key == "ssim")  # smaller means more different
    assert [ssim.place(v)[0] for v in (1.0, 0.95, 0.9, 0.8, 0.5)] == ["rotated", "resampled", "adjacent",
                                                                     "another_place", "beyond"]


def test_the_range_quoted_holds_the_value_or_the_sentence_says_below_or_above():
    kl = next(m for m in METRICS if m.key == "kl")
    low, high = kl.references["adjacent"]
    below = low * 0.85  # placed with the adjacent tile (nearer it than the resampled land), under its range
    assert kl.place(below) == ("adjacent", f"like the adjacent tile of the same survey (below {low:.4f}-{high:.4f})")
    inside = (low + high) / 2
    assert kl.place(inside)[1] == f"like the adjacent tile of the same survey ({low:.4f}-{high:.4f})"
    ssim = next(m for m in METRICS if m.key == "ssim")  # a similarity: its raw value above the range
    lo, hi = sorted(ssim.references["resampled"])
    assert ssim.place(min(hi + 0.005, 0.9999))[1].endswith(f"(above {ssim.shown_range('resampled')})")
    for m in METRICS:  # every sentence true to its value
        for case, (a, b) in m.references.items():
            for value in (min(a, b) * 0.9, (a + b) / 2, max(a, b) * 1.05):
                says = m.place(value)[1]
                if m.shown_range(case) in says and "beyond" not in says:
                    held = min(a, b) <= value <= max(a, b)
                    assert held == ("below" not in says and "above" not in says), (m.key, value, says)



def placed(metric, value):
    """The case a value is placed in, by the rule docs/comparison.md states: as a distance from
    "same", within 5e-5 of it the same land rotated; else the first case below the geometric
    mean of its highest value and the next case's lowest; above the last case's highest, beyond."""
    def distance(x):
        return abs(x - metric.same)

    d = distance(value)
    if d < 5e-5:
        return "rotated"
    cases = ["resampled", "adjacent", "another_place"]
    spans = [sorted(distance(x) for x in metric.references[c]) for c in cases]
    for k in range(2):
        if d < math.sqrt(spans[k][1] * spans[k + 1][0]):
            return cases[k]
    return "beyond" if d > spans[2][1] else "another_place"


def test_compare_s_json_and_report_place_every_metric(tmp_path):
    done = run("compare", SAMPLES / "epoch1.laz", SAMPLES / "epoch2.laz", "--json", "--report", tmp_path / "r.html")
    assert done.returncode == 0, done.stderr
    info = json.loads(done.stdout)
    assert set(info["scale"]) == {m.key for m in METRICS}
    html = (tmp_path / "r.html").read_text()
    for m in METRICS:
        entry = info["scale"][m.key]
        like = placed(m, info[m.key])
        assert (entry["name"], entry["like"]) == (m.name, like)
        if like in m.references:  # the phrase quotes the case's range, and says where a value outside it lies
            low, high = m.references[like]
            side = "below " if info[m.key] < min(low, high) else "above " if info[m.key] > max(low, high) else ""
            assert f"({side}{low:.4f}-{high:.4f})" in entry["says"], entry["says"]
        assert entry["resampled"] == list(m.references["resampled"]) and entry["rotated"] == m.same
        assert entry["says"] in html
    assert "on the project&#x27;s scale" in html or "on the project's scale" in html


# -- outliers: a threshold, and a verdict when nothing stands out -------------------------------

def test_outliers_say_no_tile_stands_out_on_the_ign_block(tmp_path):
    folder = need_data(DATA / "ign_lidarhd_montpellier")
    cat = tmp_path / "ign.h5"
    assert run("catalog", folder, "-o", cat, "--workers", "1", "-q").returncode == 0
    done = run("outliers", cat, "--report", tmp_path / "qc.html")
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    verdict = [line for line in lines if line.startswith("no tile stands out: no score reaches 3.5, the mark of an")]
    assert len(verdict) == 1 and "with 6 tiles the scores rest on few distances and are indicative" in verdict[0]
    assert not any(re.match(r"^ +\d+\*", line) for line in lines)
    html = (tmp_path / "qc.html").read_text()
    assert "No tile stands out" in html and "Highest scores beside their neighbours (no tile stands out)" in html
    assert "Top outliers" not in html
    info = json.loads(run("outliers", cat, "--json").stdout)
    assert info["threshold"] == 3.5 and info["standing_out"] == 0
    assert not any(r["outlier"] for r in info["results"]) and max(r["score"] for r in info["results"]) < 3.5


def test_outliers_mark_the_tiles_that_reach_the_threshold(tmp_path):
    cat = tmp_path / "samples.h5"
    assert run("catalog", SAMPLES, "-o", cat, "--workers", "1", "-q").returncode == 0
    done = run("outliers", cat)
    lines = done.stdout.splitlines()
    assert re.match(r"^ +1\* +234\.\d\d .*epoch1\.laz", lines[2]), lines
    assert lines[-1] == ("1 tile stands out (score 3.5 or more, the mark of an outlier): epoch1.laz, marked *; with 3 "
                         "tiles the scores rest on few distances and are indicative (9 or more give them their meaning)")


def test_the_verdict_on_nine_tiles_or_more_states_the_scores_without_reserve():
    from lidar_sig.survey_catalog._outlier_scores import FEW_TILES, Outliers

    def verdict(n, standing_out):
        results = [{"name": f"t{i}", "outlier": i < standing_out} for i in range(n)]
        return Outliers(None, results, np.zeros((n, n)), [[]] * n, 10.0, ()).verdict()

    assert FEW_TILES == 9
    assert "indicative" in verdict(8, 0) and "indicative" in verdict(8, 1)
    assert verdict(9, 0) == "no tile stands out: no score reaches 3.5, the mark of an outlier"
    assert verdict(9, 1) == "1 tile stands out (score 3.5 or more, the mark of an outlier): t0"


# -- copies in a catalogue, and similar's answer ------------------------------------------------

@pytest.fixture(scope="module")
def with_copies(tmp_path_factory):
    """A catalogue of an IGN tile, its COPC copy, the same tile copied under another name and a
    second tile."""
    need_data(COPC)
    folder = tmp_path_factory.mktemp("copies")
    for path in (TILE, COPC, OTHER):
        shutil.copy(path, folder / path.name)
    shutil.copy(TILE, folder / "same_file.laz")
    done = run("catalog", folder, "-o", folder / "cat.h5", "--workers", "1")
    assert done.returncode == 0, done.stderr
    return folder, done


def test_the_catalogue_names_a_tile_its_copc_copy_and_an_identical_file(with_copies):
    folder, done = with_copies
    notes = [line for line in done.stderr.splitlines() if line.startswith("lidar-sig: note: ")]
    assert len(notes) == 2, done.stderr
    assert any("same_file.laz and test_data_77050_627755_LA93_IGN69.laz are identical files" in n for n in notes)
    copc = next(n for n in notes if "hold the same points" in n)
    assert "test_data_77050_627755.copc.laz" in copc and "COPC" in copc and "--overwrite" in copc
    assert "test_data_77055_627755_LA93_IGN69.laz" not in " ".join(notes)  # another tile is no copy
    report = run("outliers", folder / "cat.h5", "--json")
    assert sum("hold the same points" in n for n in json.loads(report.stdout)["notes"]) == 1


def test_similar_leaves_the_query_out_and_finds_its_copies_first(with_copies):
    folder, _ = with_copies
    done = run("similar", TILE.name, folder / "cat.h5", "--json")
    assert done.returncode == 0, done.stderr
    info = json.loads(done.stdout)
    names = [r["name"] for r in info["results"]]
    assert TILE.name not in names and len(names) == 3
    assert set(names[:2]) == {"same_file.laz", COPC.name}
    assert all(r["distance"] == pytest.approx(0.0, abs=1e-12) for r in info["results"][:2])
    assert info["shortlist"]["tiles"] == 3 and info["shortlist"]["query_left_out"]
    text = run("similar", TILE.name, folder / "cat.h5").stdout.splitlines()
    assert "a tile of the catalogue, left out of the list" in text[0] and "every other tile" in text[0]


def test_similar_refuses_a_catalogue_of_the_query_alone(tmp_path):
    one = tmp_path / "one"
    one.mkdir()
    shutil.copy(SAMPLES / "epoch1.laz", one / "epoch1.laz")
    assert run("catalog", one, "-o", tmp_path / "one.h5", "--workers", "1", "-q").returncode == 0
    done = run("similar", "epoch1.laz", tmp_path / "one.h5")
    assert done.returncode == 2 and len(done.stderr.splitlines()) == 1
    assert "one.h5" in done.stderr and "no tile but the query epoch1.laz" in done.stderr
