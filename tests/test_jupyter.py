"""The package in notebooks as people run them: its cards in a real JupyterLab page (JupyterLab's
own styles apply to them there, which a bare HTML page does not show), and its progress in a
notebook run by a kernel."""
import os
import shutil
import time
from pathlib import Path

import pytest

from browser import Browser, missing
from conftest import IGN, SAMPLES, need_data
from jupyter_run import JupyterLab, environment, execute, missing_lab, missing_nbconvert, notebook, run_in_page

#: Computed style of every cell of the cards' tables: (table's card title, column, text, text-align).
CELLS = """
return [...document.querySelectorAll('.jp-OutputArea-output .lidar-sig-card table')].flatMap(t => {
  const title = t.closest('.lidar-sig-card').querySelector('b').innerText;
  const head = [...t.querySelectorAll('thead th')].map(h => h.innerText.trim());
  return [...t.querySelectorAll('tbody td')].map(c =>
    [title, head[c.cellIndex], c.innerText.trim(), getComputedStyle(c).textAlign]);
});
"""
#: Where each card's first table starts, against its card's left edge (px), and its margins.
TABLES = """
return [...document.querySelectorAll('.jp-OutputArea-output .lidar-sig-card table')].map(t => {
  const text = t.parentElement.getBoundingClientRect().left;
  const s = getComputedStyle(t);
  return [t.closest('.lidar-sig-card').querySelector('b').innerText, t.getBoundingClientRect().left - text,
          s.marginLeft];
});
"""


def _keep(shot):
    if os.environ.get("LIDAR_SIG_SCREENSHOTS"):  # keep the artefact where CI or a person looks
        target = Path(os.environ["LIDAR_SIG_SCREENSHOTS"])
        target.mkdir(parents=True, exist_ok=True)
        shutil.copy(shot, target / shot.name)


def test_the_cards_read_left_aligned_with_numbers_right_in_a_real_jupyterlab_page(tmp_path):
    why = missing_lab() or missing()
    if why:
        pytest.skip(f"no JupyterLab page to look at: {why}")
    epoch1, epoch2, aligned = (repr(str(SAMPLES / n)) for n in ("epoch1.laz", "epoch2.laz", "epoch2_aligned.laz"))
    notebook(tmp_path / "cards.ipynb", [
        f"import lidar_sig as ls\npipe = ls.Pipeline(progress=False)\na = pipe.run({epoch1})\na.signature",
        f"ls.compare(a, pipe.run({epoch2}))",
        f"cm = ls.changes({epoch1}, {aligned}, cell=8, pipeline=pipe)\ncm",
        "cm.levels",
        "cm.top(3)",
    ])
    with JupyterLab(tmp_path) as lab, Browser(1280, 2400) as browser:
        errors = run_in_page(browser, lab, "cards.ipynb", ".lidar-sig-card", count=5)
        assert not errors, errors
        cells = browser.driver.execute_script(CELLS)
        tables = browser.driver.execute_script(TABLES)
        shot = browser.screenshot(tmp_path / "jupyterlab_cards.png")
    _keep(shot)
    align = {}
    for title, column, text, how in cells:
        align.setdefault((title, column), set()).add(how)
    # text: a class name, what a metric reacts to; numbers: a count of points, a metric's value
    assert align[("Signature", "class")] == {"left"}, cells
    assert align[("Signature", "points")] == {"right"}, cells
    assert align[("Comparison", "reacts to")] == {"left"} and align[("Comparison", "value")] == {"right"}, cells
    assert align[("ChangeMap", "significant")] == {"left"} and align[("ChangeMap", "score")] == {"right"}, cells
    assert align[("Levels of detection", "metric")] == {"left"} and align[("Levels of detection", "beta")] == {"right"}
    assert align[("TopCells", "points per class, A \u2192 B")] == {"left"} and align[("TopCells", "z")] == {"right"}
    assert any(text == "ground" for _, _, text, _ in cells)  # the cells read are the cards' own
    # JupyterLab centres tables (margin auto): a card's table starts at its text's left edge
    assert tables and all(abs(offset) < 1 and margin == "0px" for _, offset, margin in tables), tables


# -- progress in a notebook --------------------------------------------------------------------

def _executed(tmp_path, cells, name):
    """The notebook of ``cells`` executed by a kernel in ``tmp_path``, progress left to its
    default (the tests' LIDAR_SIG_PROGRESS=none unset)."""
    env = environment(tmp_path)
    env.pop("LIDAR_SIG_PROGRESS", None)
    return execute(notebook(tmp_path / name, cells), env)


def _outputs(nb):
    return [o for cell in nb.cells for o in cell.outputs]


def _errors(nb):
    return [o.get("evalue") or o.get("text") for o in _outputs(nb) if o.output_type == "error"]


def test_a_catalogue_built_in_a_notebook_shows_its_progress_as_bars(tmp_path):
    why = missing_nbconvert()
    if why:
        pytest.skip(f"no kernel to run a notebook: {why}")
    try:
        import ipywidgets  # noqa: F401
    except ImportError:
        pytest.skip("ipywidgets is not installed (pip install -e '.[test]'): the notebook's bars need it")
    tiles = [str(p) for p in sorted(need_data(IGN).glob("*.laz"))[:2]]
    build = f"import lidar_sig as ls\ncat = ls.Catalog.build({tiles!r}, 'tiles.h5')\ncat"
    nb = _executed(tmp_path, [build], "bars.ipynb")
    assert not _errors(nb), _errors(nb)
    shown = [o.data.get("text/plain", "") for o in _outputs(nb) if o.output_type == "display_data"]
    # each closed bar's output is its last line, what a saved notebook shows without the widgets'
    # state: the tiles' bar at its end, no bar left at the "0%" it started at
    assert any(text.startswith("tiles: 100%") and "2/2" in text for text in shown), shown
    assert not [text for text in shown if " 0%|" in text or text.startswith("0%")], shown
    # the widgets' last state, kept with the notebook: the tiles' bar went to its end
    state = nb.metadata["widgets"]["application/vnd.jupyter.widget-state+json"]["state"]
    progress = [m["state"] for m in state.values() if m["model_name"] == "FloatProgressModel"]
    assert any(p["max"] == 2 and p["value"] == 2 for p in progress), progress
    assert not [o for o in _outputs(nb) if o.output_type == "stream" and "progress" in o.text]  # bars, not lines


