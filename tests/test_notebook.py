"""At home in a notebook: every object of lidar_sig that the README's and docs/python.md's
examples make prints in one line or a few (its repr), and the objects with more to show draw an
HTML card (``_repr_html_``) that a browser renders: a signature's image, a comparison's metric
table, a change map's thumbnail and counts, a catalogue's summary."""
import ast
import contextlib
import io
import os
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

from browser import Browser, missing
from conftest import DATA, IGN, ROOT, SAMPLES, need_data
from test_docs import blocks

#: Longest repr of a public object, in characters.
REPR_MAX = 300


def _ours(value):
    return type(value).__module__.startswith("lidar_sig")


def _shown(value):
    """Whether ``value`` is something of the package a user meets: one of its objects, or a list,
    tuple or dict one of its calls returned (numpy arrays print as numpy prints them)."""
    return (_ours(value) and not isinstance(value, type) and not callable(value)) or isinstance(value, (list, tuple))


def _made_by_examples(page, folder, monkeypatch):
    """Every lidar_sig object the Python examples of ``page`` make, run in ``folder``: the names
    they bind, what each call of the package they make returns, the attributes of its objects
    they read, and the items of its mappings (``cm.levels["kl"]``)."""
    monkeypatch.chdir(folder)
    found = {}
    where = str(page)

    def returned(frame, event, value):  # a call of the package made by the example's own code
        if event == "return" and frame.f_back is not None and frame.f_back.f_code.co_filename == where \
                and frame.f_globals.get("__name__", "").startswith("lidar_sig") and _shown(value) \
                and not frame.f_code.co_name.startswith("_"):
            found.setdefault(f"{page.name}: {frame.f_code.co_qualname}() ({type(value).__name__})", value)

    for kind, text in blocks(page):
        if kind != "python" or "import open3d" in text:  # Open3D's objects are not ours
            continue
        namespace = {"__name__": "__main__"}
        sys.setprofile(returned)
        try:
            with contextlib.redirect_stdout(io.StringIO()):
                exec(compile(text, where, "exec"), namespace)
        finally:
            sys.setprofile(None)
        for name, value in namespace.items():
            for v in (value if isinstance(value, (list, tuple)) else [value]):
                if _ours(v) and not isinstance(v, type) and not callable(v):
                    found.setdefault(f"{page.name}: {name} ({type(v).__name__})", v)
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) \
                    and _ours(namespace.get(node.value.id)):
                value = getattr(namespace[node.value.id], node.attr, None)
                if _ours(value) and not callable(value):
                    found.setdefault(f"{page.name}: {node.value.id}.{node.attr} ({type(value).__name__})", value)
    for name, value in list(found.items()):
        if _ours(value) and isinstance(value, dict):
            for key, item in value.items():
                if _ours(item):
                    found.setdefault(f"{name}[{key!r}] ({type(item).__name__})", item)
    return found


#: Pages whose Python examples make the objects checked (all but Open3D's, viewing.md).
PAGES = [ROOT / "README.md", *(p for p in sorted((ROOT / "docs").rglob("*.md"))
                               if any(kind == "python" and "import open3d" not in text for kind, text in blocks(p)))]


@pytest.fixture(scope="module")
def example_objects(tmp_path_factory):
    folder = tmp_path_factory.mktemp("examples") / "project"
    folder.mkdir()
    (folder / "data_samples").symlink_to(SAMPLES)
    if DATA.exists():
        (folder.parent / "shared").symlink_to(DATA.parent)
    with pytest.MonkeyPatch.context() as patch:
        found = {}
        for page in PAGES:
            if "../shared/data" in page.read_text() and not DATA.exists():
                continue  # tests/test_docs.py says why it skips them
            found.update(_made_by_examples(page, folder, patch))
    return found


def test_the_examples_make_the_objects_a_user_meets(example_objects):
    kinds = {type(v).__name__ for v in example_objects.values()}
    assert {"PointCloud", "Pipeline", "Result", "Saliency", "Signature", "ChangeMap", "Report", "Comparison"} <= kinds


