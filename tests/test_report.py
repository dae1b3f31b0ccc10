"""The HTML report: one self-contained file from `lidar-sig compare --report` and
`lidar-sig signature --report`, its figures with --plots, what it shows on the README's demo,
and how it opens in a real browser (headless Chromium)."""
import base64
import os
import re
from pathlib import Path

import laspy
import numpy as np
import pytest

import lidar_sig as ls
from browser import Browser, missing
from command_line import run
from conftest import SAMPLES
from lidar_sig.metrics import METRICS
from lidar_sig.reporting import COMPARISON_PLOTS, SIGNATURE_PLOTS

EPOCH1, EPOCH2 = SAMPLES / "epoch1.laz", SAMPLES / "epoch2.laz"


@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    """The README's demo run with --report and --plots: (folder, completed process)."""
    folder = tmp_path_factory.mktemp("demo")
    done = run("compare", EPOCH1, EPOCH2, "--report", "report.html", "--plots", "plots", cwd=folder)
    assert done.returncode == 0, done.stderr
    return folder, done


def embedded_pngs(html):
    return [base64.b64decode(m) for m in re.findall(r'src="data:image/png;base64,([A-Za-z0-9+/=]+)"', html)]


def decode(png):
    import cv2

    return cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_COLOR)[..., ::-1]  # RGB


def test_compare_report_is_one_self_contained_file_with_every_figure(demo):
    folder, done = demo
    html = (folder / "report.html").read_text(encoding="utf-8")
    assert "wrote report.html" in done.stdout and "wrote 10 plots in plots" in done.stdout
    # nothing fetched from anywhere: every picture embedded, no script, no link to a resource
    assert not re.search(r'(src|href)="(?!data:|#)', html)
    assert "<script" not in html.lower()
    pngs = embedded_pngs(html)
    assert sorted(p.name for p in (folder / "plots").iterdir()) == sorted(COMPARISON_PLOTS)
    assert len(pngs) == len(COMPARISON_PLOTS)
    # the page embeds exactly the plots written beside it
    assert sorted(pngs) == sorted((folder / "plots" / name).read_bytes() for name in COMPARISON_PLOTS)
    for png in pngs:
        assert decode(png).shape[0] > 100
    for title in ("Warnings", "Metrics", "Signatures", "Difference of the signatures", "Class composition",
                  "Geometric entropy Egeom", "Saliency per class", "Top views", "Parameters and provenance"):
        assert f"<h2>{title}</h2>" in html
    assert "@media print" in html


def test_report_provenance_names_the_files_their_checksums_and_the_method(demo):
    import hashlib

    html = (demo[0] / "report.html").read_text(encoding="utf-8")
    for path in (EPOCH1, EPOCH2):
        assert hashlib.sha256(path.read_bytes()).hexdigest() in html
        assert f"{path.stat().st_size:,} bytes" in html
        n = laspy.read(path).header.point_count
        assert f"{n:,}" in html
    assert "RGF93 / Lambert-93" in html  # the CRS of the sample files, by name
    assert "k 20, 30, 40" in html and "c3dcm" in html and "multiscale" in html and "smooth" in html
    assert f"lidar_sig {ls.__version__}" in html


def _class_shares(path):
    codes = np.asarray(laspy.read(path).classification)
    return {c: np.mean(codes == c) for c in (5, 6)}  # ASPRS high vegetation, building


