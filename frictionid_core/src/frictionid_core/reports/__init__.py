"""HTML reports of one result on any data (:mod:`.result_report`), drawn with :mod:`.html_page`
(the page style, tables and plots; the EMPS report draws with it too).
"""

from frictionid_core import lazy

# Public names -> the module that defines them (loaded on first use).
_LAZY = {
    **dict.fromkeys((
        "friction_axes", "html_table", "MAX_PLOT_POINTS", "PAGE_STYLE", "png_bytes", "REPORT_FILES",
    ), "frictionid_core.reports.html_page"),
    **dict.fromkeys(("build_fit_report",), "frictionid_core.reports.result_report"),
}

__all__ = ["MAX_PLOT_POINTS", "PAGE_STYLE", "REPORT_FILES", "build_fit_report", "friction_axes", "html_table",
           "png_bytes"]

__getattr__, __dir__ = lazy.lazy_names(__name__, _LAZY)