def test_every_object_the_examples_make_prints_in_a_few_lines(example_objects):
    # what the README's, python.md's, changes' and catalog.md's examples call
    for made in ("ChangeMap.top() (TopCells)", "cm.levels (Levels)", "cm.levels (Levels)['kl'] (Level)",
                 "Report.save_plots() (Files)", "report.figures (Figures)", "Catalog.distances() (Distances)"):
        assert any(name.endswith(made) for name in example_objects), (made, sorted(example_objects))
    long = {name: len(repr(v)) for name, v in example_objects.items() if len(repr(v)) > REPR_MAX}
    assert not long, long
    assert all("\n" not in repr(v) for v in example_objects.values()), \
        [n for n, v in example_objects.items() if "\n" in repr(v)]
    assert all("object at 0x" not in repr(v) for v in example_objects.values()), \
        [n for n, v in example_objects.items() if "object at 0x" in repr(v)]


def test_the_public_objects_with_more_to_show_draw_a_card_a_browser_renders(tmp_path):
    import lidar_sig as ls

    a = ls.Pipeline(progress=False).run(SAMPLES / "epoch1.laz")
    b = ls.Pipeline(progress=False).run(SAMPLES / "epoch2.laz")
    cm = ls.changes(SAMPLES / "epoch1.laz", SAMPLES / "epoch2_aligned.laz", cell=16,
                    pipeline=ls.Pipeline(progress=False))
    views = {"signature": a.signature, "comparison": ls.compare(a, b), "change map": cm}
    views.update({"levels": cm.levels, "top cells": cm.top(3),
                  "series": ls.changes(SAMPLES / "epoch1.laz", SAMPLES / "epoch2_aligned.laz", SAMPLES / "epoch1.laz",
                                       cell=16, pipeline=ls.Pipeline(progress=False))})
    if IGN.exists():
        cat = ls.Catalog.build([need_data(IGN)], tmp_path / "ign.h5")
        views.update({"catalogue": cat, "similar": cat.similar(cat.names[0], top=3), "outliers": cat.outliers(),
                      "distances": cat.distances()})
    page = tmp_path / "cards.html"
    page.write_text("<!DOCTYPE html><html><body>" + "".join(f"<h3>{k}</h3>{v._repr_html_()}" for k, v in views.items())
                    + "</body></html>")
    for name, view in views.items():
        html = view._repr_html_()
        assert html.startswith("<") and len(html) < 400_000, name
    assert 'src="data:image/png;base64,' in views["signature"]._repr_html_()
    assert "d_BD-Img" in views["comparison"]._repr_html_() and "reacts" in views["comparison"]._repr_html_()
    assert "significant" in views["change map"]._repr_html_()
    assert "kl" in views["levels"]._repr_html_() and "beta" in views["levels"]._repr_html_()
    series = views["series"]._repr_html_()
    assert "3 epochs, 2 intervals" in series and "changed most" in series and series.count("<img") == 3
    if "outliers" in views:
        qc, d = views["outliers"], views["distances"]
        assert qc.verdict() in qc._repr_html_() and qc.short_verdict() in repr(qc)
        assert all(f"{v:.3f}" in d._repr_html_() for v in d.values[0]) and "<img" in d._repr_html_()
        assert views["similar"].results[0]["name"] in views["similar"]._repr_html_()
    why = missing()
    if why:
        pytest.skip(f"no headless browser to render the cards ({why})")
    with Browser() as browser:
        browser.open(page)
        images = browser.images()
        assert len(images) >= 5 and all(width > 0 for _, width, _ in images), images
        shot = browser.screenshot(tmp_path / "notebook_cards.png")
    assert shot.stat().st_size > 10_000
    if os.environ.get("LIDAR_SIG_SCREENSHOTS"):  # keep the artefact where CI or a person looks
        target = Path(os.environ["LIDAR_SIG_SCREENSHOTS"])
        target.mkdir(parents=True, exist_ok=True)
        shutil.copy(shot, target / shot.name)


def test_a_signature_card_shows_its_classes():
    import lidar_sig as ls

    xyz = np.random.default_rng(0).uniform(0, 20, (400, 3)) * [1, 1, 0.05]
    sig = ls.Pipeline(progress=False).run(xyz, labels=np.repeat([2, 6], 200)).signature
    html = sig._repr_html_()
    assert "ground" in html and "building" in html and len(repr(sig)) <= REPR_MAX


