"""One document of a result, rendered four ways: terminal text, Markdown, HTML and JSON.

The contract, after statsmodels' ``iolib.summary.Summary``: a results object's ``document()`` builds a
:class:`Summary` (a title, lead paragraphs under it, then sections of paragraphs and tables), and the four
renderers lay that one document out, so that the command line's text, a Markdown file and a web page cannot
say different things.  A :class:`Table` keeps each cell's text as shown and, when it has them, the numbers
behind it; its columns name their units, which the text shows in the header it is given and the other
renderers beside the column's name.  The document computes nothing: the results object has decided every
word and number before building it.

The terminal text is laid out as the commands have always printed it: the title and its lead, then each
section after a blank line; a wrapped paragraph breaks at :data:`TEXT_WIDTH` characters.
"""

from __future__ import annotations

import html
import textwrap
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from bayescal.jsonsafe import json_safe

__all__ = ["Column", "Paragraph", "Section", "Span", "Summary", "Table", "TEXT_WIDTH"]

TEXT_WIDTH = 100
"""Characters per line of a wrapped paragraph in the terminal text (the commands' next-step advice)."""


@dataclass(frozen=True)
class Paragraph:
    """A sentence or a line of a section.

    Attributes
    ----------
    text : str
        The words, without a line break.
    wrap : bool
        Whether the terminal text breaks it at :data:`TEXT_WIDTH` characters (otherwise one line, however long).
    indent, subsequent_indent : str
        What the terminal text puts before its first line and before each following one.
    kind : str
        ``"text"``, ``"note"`` (an aside, such as what a table's symbols mean) or ``"warning"``; the HTML
        gives it as the paragraph's class, the Markdown sets notes in italics and warnings in bold.
    """

    text: str
    wrap: bool = False
    indent: str = ""
    subsequent_indent: str = ""
    kind: str = "text"

    def text_lines(self) -> list[str]:
        if self.wrap:
            return textwrap.wrap(self.text, width=TEXT_WIDTH, initial_indent=self.indent, subsequent_indent=self.subsequent_indent)
        return [self.indent + self.text]

    def markdown(self) -> str:
        return {"note": f"*{self.text}*", "warning": f"**{self.text}**"}.get(self.kind, self.text) if self.text else ""

    def html(self) -> str:
        return f'<p class="{self.kind}">{html.escape(self.text)}</p>'

    def to_json(self) -> dict:
        return {"paragraph": self.text, "kind": self.kind}


@dataclass(frozen=True)
class Column:
    """A table's column: its name, its unit, and how the terminal text lays it out.

    Attributes
    ----------
    name : str
        The column's name (a parameter, a candidate, a statistic).
    unit : str
        Its unit, ``""`` for a count, a name or a ratio.
    width : int
        Characters the terminal text pads each cell to (0: no padding).
    align : str
        ``"<"`` (left) or ``">"`` (right) in the terminal text.
    before : str
        What the terminal text puts before the column (a separator).
    header : str or None
        The column's header in the terminal text, when it differs from ``name`` (the unit in it, a symbol).
    """

    name: str
    unit: str = ""
    width: int = 0
    align: str = ">"
    before: str = ""
    header: str | None = None

    def label(self) -> str:
        """The column's name with its unit in brackets, as the Markdown and the HTML head it."""
        return f"{self.name} ({self.unit})" if self.unit else self.name


@dataclass(frozen=True)
class Span:
    """A cell's text laid over ``columns`` columns: the terminal text and the HTML span them, the Markdown and the JSON
    give it in the first and leave the others empty."""

    text: str
    columns: int


