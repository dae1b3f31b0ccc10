"""The three faces of one change map side by side, for the docs (docs/changes.md, "Colours"):
QGIS's picture of the map and its cells, the notebook card and the report's map, each as headless
Chromium or QGIS draws it, of the two IGN tiles and their edited copy in 10 m cells (the map of
tests/test_qgis.py and tests/test_change_colours.py).

    LIDAR_SIG_SCREENSHOTS=shots python3 -m pytest tests/test_qgis.py -k loads_the_map   # QGIS's picture
    python3 tests/faces.py shots/qgis_change_map.png docs/figures/change_map_faces.png

Needs the IGN data beside the project, Chromium with its driver and selenium (tests/browser.py).
"""
from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from browser import Browser  # noqa: E402
from conftest import IGN, ROOT  # noqa: E402

TILES = ("test_data_77055_627755_LA93_IGN69.laz", "test_data_77060_627755_LA93_IGN69.laz")
#: Scale of each panel in the combined picture (QGIS's picture is drawn at 150 dpi), and the gap
#: between panels (px).
SCALES, GAP = (0.55, 1.0, 0.85), 24


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
    os.chdir(folder)  # the card names the files as given: epoch1.laz -> epoch2.laz
    return changes("epoch1.laz", "epoch2.laz", cell=10)


def shots(cm, folder):
    """(the notebook card, the report's map figure) as Chromium draws them, each cropped to its
    element."""
    from selenium.webdriver.common.by import By

    card = folder / "card.html"
    card.write_text("<!DOCTYPE html><html><body style='margin:8px;background:#fff'>"
                    f"{cm._repr_html_()}</body></html>", encoding="utf-8")
    report = folder / "report.html"
    cm.report().save(report)
    with Browser(760, 1400) as browser:
        browser.open(card)
        card_png = folder / "card.png"
        browser.driver.find_element(By.CSS_SELECTOR, ".lidar-sig-card").screenshot(str(card_png))
    with Browser(1000, 1600) as browser:
        browser.open(report)
        report_png = folder / "report.png"
        figure = browser.driver.execute_script("return document.querySelector('img[alt=\"change map\"]').closest('figure')")
        figure.screenshot(str(report_png))
    return card_png, report_png


def _read(path):
    import cv2

    return cv2.imread(str(path))


def _panel(image, title, scale):
    """``image`` scaled by ``scale``, a title above it."""
    import cv2

    scaled = cv2.resize(image, (round(image.shape[1] * scale), round(image.shape[0] * scale)),
                        interpolation=cv2.INTER_AREA)
    head = np.full((34, scaled.shape[1], 3), 255, np.uint8)
    cv2.putText(head, title, (6, 24), cv2.FONT_HERSHEY_SIMPLEX, 0.65, (20, 20, 20), 1, cv2.LINE_AA)
    return np.vstack([head, scaled])


def main(argv):
    import cv2

    if len(argv) != 2:
        sys.exit(__doc__)
    qgis, out = Path(argv[0]), Path(argv[1])
    qgis, out = qgis.resolve(), out.resolve()
    here = Path.cwd()
    with tempfile.TemporaryDirectory() as tmp:
        card, report = shots(change_map(Path(tmp)), Path(tmp))
        titles = ("QGIS 3.22: the GeoTIFF and the cells in their styles", "JupyterLab: the ChangeMap card",
                  "the HTML report's map")
        panels = [_panel(_read(path), title, scale) for path, title, scale in zip((qgis, card, report), titles, SCALES)]
        os.chdir(here)
    height = max(p.shape[0] for p in panels)
    panels = [np.vstack([p, np.full((height - p.shape[0], p.shape[1], 3), 255, np.uint8)]) for p in panels]
    gap = np.full((height, GAP, 3), 255, np.uint8)
    joined = np.hstack([p if k == 0 else np.hstack([gap, p]) for k, p in enumerate(panels)])
    cv2.imwrite(str(out), joined, [cv2.IMWRITE_PNG_COMPRESSION, 9])
    print(f"wrote {out} ({out.stat().st_size / 1e3:.0f} kB)")


if __name__ == "__main__":
    main(sys.argv[1:])