def test_a_repr_names_the_files_without_their_folders_and_a_cut_one_still_closes(tmp_path):
    import lidar_sig as ls

    deep = tmp_path.joinpath(*["a_rather_long_folder_name"] * 12)
    deep.mkdir(parents=True)
    for name in ("epoch1.laz", "epoch2.laz"):
        shutil.copy(SAMPLES / name, deep / name)
    shown = repr(ls.compare(deep / "epoch1.laz", deep / "epoch2.laz"))
    assert shown.startswith("<Comparison epoch1.laz vs epoch2.laz: ") and "a_rather_long" not in shown

    from lidar_sig.jobs import info

    described = info(deep / "epoch1.laz")  # its first line holds the whole path, 12 folders deep
    assert len(described.lines[0]) > REPR_MAX
    assert len(repr(described)) == REPR_MAX and repr(described).endswith("...>")
    cloud = repr(ls.read(deep / "epoch2.laz"))  # says where it came from, within the line
    assert len(cloud) == REPR_MAX and cloud.startswith("<PointCloud 31,354 points") and cloud.endswith("...>")


def test_the_compile_notice_points_at_the_users_call_whichever_entry_made_it(tmp_path, monkeypatch):
    # a notice located in the library (pipeline.py, `self.announce_compilation()`) reads as the
    # library's own warning; a notebook shows the line of the user's cell instead
    import warnings

    import lidar_sig as ls
    from lidar_sig.base import compile as kernels
    from lidar_sig.base.errors import LidarSigWarning

    monkeypatch.setattr(kernels, "kernels_cached", lambda *a, **k: False)  # as on the first run after installing
    monkeypatch.chdir(tmp_path)
    epoch1, epoch2 = SAMPLES / "epoch1.laz", SAMPLES / "epoch2.laz"
    (tmp_path / "wd").mkdir()  # a run's work folder is made inside the folder given
    entries = {
        "Pipeline.run": lambda: ls.Pipeline().run(epoch2),
        "compare": lambda: ls.compare(epoch1, epoch2),
        "changes": lambda: ls.changes(epoch1, SAMPLES / "epoch2_aligned.laz", cell=16),
        "Catalog.build": lambda: ls.Catalog.build([epoch1, epoch2], tmp_path / "c.h5", overwrite=True),
        "jobs.saliency": lambda: ls.jobs.saliency(epoch2, tmp_path / "s.laz", overwrite=True),
        "a run in tiles": lambda: ls.Pipeline().run(epoch2, execution=ls.Execution(tile_size=60, workers=1,
                                                                                    work_dir=tmp_path / "wd")),
    }
    for name, call in entries.items():
        monkeypatch.setattr(kernels, "_ANNOUNCED", False)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            call()
        notices = [w for w in caught if issubclass(w.category, LidarSigWarning) and "compiling" in str(w.message)]
        assert len(notices) == 1, (name, [str(w.message) for w in caught])
        assert (notices[0].filename, notices[0].lineno) == (__file__, call.__code__.co_firstlineno), \
            (name, notices[0].filename, notices[0].lineno)


