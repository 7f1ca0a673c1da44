"""Rendering results (from result.json alone) as HTML, Markdown and JUnit XML.

Public API: `load_result`, `render_reports`, `ResultError`, `FORMATS` (see `reports.render`).
"""

from casewatch.reports.render import FORMATS, ResultError, load_result, render_reports

__all__ = ["FORMATS", "ResultError", "load_result", "render_reports"]
