"""The report as one self-contained HTML page: markdown rendered by Python-Markdown (tables,
fenced code, lists, emphasis), the figures embedded as base64 PNG."""

from __future__ import annotations

import base64
import html
import re
from pathlib import Path

import markdown

_IMG_SRC = re.compile(r'<img alt="([^"]*)" src="([^"]+)"\s*/?>')
STYLE = ("body{font-family:sans-serif;max-width:1100px;margin:2em auto;padding:0 1em}"
         "table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #bbb;"
         "padding:3px 8px;text-align:right}td:first-child,th:first-child{text-align:left}"
         "img{max-width:100%}pre{background:#f4f4f4;padding:8px;overflow:auto}"
         "blockquote{background:#fff4d6;border-left:4px solid #e0a000;padding:6px 12px}")


def markdown_to_html(md: str, *, base: Path) -> str:
    """A self-contained HTML page of the markdown ``md``; images are read relative to
    ``base`` and embedded (an image that is missing keeps its link)."""

    def embed(m: re.Match[str]) -> str:
        p = Path(base) / html.unescape(m.group(2))
        if not p.is_file():
            return m.group(0)
        data = base64.b64encode(p.read_bytes()).decode("ascii")
        return f'<img alt="{m.group(1)}" src="data:image/png;base64,{data}">'

    body = markdown.markdown(md, extensions=["tables", "fenced_code", "sane_lists"],
                             output_format="html")
    body = _IMG_SRC.sub(embed, body)
    return ("<!DOCTYPE html>\n<html><head><meta charset='utf-8'><title>wavealt reproduce</title>"
            f"<style>{STYLE}</style></head><body>\n{body}\n</body></html>\n")


__all__ = ["markdown_to_html"]
