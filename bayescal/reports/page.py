"""A report page written three ways at once: HTML, Markdown and JSON, with its figures.

:class:`Page` collects headings, paragraphs, tables and figures, and
:meth:`Page.files` returns the HTML document, the Markdown and the JSON of
every number shown, so that the three always agree.  Every term of
:data:`bayescal.reports.terms.TERMS` in a paragraph, a list or a table's
header gets a hover title, and :meth:`Page.glossary` lists the terms the page
used.  :func:`generic` lays out any JSON mapping (tables for mappings of
mappings, text for the rest), keys in words, for inputs whose keys the report
does not know.
"""

from __future__ import annotations

import html
import json
import math
import re
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from bayescal import __version__
from bayescal.reports.render import png_files
from bayescal.reports.terms import TERMS, label

__all__ = ["Page", "generic", "format_value", "plain", "finite_number", "HTML_FILE", "MARKDOWN_FILE", "JSON_FILE"]

HTML_FILE = "index.html"
MARKDOWN_FILE = "summary.md"
JSON_FILE = "numbers.json"
SIGNIFICANT = 4
"""Significant digits of a number shown without an uncertainty to round it to (the JSON keeps every digit)."""
_TERM = re.compile("|".join(rf"(?<![\w]){re.escape(term)}(?![\w])" for term in sorted(TERMS, key=len, reverse=True)))


