"""Tests for bayescal/summary.py: one document, four renderings that say the same thing."""

from __future__ import annotations

import json
from xml.etree import ElementTree

from bayescal.summary import Column, Paragraph, Section, Span, Summary, Table


def _document() -> Summary:
    columns = (Column("parameter", width=10, align="<"), Column("mean", "μrad/(N·m)", width=8), Column("±3σ", "μrad/(N·m)", width=6),
               Column("named", align="<", before="  "))
    table = Table("estimates", columns, (("k2", "0.38", "0.01", "yes"), ("k1", Span("not identifiable", 2), "")),
                  values=({"parameter": "k2", "mean": 0.3812, "±3σ": 0.0104, "named": True}, {"parameter": "k1", "mean": float("nan")}))
    advice = "Next: " + " ".join(["measure"] * 30) + "."
    return Summary(
        "campaign.csv: 405 equations",
        (Paragraph("verdict: misfit <backlash> & more"),),
        (Section((table, Paragraph("(widths in %)", kind="note"))), Section((Paragraph(advice, wrap=True, indent="  "),), heading="Next:")),
    )


def test_text_lays_columns_out_as_given_and_spans_cells():
    lines = _document().as_text().splitlines()
    assert lines[:3] == ["campaign.csv: 405 equations", "verdict: misfit <backlash> & more", ""]
    assert lines[3] == "parameter     mean   ±3σ  named"
    assert lines[4] == "k2            0.38  0.01  yes"
    # a span covers the widths of its columns: 8 + 6 characters, right-aligned as its last column
    assert lines[5] == "k1        " + f"{'not identifiable':>14}" + "  "
    assert lines[6] == "(widths in %)"
    assert lines[7:9] == ["", "Next:"]
    assert all(len(line) <= 100 for line in lines[9:]) and len(lines) > 10 and lines[9].startswith("  Next: measure")


def test_text_of_a_document_without_sections_is_its_title_and_lead():
    assert Summary("title", (Paragraph("lead"),)).as_text() == "title\nlead"
    assert Summary("title", (), (Section(()),)).as_text() == "title\n"


def test_markdown_gives_units_in_the_head_and_escapes_pipes():
    markdown = _document().as_markdown()
    assert markdown.startswith("# campaign.csv: 405 equations\n\nverdict: misfit <backlash> & more\n\n")
    assert "| parameter | mean (μrad/(N·m)) | ±3σ (μrad/(N·m)) | named |\n|---|---:|---:|---|\n| k2 | 0.38 | 0.01 | yes |" in markdown
    assert "| k1 | not identifiable |  |  |" in markdown
    assert "*(widths in %)*" in markdown and "## Next\n" in markdown
    assert "| a \\| b |" in Table("t", (Column("x"),), (("a | b",),)).markdown()


def test_html_is_well_formed_escaped_and_spans_columns():
    page = _document().as_html()
    root = ElementTree.fromstring(page)
    assert root.tag == "article" and root.find("h1").text == "campaign.csv: 405 equations"
    assert root.find("p").text == "verdict: misfit <backlash> & more" and "&lt;backlash&gt; &amp;" in page
    head = [th.text for th in root.iter("th")]
    assert head == ["parameter", "mean (μrad/(N·m))", "±3σ (μrad/(N·m))", "named"]
    spanned = [td for td in root.iter("td") if td.get("colspan")]
    assert [(td.text, td.get("colspan")) for td in spanned] == [("not identifiable", "2")]
    assert root.find("section/p").get("class") == "note"


def test_json_gives_the_numbers_behind_the_texts_and_no_nan():
    data = _document().as_json()
    text = json.dumps(data, allow_nan=False)
    table = data["sections"][0]["blocks"][0]
    assert table["table"] == "estimates"
    assert table["columns"][1] == {"name": "mean", "unit": "μrad/(N·m)"}
    assert table["rows"][0]["mean"] == 0.3812 and table["rows"][1]["mean"] is None
    assert data["lead"] == [{"paragraph": "verdict: misfit <backlash> & more", "kind": "text"}]
    assert data["sections"][1]["heading"] == "Next:" and "not identifiable" not in text


def test_json_of_a_table_without_numbers_gives_its_texts_a_span_in_its_first_column():
    table = Table("t", (Column("a"), Column("b"), Column("c")), (("1", "x", "y"), ("2", Span("both", 2))))
    assert table.to_json()["rows"] == [{"a": "1", "b": "x", "c": "y"}, {"a": "2", "b": "both", "c": ""}]