@dataclass(frozen=True)
class Table:
    """A table of a section: named columns with units, rows of texts, and the numbers behind them.

    Attributes
    ----------
    key : str
        The table's name in the JSON.
    columns : tuple of Column
    rows : tuple of tuple
        Per row, a text (str) or a :class:`Span` per column; a span stands for as many columns as it covers.
    values : tuple of dict, optional
        Per row, the numbers behind its texts under the columns' names (the JSON's rows; their units are the
        columns'); without them the JSON gives the texts.
    rule : bool
        Whether the terminal text rules the header off with a line of dashes as long as it.
    """

    key: str
    columns: tuple[Column, ...]
    rows: tuple[tuple[str | Span, ...], ...]
    values: tuple[dict, ...] | None = None
    rule: bool = False

    def text_lines(self) -> list[str]:
        header = "".join(f"{c.before}{(c.name if c.header is None else c.header):{c.align}{c.width}}" for c in self.columns)
        lines = [header] + (["-" * len(header)] if self.rule else [])
        for row in self.rows:
            parts, at = [], 0
            for cell in row:
                if isinstance(cell, Span):
                    covered = self.columns[at : at + cell.columns]
                    width = sum(c.width + len(c.before) for c in covered) - len(covered[0].before)
                    parts.append(f"{covered[0].before}{cell.text:{covered[-1].align}{width}}")
                    at += cell.columns
                else:
                    column = self.columns[at]
                    parts.append(f"{column.before}{cell:{column.align}{column.width}}")
                    at += 1
            lines.append("".join(parts))
        return lines

    def _cells(self, row: tuple[str | Span, ...]) -> list[tuple[str, int]]:
        """The row's texts with the columns each covers, empty cells added up to the table's width (a row may end early)."""
        cells = [(cell.text, cell.columns) if isinstance(cell, Span) else (cell, 1) for cell in row]
        return cells + [("", 1)] * (len(self.columns) - sum(span for _, span in cells))

    def _texts(self, row: tuple[str | Span, ...]) -> list[str]:
        """One text per column: a span's in its first column, the columns it covers empty."""
        return [part for text, span in self._cells(row) for part in [text] + [""] * (span - 1)]

    def markdown(self) -> str:
        def line(cells: Sequence[str]) -> str:
            return "| " + " | ".join(cell.replace("|", "\\|") for cell in cells) + " |"

        rows = [line(self._texts(row)) for row in self.rows]
        rule = "|" + "|".join("---" if c.align == "<" else "---:" for c in self.columns) + "|"
        return "\n".join([line([c.label() for c in self.columns]), rule, *rows])

    def html(self) -> str:
        head = "".join(f"<th>{html.escape(c.label())}</th>" for c in self.columns)
        body = "".join("<tr>" + "".join(_cell_html(text, span) for text, span in self._cells(row)) + "</tr>" for row in self.rows)
        return f'<table id="{html.escape(self.key)}"><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>'

    def to_json(self) -> dict:
        rows = self.values if self.values is not None else [
            {column.name: text for column, text in zip(self.columns, self._texts(row))} for row in self.rows
        ]
        return {"table": self.key, "columns": [{"name": c.name, "unit": c.unit} for c in self.columns], "rows": json_safe(list(rows))}


def _cell_html(text: str, span: int) -> str:
    return f'<td colspan="{span}">{html.escape(text)}</td>' if span > 1 else f"<td>{html.escape(text)}</td>"


@dataclass(frozen=True)
class Section:
    """Paragraphs and tables under an optional heading.

    The terminal text gives the heading on a line of its own, as written (``"Not identifiable:"``); the
    Markdown and the HTML without its closing colon.
    """

    blocks: tuple[Paragraph | Table, ...]
    heading: str = ""

    def text_lines(self) -> list[str]:
        lines = [self.heading] if self.heading else []
        for block in self.blocks:
            lines += block.text_lines()
        return lines


@dataclass(frozen=True)
class Summary:
    """A result's document: a title, the paragraphs under it, and its sections.

    Attributes
    ----------
    title : str
        The first line: what was computed from what.
    lead : tuple of Paragraph or Table
        What follows the title directly, without a blank line (a verdict; a document of one block).
    sections : tuple of Section
    """

    title: str
    lead: tuple[Paragraph | Table, ...] = ()
    sections: tuple[Section, ...] = field(default_factory=tuple)

    def as_text(self) -> str:
        """The document as the terminal shows it: the title and lead, then each section after a blank line."""
        lines = [self.title] + [line for block in self.lead for line in block.text_lines()]
        for section in self.sections:
            lines += ["", *section.text_lines()]
        return "\n".join(lines)

    def as_markdown(self) -> str:
        """The document in Markdown: the title as a level-1 heading, sections as level-2 ones, tables with units in their heads."""
        parts = [f"# {self.title}", *(block.markdown() for block in self.lead)]
        for section in self.sections:
            if section.heading:
                parts.append(f"## {section.heading.rstrip(':')}")
            parts += [block.markdown() for block in section.blocks]
        return "\n\n".join(part for part in parts if part) + "\n"

    def as_html(self) -> str:
        """The document as an HTML fragment: an ``<article>`` of a heading, paragraphs and ``<section>`` elements."""
        parts = [f"<h1>{html.escape(self.title)}</h1>", *(block.html() for block in self.lead)]
        for section in self.sections:
            inner = [f"<h2>{html.escape(section.heading.rstrip(':'))}</h2>"] if section.heading else []
            parts.append("<section>" + "".join(inner + [block.html() for block in section.blocks]) + "</section>")
        return "<article>" + "".join(parts) + "</article>"

    def as_json(self) -> dict[str, Any]:
        """The document as JSON-ready data: title, lead and sections, each table's rows as its numbers where it has them."""
        return {
            "title": self.title,
            "lead": [block.to_json() for block in self.lead],
            "sections": [{"heading": s.heading, "blocks": [b.to_json() for b in s.blocks]} for s in self.sections],
        }

    def __str__(self) -> str:
        return self.as_text()
