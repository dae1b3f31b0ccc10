"""At home in a notebook: every object of lidar_sig that the README's and docs/python.md's
examples make prints in one line or a few (its repr), and the objects with more to show draw an
HTML card (``_repr_html_``) that a browser renders: a signature's image, a comparison's metric
table, a change map's thumbnail and counts, a catalogue's summary."""
import contextlib
import io
import os
import shutil
from pathlib import Path

import numpy as np
import pytest

from browser import Browser, missing
from conftest import IGN, ROOT, SAMPLES, need_data
from test_docs import blocks

#: Longest repr of a public object, in characters.
REPR_MAX = 300


def _ours(value):
    return type(value).__module__.startswith("lidar_sig")


def _made_by_examples(page, folder, monkeypatch):
    """Every lidar_sig object bound by the Python examples of ``page``, run in ``folder``."""
    monkeypatch.chdir(folder)
    found = {}
    for kind, text in blocks(page):
        if kind != "python" or "import open3d" in text:  # Open3D's objects are not ours
            continue
        namespace = {"__name__": "__main__"}
        with contextlib.redirect_stdout(io.StringIO()):
            exec(compile(text, str(page), "exec"), namespace)
        for name, value in namespace.items():
            for v in (value if isinstance(value, (list, tuple)) else [value]):
                if _ours(v) and not isinstance(v, type) and not callable(v) or _ours(v) and hasattr(v, "__dict__") \
                        and not isinstance(v, type) and not hasattr(v, "__code__"):
                    found.setdefault(f"{page.name}: {name} ({type(v).__name__})", v)
    return found


@pytest.fixture(scope="module")
def example_objects(tmp_path_factory):
    folder = tmp_path_factory.mktemp("examples")
    (folder / "data_samples").symlink_to(SAMPLES)
    with pytest.MonkeyPatch.context() as patch:
        found = {}
        for page in (ROOT / "README.md", ROOT / "docs" / "python.md"):
            found.update(_made_by_examples(page, folder, patch))
    return found


def test_the_examples_make_the_objects_a_user_meets(example_objects):
    kinds = {type(v).__name__ for v in example_objects.values()}
    assert {"PointCloud", "Pipeline", "Result", "Saliency", "Signature", "ChangeMap", "Report", "Comparison"} <= kinds


def test_every_object_the_examples_make_prints_in_a_few_lines(example_objects):
    long = {name: len(repr(v)) for name, v in example_objects.items() if len(repr(v)) > REPR_MAX}
    assert not long, long
    assert all("object at 0x" not in repr(v) for v in example_objects.values()), \
        [n for n, v in example_objects.items() if "object at 0x" in repr(v)]


def test_the_public_objects_with_more_to_show_draw_a_card_a_browser_renders(tmp_path):
    import lidar_sig as ls

    a = ls.Pipeline(progress=False).run(SAMPLES / "epoch1.laz")
    b = ls.Pipeline(progress=False).run(SAMPLES / "epoch2.laz")
    cm = ls.changes(SAMPLES / "epoch1.laz", SAMPLES / "epoch2_aligned.laz", cell=16,
                    pipeline=ls.Pipeline(progress=False))
    views = {"signature": a.signature, "comparison": ls.compare(a, b), "change map": cm}
    if IGN.exists():
        cat = ls.Catalog.build([need_data(IGN)], tmp_path / "ign.h5")
        views["catalogue"] = cat
    page = tmp_path / "cards.html"
    page.write_text("<!DOCTYPE html><html><body>" + "".join(f"<h3>{k}</h3>{v._repr_html_()}" for k, v in views.items())
                    + "</body></html>")
    for name, view in views.items():
        html = view._repr_html_()
        assert html.startswith("<") and len(html) < 400_000, name
    assert 'src="data:image/png;base64,' in views["signature"]._repr_html_()
    assert "d_BD-Img" in views["comparison"]._repr_html_() and "reacts" in views["comparison"]._repr_html_()
    assert "significant" in views["change map"]._repr_html_()
    why = missing()
    if why:
        pytest.skip(f"no headless browser to render the cards ({why})")
    with Browser() as browser:
        browser.open(page)
        images = browser.images()
        assert len(images) >= 2 and all(width > 0 for _, width, _ in images), images
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
