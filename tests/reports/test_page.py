import json
import math
import re

import numpy as np
import pandas as pd

from bayescal.reports.page import HTML_FILE, JSON_FILE, MARKDOWN_FILE, Page, format_value, generic, plain


def test_a_table_shows_the_same_numbers_in_html_markdown_and_json():
    page = Page("T")
    page.heading("fit", "Fit")
    frame = pd.DataFrame({"mean": [1.234567, math.nan]}, index=pd.Index(["k2", "k3"], name="parameter"))
    page.table("parameters", frame, caption="a | b")
    page.close()
    files = page.files()
    numbers = json.loads(files[JSON_FILE])
    assert numbers["fit"]["parameters"] == {"k2": {"mean": 1.234567}, "k3": {"mean": None}}
    html, markdown = files[HTML_FILE].decode(), files[MARKDOWN_FILE].decode()
    assert "<td class=num>1.235</td>" in html and "| k2 | 1.235 |" in markdown
    assert "| k3 | – |" in markdown
    assert "a \\| b" not in markdown and "*a | b*" in markdown


def test_values_are_written_for_people_and_for_json():
    assert format_value(np.float64(0.000123456)) == "0.0001235"
    assert format_value(True) == "yes" and format_value(None) == "–" and format_value(3) == "3"
    assert plain({"x": np.float32(2.0), "y": [math.inf, np.int64(3)]}) == {"x": 2.0, "y": [None, 3]}


def test_generic_lays_out_unknown_json_as_tables_and_lists():
    page = Page("T")
    page.heading("plan", "Plan")
    generic(page, {"criterion": 1.5, "rows": [{"q2_deg": -10.0}, {"q2_deg": -20.0}], "notes": ["a", "b"]})
    numbers = json.loads(page.files()[JSON_FILE])["plan"]
    assert numbers["values"] == {"criterion": 1.5}
    assert numbers["rows"] == {"0": {"q2_deg": -10.0}, "1": {"q2_deg": -20.0}}
    assert numbers["notes"] == ["a", "b"]


def test_terms_get_a_hover_title_once_per_element_and_the_page_ends_with_those_it_used():
    from bayescal.reports.terms import TERMS

    page = Page("T")
    page.heading("fit", "Fit")
    page.paragraph("R-hat 1.004 and R-hat again; χ²/dof 0.97; condition numbers are not a term")
    page.glossary()
    document = page.files()[HTML_FILE].decode()
    assert document.count("<abbr title=") == 2  # R-hat once, χ²/dof once
    assert '<abbr title="' + TERMS["R-hat"] in document
    assert "<dt>R-hat</dt>" in document and "<dt>χ²/dof</dt>" in document and "<dt>ΔELPD</dt>" not in document
    assert "**R-hat**" in page.files()[MARKDOWN_FILE].decode()


def test_generic_shows_keys_in_words_and_keeps_them_in_the_json():
    page = Page("T")
    page.heading("critique", "C")
    generic(page, {"evidence": {"tilt": {"delta_elpd": 13.7, "se": 3.0}}})
    assert "<th>ΔELPD [nats]</th>" in re.sub(r"<abbr[^>]*>|</abbr>", "", page.files()[HTML_FILE].decode())
    assert json.loads(page.files()[JSON_FILE])["critique"]["evidence"] == {"tilt": {"delta_elpd": 13.7, "se": 3.0}}
