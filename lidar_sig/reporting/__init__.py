"""The HTML report: the paper's figures for one cloud, for the comparison of two, for a change
map or series, or for a catalogue's outliers, made from computed results (a
:class:`lidar_sig.comparison.Comparison`, a :class:`lidar_sig.comparison.Side`, a
:class:`lidar_sig.change_map.ChangeMap` or :class:`~lidar_sig.change_map.ChangeSeries`, a
:class:`lidar_sig.survey_catalog._outlier_scores.Outliers`); nothing here
reads a file or runs a pipeline (:func:`lidar_sig.comparison.report` does, then makes the report).

A :class:`Report` is one self-contained HTML page (pictures embedded, no network). In a notebook
it displays itself; ``save`` writes the page, ``save_plots`` every figure as PNG.

>>> import lidar_sig as ls                                         # doctest: +SKIP
>>> ls.report("epoch1.laz", "epoch2.laz").save("report.html")      # doctest: +SKIP
"""
from ._changes_page import changes_report
from ._comparison_page import COMPARISON_PLOTS, comparison_report
from ._document import Report
from .map_image import change_map_image, when_map_image
from ._outliers_page import outliers_report
from ._paths import HTML_EXTENSIONS, check_plots_folder, check_report_path
from ._series_page import series_report
from ._signature_page import SIGNATURE_PLOTS, signature_report

__all__ = ["COMPARISON_PLOTS", "HTML_EXTENSIONS", "SIGNATURE_PLOTS", "Report", "change_map_image", "changes_report",
           "check_plots_folder", "check_report_path", "comparison_report", "outliers_report", "series_report",
           "signature_report", "when_map_image"]