def test_without_ipywidgets_a_notebook_shows_progress_lines_of_a_catalogue_and_a_first_run(tmp_path):
    why = missing_nbconvert()
    if why:
        pytest.skip(f"no kernel to run a notebook: {why}")
    tiles = [str(p) for p in sorted(need_data(IGN).glob("*.laz"))[:2]]
    nb = _executed(tmp_path, [
        "import sys\nsys.modules['ipywidgets'] = None  # as where it is not installed",
        f"import lidar_sig as ls\ncat = ls.Catalog.build({tiles!r}, 'tiles.h5')",
        f"result = ls.Pipeline().run({str(SAMPLES / 'epoch2.laz')!r})",
    ], "lines.ipynb")
    assert not _errors(nb), _errors(nb)
    said = ["".join(o.text for o in cell.outputs if o.output_type == "stream" and o.name == "stderr").splitlines()
            for cell in nb.cells]
    assert said[1][:1] == ["lidar-sig: progress: tiles: 0%"] and "lidar-sig: progress: tiles: 100%" in said[1], said[1]
    assert "lidar-sig: progress: writing tiles.h5: 100%" in said[1], said[1]
    run = [line for line in said[2] if line.startswith("lidar-sig: progress: ")]
    assert "lidar-sig: progress: reading epoch2.laz: 0%" in run and \
        "lidar-sig: progress: saliency (c3dcm multiscale): 100%" in run, said[2]


#: Each card's display, whether its picture lies left of its text, its title (in JupyterLab's page).
CARD_LAYOUT = """
return [...document.querySelectorAll('.jp-OutputArea-output .lidar-sig-card')].map(c => {
  const img = c.querySelector(':scope > img'), text = c.querySelector(':scope > div');
  return [c.querySelector('b').innerText, getComputedStyle(c).display,
          img ? img.getBoundingClientRect().right <= text.getBoundingClientRect().left : null];
});
"""


def test_the_cards_keep_their_layout_in_a_notebook_that_is_not_trusted(tmp_path):
    # a notebook executed by nbconvert's client and opened in JupyterLab is not trusted: its
    # outputs go through JupyterLab's sanitizer, which strips <style> blocks
    why = missing_lab() or missing_nbconvert() or missing()
    if why:
        pytest.skip(f"no JupyterLab page to look at: {why}")
    import nbformat

    epoch1, epoch2, aligned = (repr(str(SAMPLES / n)) for n in ("epoch1.laz", "epoch2.laz", "epoch2_aligned.laz"))
    nb = _executed(tmp_path, [
        f"import lidar_sig as ls\npipe = ls.Pipeline(progress=False)\na = pipe.run({epoch1})\na.signature",
        f"ls.compare(a, pipe.run({epoch2}))",
        f"cm = ls.changes({epoch1}, {aligned}, cell=8, pipeline=pipe)\ncm",
        "cm.levels",
        "cm.top(3)",
        "cm.report()",
    ], "untrusted.ipynb")
    assert not _errors(nb), _errors(nb)
    nbformat.write(nb, str(tmp_path / "untrusted.ipynb"))
    with JupyterLab(tmp_path) as lab, Browser(1280, 2400) as browser:
        driver = browser.driver
        driver.get(lab.page("untrusted.ipynb"))
        deadline = time.monotonic() + 120
        while driver.execute_script(
                "return document.querySelectorAll('.jp-OutputArea-output .lidar-sig-card').length") < 6:
            assert time.monotonic() < deadline, "JupyterLab showed no cards"
            time.sleep(0.5)
        trusted = driver.execute_script(
            "const m = window.jupyterapp.shell.currentWidget.content.model;"
            "return [...Array(m.cells.length).keys()].map(i => m.cells.get(i).trusted);")
        cells = driver.execute_script(CELLS)
        cards = driver.execute_script(CARD_LAYOUT)
        tables = driver.execute_script(TABLES)
        shot = browser.screenshot(tmp_path / "jupyterlab_untrusted_cards.png")
    _keep(shot)
    assert trusted and not any(trusted), trusted  # the sanitizer applies
    assert len(cards) == 6 and all(display == "flex" for _, display, _ in cards), cards
    assert all(left is not False for _, _, left in cards) and sum(bool(left) for _, _, left in cards) >= 3, cards
    align = {}
    for title, column, text, how in cells:
        align.setdefault((title, column), set()).add(how)
    assert align[("Signature", "class")] == {"left"} and align[("Signature", "points")] == {"right"}, cells
    assert align[("ChangeMap", "significant")] == {"left"} and align[("ChangeMap", "score")] == {"right"}, cells
    assert align[("Levels of detection", "metric")] == {"left"} and align[("Levels of detection", "beta")] == {"right"}
    assert tables and all(abs(offset) < 1 and margin == "0px" for _, offset, margin in tables), tables