def test_a_thumbnail_shades_by_the_distance_to_the_level_so_identical_epochs_look_unchanged():
    import lidar_sig as ls
    from lidar_sig.reporting.change_scale import CHANGE_SCALE

    pipe = ls.Pipeline(progress=False)
    same = ls.changes(SAMPLES / "epoch1.laz", SAMPLES / "epoch1.laz", cell=16, pipeline=pipe)
    valid = same.raster("valid") > 0
    assert valid.sum() > 10 and same.n_significant == 0
    k = same.thumbnail().shape[0] // same.grid.rows
    cells = same.thumbnail()[k // 4::k, k // 4::k][:same.grid.rows, :same.grid.cols]  # beside the rank numbers
    # every compared cell in the lightest class: a score of 0 is far below any level
    assert (cells[valid] == CHANGE_SCALE.colours[0]).all()
    cm = ls.changes(SAMPLES / "epoch1.laz", SAMPLES / "epoch2_aligned.laz", cell=16, pipeline=pipe)
    reached, t = cm.table["lod_ratio"], cm.table
    # above its level in one of the two tests is what makes a cell significant
    assert np.array_equal(np.nan_to_num(reached) > 1, t["significant"]) and np.isnan(reached[~t["valid"]]).all()


def test_a_signature_card_draws_its_triangle_and_a_comparison_says_what_each_side_is():
    import lidar_sig as ls

    pipe = ls.Pipeline(progress=False)
    sig = pipe.run(SAMPLES / "epoch1.laz").signature
    picture = sig.picture(360)
    v = sig.frame.vertices * 360 / sig.frame.size  # V_l, V_s, V_p
    for a, b in ((0, 1), (1, 2), (2, 0)):  # the outline: dark ink at each side's middle
        x, y = np.rint((v[a] + v[b]) / 2).astype(int)
        assert picture[y - 1:y + 2, x - 1:x + 2].min() < 140, (a, b)
    top = picture[:int(v[0][1]) - 2, int(v[0][0]) - 40:int(v[0][0]) + 40]
    assert (top.min(axis=2) < 140).sum() > 20  # the label above the line vertex: "Cl line"
    shown = ls.compare(sig, pipe.run(SAMPLES / "epoch2.laz").signature)
    card = shown._repr_html_()
    assert "archive" not in card and card.count("signature ") >= 2 and shown.a.kind == "signature"


#: For each card in the page, in the browser: its display, whether its picture lies left of its
#: text, and each table cell's alignment with the column's numeric class.
LAYOUT = """
return [...document.querySelectorAll('.lidar-sig-card')].map(c => {
  const img = c.querySelector(':scope > img'), text = c.querySelector(':scope > div');
  const cells = [...c.querySelectorAll('td')].map(td => [td.classList.contains('n'), getComputedStyle(td).textAlign]);
  const tables = [...c.querySelectorAll('table')].map(t => getComputedStyle(t).marginLeft);
  return [c.querySelector('b').innerText, getComputedStyle(c).display,
          img ? img.getBoundingClientRect().right <= text.getBoundingClientRect().left : null, cells, tables];
});
"""
#: JupyterLab's own rules that a card's layout must withstand (right-aligned cells, centred tables).
HOSTILE = "<style>td,th{text-align:right}table{margin-left:auto;margin-right:auto}</style>"


def test_every_card_keeps_its_layout_in_an_untrusted_notebook(example_objects, tmp_path):
    # JupyterLab's sanitizer strips <style> and <script> and the attributes and style properties
    # it does not list (tests/untrusted.py): every card of every object the docs' examples make
    # loses nothing, and a browser lays the sanitized cards out as intended
    from untrusted import sanitized

    import lidar_sig as ls

    cm = ls.changes(SAMPLES / "epoch1.laz", SAMPLES / "epoch2_aligned.laz", cell=16,
                    pipeline=ls.Pipeline(progress=False))
    objects = {**example_objects, "cm.levels": cm.levels, "cm.top(3)": cm.top(3), "cm.report()": cm.report()}
    # every card; not the report's full page that report.show() gives on demand: a page of its own
    # stylesheet, which an untrusted notebook shows unstyled (docs/python.md says so; the card
    # links to the saved page)
    cards = {name: v._repr_html_() for name, v in objects.items() if callable(getattr(v, "_repr_html_", None))
             and type(v).__name__ != "Page"}
    kinds = {type(objects[name]).__name__ for name in cards}
    assert {"Signature", "ChangeMap", "Comparison", "Report", "Levels", "TopCells"} <= kinds, kinds
    kept = {}
    for name, html in cards.items():
        kept[name], removed = sanitized(html)
        assert not removed, (name, removed[:5])
        assert "<style" not in html and 'class="lidar-sig-card" style="' in html and "display:flex" in html, name
    why = missing()
    if why:
        pytest.skip(f"no headless browser to lay the cards out ({why})")
    page = tmp_path / "untrusted.html"
    # the HTML JupyterLab keeps, under rules as hostile as JupyterLab's own
    page.write_text(f"<!DOCTYPE html><html><head>{HOSTILE}</head><body>" + "".join(kept.values()) + "</body></html>")
    with Browser() as browser:
        browser.open(page)
        layout = browser.driver.execute_script(LAYOUT)
    assert len(layout) >= len(cards), layout
    for title, display, picture_left, cells, tables in layout:
        assert display == "flex", title
        assert picture_left in (True, None), title
        assert all(how == ("right" if numeric else "left") for numeric, how in cells), (title, cells)
        assert all(margin == "0px" for margin in tables), (title, tables)
    assert any(picture_left for _, _, picture_left, _, _ in layout)
    assert sum(len(cells) for *_, cells, _ in layout) > 20
