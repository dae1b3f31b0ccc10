"""The three faces of one change map side by side, for the docs (docs/changes.md, "Colours"):
QGIS's picture of the map and its cells, the notebook card and the report's map, each as headless
Chromium or QGIS draws it, of the two IGN tiles and their edited copy in 10 m cells (the map of
tests/test_qgis.py and tests/test_change_colours.py).

    LIDAR_SIG_SCREENSHOTS=shots python3 -m pytest tests/test_qgis.py -k loads_the_map   # QGIS's picture
    python3 tests/faces.py shots/qgis_change_map.png docs/figures/change_map_faces.png

Needs the IGN data beside the project, Chromium with its driver and selenium (tests/browser.py).
"""
from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from browser import Browser  # noqa: E402
from conftest import IGN, ROOT  # noqa: E402

TILES = ("test_data_77055_627755_LA93_IGN69.laz", "test_data_77060_627755_LA93_IGN69.laz")
#: Height of each panel in the combined picture (px), and the gap between panels.
HEIGHT, GAP = 620, 16


def change_map(folder):
    """The two IGN tiles against their edited copy (benchmarks/edited_epoch.py), 10 m cells,
    written as LAZ and read back as tests/test_qgis.py gives them to QGIS."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    from edited_epoch import edit, write_las

    from lidar_sig.change_map import changes, read_epoch

    one = read_epoch([IGN / name for name in TILES])
    two, _ = edit(one)
    write_las(one, folder / "epoch1.laz")
    write_las(two, folder / "epoch2.laz")
    return changes(folder / "epoch1.laz", folder / "epoch2.laz", cell=10)


def shots(cm, folder):
    """(the notebook card's picture, the report's map section) as Chromium draws them."""
    card = folder / "card.html"
    card.write_text("<!DOCTYPE html><html><body style='margin:8px;background:#fff'>"
                    f"{cm._repr_html_()}</body></html>", encoding="utf-8")
    report = folder / "report.html"
    cm.report().save(report)
    with Browser(900, 900) as browser:
        browser.open(card)
        height = browser.driver.execute_script(
            "return document.querySelector('.lidar-sig-card').getBoundingClientRect().bottom + 8")
        card_png = browser.screenshot(folder / "card.png", max_height=int(height))
    with Browser(1000, 900) as browser:
        browser.open(report)
        top = browser.driver.execute_script(
            "const f = document.querySelector('img[alt=\"change map\"]').closest('section');"
            "f.scrollIntoView(); return window.scrollY;")
        browser.driver.execute_script("document.body.style.marginTop = '-' + arguments[0] + 'px'", top)
        report_png = browser.screenshot(folder / "report.png", max_height=1150)
    return card_png, report_png


def _read(path):
    import cv2

    return cv2.imread(str(path))


def _panel(image, title):
    """``image`` scaled to :data:`HEIGHT` px tall, a title above it."""
    import cv2

    scale = HEIGHT / image.shape[0]
    scaled = cv2.resize(image, (max(1, round(image.shape[1] * scale)), HEIGHT), interpolation=cv2.INTER_AREA)
    head = np.full((34, scaled.shape[1], 3), 255, np.uint8)
    cv2.putText(head, title, (6, 24), cv2.FONT_HERSHEY_SIMPLEX, 0.65, (20, 20, 20), 1, cv2.LINE_AA)
    return np.vstack([head, scaled])


def main(argv):
    import cv2

    if len(argv) != 2:
        sys.exit(__doc__)
    qgis, out = Path(argv[0]), Path(argv[1])
    with tempfile.TemporaryDirectory() as tmp:
        card, report = shots(change_map(Path(tmp)), Path(tmp))
        panels = [_panel(_read(qgis), "QGIS 3.22: the GeoTIFF and the cells in their styles"),
                  _panel(_read(card), "JupyterLab: the ChangeMap card"),
                  _panel(_read(report), "the HTML report's map")]
    gap = np.full((panels[0].shape[0], GAP, 3), 255, np.uint8)
    joined = np.hstack([p if k == 0 else np.hstack([gap, p]) for k, p in enumerate(panels)])
    cv2.imwrite(str(out), joined, [cv2.IMWRITE_PNG_COMPRESSION, 9])
    print(f"wrote {out} ({out.stat().st_size / 1e3:.0f} kB)")


if __name__ == "__main__":
    main(sys.argv[1:])