class Page:
    """HTML, Markdown, JSON and figures written side by side, so that they show the same numbers."""

    def __init__(self, title: str) -> None:
        self.title = title
        self.html: list[str] = []
        self.markdown: list[str] = [f"# {title}", ""]
        self.numbers: dict[str, Any] = {}
        self.figures: dict[str, Figure] = {}
        self.contents: list[tuple[str, str]] = []
        self.section = ""
        self.used: set[str] = set()

    def marked(self, text: str) -> str:
        """``text`` as HTML, the first use of each glossary term in it with its explanation as a hover title."""
        seen: set[str] = set()

        def title(match: re.Match) -> str:
            term = match.group(0)
            if term in seen:
                return html.escape(term)
            seen.add(term)
            self.used.add(term)
            return f'<abbr title="{html.escape(TERMS[term], quote=True)}">{html.escape(term)}</abbr>'

        parts, last = [], 0
        for match in _TERM.finditer(text):
            parts += [html.escape(text[last : match.start()]), title(match)]
            last = match.end()
        return "".join(parts) + html.escape(text[last:])

    def heading(self, key: str, title: str) -> None:
        self.section = key
        self.numbers.setdefault(key, {})
        self.contents.append((key, title))
        self.html.append(f'<section id="{key}"><h2>{html.escape(title)}</h2>')
        self.markdown += [f"## {title}", ""]

    def close(self) -> None:
        self.html.append("</section>")

    def paragraph(self, text: str, *, css: str = "") -> None:
        attribute = f' class="{css}"' if css else ""
        self.html.append(f"<p{attribute}>{self.marked(text)}</p>")
        self.markdown += [text, ""]

    def items(self, lines: Sequence[str]) -> None:
        self.html.append("<ul>" + "".join(f"<li>{self.marked(line)}</li>" for line in lines) + "</ul>")
        self.markdown += [f"- {line}" for line in lines] + [""]

    def record(self, key: str, value: Any) -> None:
        self.numbers[self.section][key] = plain(value)

    def table(
        self,
        key: str,
        frame: pd.DataFrame,
        *,
        caption: str = "",
        shown: pd.DataFrame | None = None,
        words: Callable[[str], str] = str,
        row_words: Callable[[str], str] = str,
    ) -> None:
        """A table on the page and in the Markdown, and its values under ``key`` in the JSON.

        ``shown``: the texts to show in place of ``frame``'s values (same index and
        columns, e.g. rounded to their uncertainty); the JSON keeps ``frame``'s numbers.
        ``words``, ``row_words``: the header shown for a column name, the label shown for a
        row's (the JSON keeps the names).
        """
        frame = frame.copy()
        index = frame.index.name or ""
        self.record(key, {str(name): row for name, row in frame.to_dict(orient="index").items()})
        header = [words(str(index)) if index else "", *(words(str(c)) for c in frame.columns)]
        texts = frame if shown is None else shown.reindex(index=frame.index, columns=frame.columns)
        rows = [[row_words(str(name)), *(format_value(value) for value in row)] for name, row in zip(frame.index, texts.itertuples(index=False))]
        numeric = [[False, *(is_number(value) for value in row)] for row in frame.itertuples(index=False)]
        # A paragraph, not a <caption>: a caption wraps to the width of a narrow table.
        caption_html = f'<p class="caption">{self.marked(caption)}</p>' if caption else ""
        self.html.append(
            f"{caption_html}<table><thead><tr>"
            + "".join(f"<th>{self.marked(h)}</th>" for h in header)
            + "</tr></thead><tbody>"
            + "".join(
                "<tr>"
                + "".join(
                    f'<td{" class=num" if n else ""}>{self.marked(c) if i == 0 else html.escape(c)}</td>'
                    for i, (c, n) in enumerate(zip(row, kinds))
                )
                + "</tr>"
                for row, kinds in zip(rows, numeric)
            )
            + "</tbody></table>"
        )
        if caption:
            self.markdown += [f"*{caption}*", ""]
        escape = lambda text: text.replace("|", "\\|")  # noqa: E731
        self.markdown += ["| " + " | ".join(map(escape, header)) + " |", "|" + "---|" * len(header)]
        self.markdown += ["| " + " | ".join(map(escape, row)) + " |" for row in rows] + [""]

    def figure(self, name: str, figure: Figure, caption: str) -> None:
        """Place ``figure`` here as ``name.png``; it is drawn with the others when :meth:`files` is asked for."""
        self.figures[f"{name}.png"] = figure
        alt = html.escape(caption, quote=True)
        self.html.append(f'<figure><img src="{name}.png" alt="{alt}"><figcaption>{self.marked(caption)}</figcaption></figure>')
        self.markdown += [f"![{caption}]({name}.png)", ""]

    def glossary(self) -> None:
        """A last section: every glossary term the page used, with its explanation (also its hover title)."""
        used = [term for term in TERMS if term in self.used]
        if not used:
            return
        self.heading("glossary", "Words used on this page")
        del self.numbers["glossary"]  # words, no numbers
        self.html.append("<dl>" + "".join(f"<dt>{html.escape(t)}</dt><dd>{html.escape(TERMS[t])}</dd>" for t in used) + "</dl>")
        self.markdown += [f"- **{term}**: {TERMS[term]}" for term in used] + ["", "More in docs/glossary.md.", ""]
        self.html.append("<p>More in docs/glossary.md of the bayescal documentation.</p>")
        self.close()

    def files(self) -> dict[str, bytes]:
        toc = "".join(f'<li><a href="#{key}">{html.escape(title)}</a></li>' for key, title in self.contents)
        document = _HTML_TEMPLATE.format(title=html.escape(self.title), version=__version__, toc=toc, body="\n".join(self.html))
        numbers = json.dumps(self.numbers, indent=2, allow_nan=False, ensure_ascii=False) + "\n"
        return {
            HTML_FILE: document.encode(),
            MARKDOWN_FILE: ("\n".join(self.markdown).rstrip() + "\n").encode(),
            JSON_FILE: numbers.encode(),
            **png_files(self.figures),
        }