def test_demo_report_shows_the_removed_trees_and_the_new_building(demo):
    """The README's epochs: epoch 2 lost a third of its trees and gained a building
    (lidar_sig/data/_scene.py). The class composition and the difference image show it."""
    folder, _ = demo
    html = (folder / "report.html").read_text(encoding="utf-8")
    a, b = _class_shares(EPOCH1), _class_shares(EPOCH2)
    assert b[5] < a[5] - 0.05 and b[6] > a[6] + 0.01  # what the files hold
    for name, code in (("high vegetation", 5), ("building", 6)):
        row = re.search(rf"<tr><td>{name}</td>(.*?)</tr>", html).group(1)
        shares = [float(v) for v in re.findall(r">([0-9.]+)%<", row)]
        assert shares == [round(a[code] * 100, 1), round(b[code] * 100, 1)]
    # the difference image: where epoch 1's vegetation lies in the triangle it is blue (A had the
    # larger share), where its buildings lie it is red
    c = ls.Pipeline().run(str(EPOCH1)).signature
    diff = decode((folder / "plots" / "difference.png").read_bytes()).astype(int)[:c.frame.size]
    veg, building = (c.counts[c.classes.index([code])[0]] for code in (5, 6))
    for counts, more in ((veg, "blue"), (building, "red")):
        mostly = counts > 0.8 * c.total.clip(1) * (c.total > 20)
        r, _, bl = diff[mostly].mean(axis=0)
        assert (bl > r + 10) if more == "blue" else (r > bl + 10)


def test_report_outputs_are_checked_before_anything_is_computed(tmp_path):
    (tmp_path / "report.html").write_text("mine")
    # a missing input would fail only later: the existing report is refused first
    done = run("compare", tmp_path / "missing.laz", EPOCH2, "--report", tmp_path / "report.html")
    assert done.returncode == 2
    assert done.stderr.strip().count("\n") == 0 and "report.html" in done.stderr and "--overwrite" in done.stderr
    assert (tmp_path / "report.html").read_text() == "mine"
    for bad, says in (("report.pdf", ".html"), ("no/report.html", "does not exist")):
        done = run("compare", EPOCH1, EPOCH2, "--report", tmp_path / bad)
        assert done.returncode == 2 and says in done.stderr and "Traceback" not in done.stderr
    (tmp_path / "plots").mkdir()
    (tmp_path / "plots" / "egeom.png").write_bytes(b"mine")
    done = run("compare", tmp_path / "missing.laz", EPOCH2, "--plots", tmp_path / "plots")
    assert done.returncode == 2 and "egeom.png" in done.stderr and "--overwrite" in done.stderr
    assert (tmp_path / "plots" / "egeom.png").read_bytes() == b"mine"
    assert sorted(os.listdir(tmp_path)) == ["plots", "report.html"]  # nothing half-written


def test_report_in_a_read_only_folder_is_refused_before_computing(tmp_path):
    if os.geteuid() == 0:
        pytest.skip("root writes in read-only folders")
    folder = tmp_path / "ro"
    folder.mkdir()
    folder.chmod(0o555)
    done = run("compare", tmp_path / "missing.laz", EPOCH2, "--report", folder / "r.html")
    folder.chmod(0o755)
    assert done.returncode == 2 and "permission denied" in done.stderr


def test_overwrite_replaces_report_and_plots(tmp_path):
    (tmp_path / "r.html").write_text("old")
    (tmp_path / "plots").mkdir()
    (tmp_path / "plots" / "egeom.png").write_bytes(b"old")
    done = run("signature", EPOCH2, "--report", tmp_path / "r.html", "--plots", tmp_path / "plots", "--overwrite")
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "r.html").read_text(encoding="utf-8").startswith("<!DOCTYPE html>")
    assert sorted(p.name for p in (tmp_path / "plots").iterdir()) == sorted(SIGNATURE_PLOTS)
    assert decode((tmp_path / "plots" / "egeom.png").read_bytes()) is not None


def test_signature_report_shows_one_cloud_without_metrics(tmp_path):
    done = run("signature", EPOCH1, "-o", tmp_path / "e1.h5", "--report", tmp_path / "sig.html")
    assert done.returncode == 0, done.stderr
    html = (tmp_path / "sig.html").read_text(encoding="utf-8")
    assert "<h2>Metrics</h2>" not in html and "<h2>Top view</h2>" in html
    assert len(embedded_pngs(html)) == len(SIGNATURE_PLOTS)
    # the caption of the one curve of Egeom speaks of one curve
    assert "this curve" in html and "two curves" not in html and "one curve per cloud" not in html
    assert (tmp_path / "e1.h5").exists()


