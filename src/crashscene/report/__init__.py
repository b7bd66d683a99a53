"""Report: a self-contained HTML page, results.json and JUnit XML from a run or campaign folder.

`write_report(out_dir, gifs=True) -> WrittenReport(html, results, junit)`.
"""
from crashscene.report.build import WrittenReport, write_report
from crashscene.report.errors import ReportError

__all__ = ["ReportError", "WrittenReport", "write_report"]