_HTML_TEMPLATE = """<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<title>{title}</title>
<style>
body {{ font-family: system-ui, sans-serif; max-width: 1120px; margin: 1.5em auto; padding: 0 1em; color: #222; line-height: 1.45; }}
h1 {{ margin-bottom: 0.2em; }}
h2 {{ border-bottom: 1px solid #ccc; padding-bottom: 0.2em; margin-top: 1.8em; }}
table {{ border-collapse: collapse; margin: 0.8em 0; font-size: 0.9em; }}
p.caption {{ font-style: italic; margin: 1em 0 0.3em 0; }}
th, td {{ border: 1px solid #bbb; padding: 0.25em 0.6em; text-align: left; vertical-align: top; }}
td.num {{ text-align: right; font-variant-numeric: tabular-nums; }}
td {{ max-width: 38em; }}
thead {{ background: #f0f0f0; }}
figure {{ margin: 1em 0; }}
figure img {{ max-width: 100%; height: auto; border: 1px solid #ddd; }}
figcaption {{ font-size: 0.9em; color: #444; }}
.verdict {{ font-size: 1.1em; font-weight: 600; padding: 0.5em 0.8em; background: #eef4fb; border-left: 4px solid #3a78c2; }}
.warning {{ padding: 0.5em 0.8em; background: #fff4e0; border-left: 4px solid #d08a00; }}
nav ul {{ columns: 2; }}
abbr[title] {{ text-decoration: underline dotted #888; cursor: help; }}
dt {{ font-weight: 600; margin-top: 0.5em; }}
dd {{ margin-left: 1.5em; }}
footer {{ margin-top: 3em; font-size: 0.8em; color: #666; }}
</style>
</head>
<body>
<h1>{title}</h1>
<nav><ul>{toc}</ul></nav>
{body}
<footer>Written by bayescal {version}. Equation, table and figure numbers are those of Klimchik et al.,
<i>Identification of geometrical and elastostatic parameters of heavy industrial robots</i>.</footer>
</body>
</html>
"""


def plain(value: Any) -> Any:
    """JSON values: numpy scalars to Python, NaN and infinity to null."""
    if isinstance(value, Mapping):
        return {str(key): plain(item) for key, item in value.items()}
    if isinstance(value, list | tuple | np.ndarray):
        return [plain(item) for item in value]
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def is_number(value: Any) -> bool:
    return isinstance(value, int | float | np.integer | np.floating) and not isinstance(value, bool | np.bool_)


def format_value(value: Any) -> str:
    if value is None or (isinstance(value, float | np.floating) and not math.isfinite(value)):
        return "–"
    if isinstance(value, bool | np.bool_):
        return "yes" if value else "no"
    if isinstance(value, int | np.integer):
        return str(value)
    if isinstance(value, float | np.floating):
        return f"{value:.{SIGNIFICANT}g}"
    if isinstance(value, Mapping | list | tuple):
        return json.dumps(plain(value), ensure_ascii=False)
    return str(value)


def generic(page: Page, data: Mapping, prefix: str = "") -> None:
    """Any JSON: scalars in one table, a mapping of mappings or a list of mappings as a table each, the rest as text."""
    scalars = {key: value for key, value in data.items() if not isinstance(value, Mapping | list)}
    if scalars:
        frame = pd.DataFrame({"value": [format_value(v) for v in scalars.values()]}, index=pd.Index([label(k) for k in scalars], name="key"))
        page.table(prefix + "values", frame, caption=_path(prefix.rstrip(".")))
        page.record(prefix + "values", scalars)
    for key, value in data.items():
        if isinstance(value, Mapping) and value and all(isinstance(item, Mapping) for item in value.values()):
            frame = pd.DataFrame.from_dict(dict(value), orient="index")
            frame.index.name = key
            page.table(prefix + key, frame, caption=_path(prefix + key), words=label)
        elif isinstance(value, Mapping):
            generic(page, value, prefix=f"{prefix}{key}.")
        elif isinstance(value, list) and value and all(isinstance(item, Mapping) for item in value):
            frame = pd.DataFrame(value)
            frame.index.name = key
            page.table(prefix + key, frame, caption=_path(prefix + key), words=label)
        elif isinstance(value, list):
            page.items([f"{label(key)}: {format_value(item)}" for item in value])
            page.record(prefix + key, value)


def _path(key: str) -> str:
    """A nested key's path in words: ``gain.before`` → ``gain: before``."""
    return ": ".join(label(part) for part in key.split(".") if part)


def finite_number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)