def test_archive_report_says_it_has_no_top_view(tmp_path):
    assert run("signature", EPOCH2, "-o", tmp_path / "e2.h5").returncode == 0
    report = ls.report(str(EPOCH1), str(tmp_path / "e2.h5"))
    assert "top_view_a.png" in report.figures and "top_view_b.png" not in report.figures
    assert "is a signature archive" in report.body and "no top view" in report.body
    # the archive records the cloud it was made from, with its checksum
    import hashlib

    assert hashlib.sha256(EPOCH2.read_bytes()).hexdigest() in report.body


def test_a_notebook_shows_a_report_as_a_compact_card_and_the_full_page_on_demand(tmp_path, monkeypatch):
    result = ls.Pipeline().run(str(EPOCH2))
    report = ls.report(result)
    shown = report._repr_html_()
    # a card of the title, the sections and a small picture: not the page's megabyte
    assert shown.startswith('<div class="lidar-sig-card"') and "<html" not in shown
    assert len(shown) < 80_000 and len(shown) * 3 < len(report.body), (len(shown), len(report.body))
    assert "Geometric entropy Egeom" in shown and "report.show()" in shown and "<a href" not in shown
    full = report.show()._repr_html_()  # on demand, in place, without a page around it
    assert full.startswith('<div class="lidar-sig-report">') and full in report.html()
    assert report.html().startswith("<!DOCTYPE html>")
    assert report.title == "lidar_sig signature: epoch2.laz"
    monkeypatch.chdir(tmp_path)
    report.save("saved.html")  # once saved, the card links to the page (beside the notebook)
    assert '<a href="saved.html" target="_blank">' in report._repr_html_()


def test_report_of_a_comparison_lists_every_metric_with_its_value():
    from lidar_sig.comparison import compare_sources

    comparison = compare_sources(str(EPOCH1), str(EPOCH2))
    body = comparison.report().body
    for m in METRICS:
        value = comparison.metrics[m.key]
        assert re.search(rf"<b>{re.escape(m.name)}</b></td><td class=\"num\">{value:.4f}</td>", body)


# -- in a real browser ------------------------------------------------------------------------

def test_report_opens_in_headless_chromium_with_every_image_and_metric(demo, tmp_path):
    why = missing()
    if why:
        pytest.skip(f"no headless browser: {why}")
    folder, _ = demo
    with Browser(width=1280) as browser:
        browser.open(folder / "report.html")
        images = browser.images()
        rows = browser.table("table.metrics")
        console = browser.console()
        shot = browser.screenshot(tmp_path / "report.png")
        if os.environ.get("LIDAR_SIG_SCREENSHOTS"):  # keep the artefact where CI or a person looks
            target = Path(os.environ["LIDAR_SIG_SCREENSHOTS"])
            target.mkdir(parents=True, exist_ok=True)
            browser.screenshot(target / "report_demo.png")
    assert len(images) == len(COMPARISON_PLOTS)
    assert all(width > 0 and height > 0 for _, width, height in images), images
    assert [r[0] for r in rows] == [m.name for m in METRICS]
    for row in rows:
        float(row[1])  # every metric has a value (the demo's clouds are both labelled)
    assert [c for c in console if c[0] in ("SEVERE", "ERROR", "WARNING")] == []
    picture = decode(shot.read_bytes())
    assert picture.shape[1] == 1280 and picture.shape[0] > 3000  # the whole page, not one screen


def test_the_top_view_draws_the_points_the_run_used(tmp_path):
    # withheld and noise points (high noise far above the roofs) were drawn grey over the scene
    from conftest import noisy_las
    from lidar_sig.comparison import side_of
    from lidar_sig.reporting.sections import top_view

    scene = noisy_las(tmp_path / "noisy.laz")
    cloud = ls.read(tmp_path / "noisy.laz")
    clean = ls.PointCloud(cloud.xyz[scene], cloud.labels[scene], crs=cloud.crs)
    pipe = ls.Pipeline(progress=False)
    # the same points with the same saliency, drawn by the same code: equal bytes on any CPU
    assert top_view(side_of(pipe.run(cloud))) == top_view(side_of(pipe.run(clean)))
    kept = ls.Pipeline(progress=False, keep_noise=True)
    assert top_view(side_of(kept.run(cloud))) != top_view(side_of(kept.run(clean)))
