"""The plugin's own files: its icons (``icons/NAME.svg``) and the help page of each algorithm's
command (``help/JOB.html``, made from docs/commands/JOB.md by qgis/build_plugin.py)."""
from pathlib import Path

from qgis.PyQt.QtCore import QUrl
from qgis.PyQt.QtGui import QIcon

HERE = Path(__file__).resolve().parent


def icon_path(name):
    """The path of the icon ``name`` ("lidar_sig" for the provider, else a job's name)."""
    return str(HERE / "icons" / f"{name}.svg")


def icon(name):
    """The icon ``name`` as a QIcon."""
    return QIcon(icon_path(name))


def help_url(job):
    """A file URL of the page of ``lidar-sig JOB``: the plugin's own copy (help/JOB.html), or,
    where the plugin runs from the repository, docs/commands/JOB.md beside it; "" without one."""
    page = HERE / "help" / f"{job}.html"
    if not page.exists():
        page = HERE.parents[1] / "docs" / "commands" / f"{job}.md"
    return QUrl.fromLocalFile(str(page)).toString() if page.exists() else ""
