"""``wavealt reproduce`` and its report: ``pipeline`` (simulate -> deglint -> train ->
evaluate, resumable by stage) -> ``markdown`` (the report text) -> ``html`` (one
self-contained page)."""

from wavealt.report.html import markdown_to_html
from wavealt.report.markdown import (
    baseline_verdicts,
    build_report_markdown,
    side_by_side_markdown,
    verdict_paragraph,
)
from wavealt.report.pipeline import reproduce
from wavealt.report.scales import SCALES, ReproduceScale

__all__ = ["SCALES", "ReproduceScale", "baseline_verdicts", "build_report_markdown",
           "markdown_to_html", "reproduce", "side_by_side_markdown", "verdict_paragraph"]
