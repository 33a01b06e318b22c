"""The calibration review: its files, its numbers, its optional sections, and the page as Chromium shows it."""

import html
import json
import re
import shutil
import subprocess
import warnings
from pathlib import Path

import pandas as pd
import pytest

from bayescal.cell.campaign import read_campaign
from bayescal.cli import main
from bayescal.inference.elastostatic import restore_results
from bayescal.inference.priors import posterior_geometry
from bayescal.numbers import rounded_pair
from bayescal.reports.page import Page
from bayescal.reports.review import HTML_FILE, JSON_FILE, MARKDOWN_FILE, ReviewInputs, render_review
from bayescal.reports.review_parameters import _weak_table
from bayescal.reports.terms import TERMS
from bayescal.sampling.summary import load

FIXTURES = Path(__file__).resolve().parent / "data"

CHROMIUM_TIMEOUT = 90
"""Seconds allowed to Chromium to load the page: it starts in 2-4 s on an idle machine."""

PROBE = """<script>
window.__errors = [];
window.addEventListener('error', e => window.__errors.push(e.message || ('failed to load ' + (e.target.src || e.target.href))), true);
const consoleError = console.error;
console.error = (...args) => { window.__errors.push(args.join(' ')); consoleError(...args); };
window.addEventListener('load', () => {
  const images = Array.from(document.images).map(i => {
    const box = i.getBoundingClientRect();
    return {src: i.getAttribute('src'), natural: i.naturalWidth, width: box.width, height: box.height};
  });
  const pre = document.createElement('pre');
  pre.id = '__probe';
  pre.textContent = JSON.stringify({images: images, errors: window.__errors});
  document.body.appendChild(pre);
});
</script>"""
"""Injected into a copy of the page: records every error and each figure's loaded and displayed size."""


@pytest.fixture(scope="module")
def report(short_calibration, tmp_path_factory):
    """A full report folder from the short calibration, with every optional file."""
    folder = tmp_path_factory.mktemp("review") / "short"
    argv = ["report", "-o", str(folder)]
    for option in ("geometry", "calibration", "campaign", "config"):
        argv += [f"--{option}", str(short_calibration[option])]
    argv += ["--plan", str(FIXTURES / "plan.json"), "--critique", str(FIXTURES / "critique.json"), "--study", str(FIXTURES / "study.csv")]
    assert main(argv) == 0
    return folder


def _chromium() -> str:
    """The Chromium command; the checks that need it are skipped where it is not installed (a test installs nothing)."""
    found = shutil.which("chromium") or shutil.which("chromium-browser")
    if not found:
        pytest.skip("headless Chromium is not installed (on Debian: apt-get install chromium)")
    return found


def test_report_writes_page_summary_numbers_and_every_figure(report):
    page = (report / HTML_FILE).read_text()
    figures = sorted(path.name for path in report.glob("*.png"))
    assert figures and all(f'src="{name}"' in page for name in figures)
    summary = (report / MARKDOWN_FILE).read_text()
    assert all(f"]({name})" in summary for name in figures)
    numbers = json.loads((report / JSON_FILE).read_text())
    sections = ["overview", "parameters", "identifiability", "test_pose", "geometry", "compensator", "data", "residuals",
                "critique", "convergence", "pairs", "plan", "study"]
    assert list(numbers) == sections
    assert all(f'id="{section}"' in page for section in sections)


def test_numbers_are_those_of_the_posteriors(report, short_calibration, cell):
    numbers = json.loads((report / JSON_FILE).read_text())
    campaign = read_campaign(short_calibration["campaign"], cell=cell)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        results = restore_results(cell, campaign, load(short_calibration["calibration"]), posterior_geometry(short_calibration["geometry"]))
    shown = numbers["parameters"]["parameters"]
    for name, value in results.parameters().items():
        if "mean" in value:
            assert shown[name]["mean"] == pytest.approx(value["mean"], rel=1e-12)
            assert shown[name]["±3σ"] == pytest.approx(value["hi3"] - value["mean"], rel=1e-12)
            # an interval reaching below zero is flagged, one that does not is not
            assert bool(shown[name]["lower end"]) == (value["lo3"] < 0)
        else:
            assert shown[name]["mean"] is None and shown[name]["identifiable"] is False
    assert shown["k4"]["Table IV"] == 3.002
    assert set(numbers["identifiability"]["not_identifiable"]) == set(results.identifiability.not_identifiable) - {
        n for n in results.identifiability.not_identifiable if n.startswith("k2_q2[")
    }
    geometry = load(short_calibration["geometry"])["posterior"]
    assert numbers["geometry"]["parameters"]["L"]["mean"] == pytest.approx(float(geometry["L"].mean()), rel=1e-12)
    assert numbers["data"]["counts"]["rows"]["value"] == len(campaign)
    # The short chains have not converged, and the page says so.
    assert "NOT converged" in (report / HTML_FILE).read_text()


def test_optional_files_are_rendered_known_keys_and_unknown_ones(report):
    numbers = json.loads((report / JSON_FILE).read_text())
    assert numbers["critique"]["verdict"] == "adequate"
    assert numbers["critique"]["evidence"]["nonlinear_stiffness"]["delta_elpd"] == 6.5
    assert numbers["critique"]["gain.rho0_mm.values"] == {"before": 0.041, "after": 0.039}
    assert numbers["critique"]["gain.values"] == {"held_out_rows": 45}
    assert numbers["plan"]["criterion"] == 0.00697
    assert numbers["plan"]["parameters"]["k2"]["width_3sd_pct"] == 1.04
    assert numbers["plan"]["parameters"]["k1"]["width_3sd"] is None
    assert numbers["plan"]["violations"]["0"]["reason"] == "the hanging load would touch the floor"
    assert numbers["study"]["table"]["2"]["angles"] == 4
    assert numbers["study"]["table"]["2"]["K_c_width_3sd_pct"] == pytest.approx(298.3866237879191)
    assert numbers["study"]["table"]["0"]["k1_width_3sd_pct"] is None  # an empty cell: not excited
    page = (report / HTML_FILE).read_text()
    assert "hand-written fixture" in page and "critique_evidence.png" in page
    # the criterion in μm, in words; the JSON's keys in words on the page
    text = _text(page)
    assert "predicted ρ0 = 6.97 μm rms" in text and "the linear model of eq 31 predicts 6.42 μm rms" in text
    assert "ΔELPD [nats]" in text and "delta_elpd" not in page and "rho0_mm" not in page


def _text(page: str) -> str:
    """The page's words as a reader sees them: tags dropped, entities read."""
    return html.unescape(re.sub(r"<[^>]+>", "", page))


def test_tables_are_rounded_to_their_uncertainty_and_every_term_has_its_words(report):
    numbers = json.loads((report / JSON_FILE).read_text())
    page = (report / HTML_FILE).read_text()
    text = _text(page)
    for name, row in numbers["parameters"]["parameters"].items():
        if row["mean"] is not None:
            mean, half = rounded_pair(row["mean"], row["±3σ"])
            assert f"<td>{name}</td><td class=num>{mean}</td><td class=num>{half}</td>" in re.sub(r"<abbr[^>]*>|</abbr>", "", page)
    error = numbers["test_pose"]["residual_error_um"]
    assert f"{error['q99.73']['everything counted [μm]']:.1f}" in text and f"{error['q99.73']['identified parameters only [μm]']:.1f}" in text
    # every glossary term the page shows has a hover title and a line in the closing glossary
    used = [term for term in TERMS if term in text.rsplit("Words used on this page", 1)[0]]
    assert {"R-hat", "bulk ESS", "tail ESS", "χ²/dof", "rank", "condition number", "ΔELPD", "nats", "SE", "ρ0"} <= set(used)
    for term in used:
        assert f'<abbr title="{html.escape(TERMS[term], quote=True)}">{html.escape(term)}</abbr>' in page
        assert f"<dt>{html.escape(term)}</dt>" in page
    assert "glossary" not in numbers  # words, no numbers


def test_an_interval_below_zero_is_cut_at_zero_with_the_reason():
    summary = pd.DataFrame(
        {"mean": [116.0, 3.0], "sd": [102.0, 0.01], "lo3": [-190.0, 2.97], "hi3": [422.0, 3.03], "unit": ["N/mm", "mm"]},
        index=["K_c", "s0"],
    )
    page = Page("T")
    page.heading("identifiability", "I")
    _weak_table(page, summary)
    files = page.files()
    html_text = files[HTML_FILE].decode()
    assert "0 (cut: cannot be negative)" in html_text and "-190" not in html_text
    assert json.loads(files[JSON_FILE])["identifiability"]["weakly_determined"]["K_c"]["lower end"] == -190.0


def test_sections_appear_only_for_what_was_given(short_calibration):
    files = render_review(ReviewInputs(sources={"geometry posterior": "g.nc"}, geometry=load(short_calibration["geometry"])))
    numbers = json.loads(files[JSON_FILE])
    assert list(numbers) == ["overview", "geometry", "convergence"]
    assert sorted(name for name in files if name.endswith(".png")) == ["geometry_pairs.png", "rank_geometry.png"]
    from bayescal.critique.results import CritiqueFindings

    critique = CritiqueFindings.from_json({"verdict": "misfit", "causes": [], "evidence": {}, "gain": {}, "something_new": {"a": 1}})
    critique_only = render_review(ReviewInputs(critique=critique))
    numbers = json.loads(critique_only[JSON_FILE])
    assert list(numbers) == ["overview", "critique"] and numbers["critique"]["something_new.values"] == {"a": 1}


def _probe(report: Path, tmp_path: Path, *, remove: tuple[str, ...] = ()) -> dict:
    """Load a copy of the report (less the files ``remove``) in headless Chromium and return what the probe recorded."""
    chromium = _chromium()
    probe = tmp_path / "probe"
    shutil.copytree(report, probe)
    for name in remove:
        (probe / name).unlink()
    page = probe / HTML_FILE
    page.write_text(page.read_text().replace("<head>", "<head>\n" + PROBE, 1))
    command = [
        chromium, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
        "--disable-background-networking", "--disable-component-update", "--disable-sync",
        f"--user-data-dir={tmp_path / 'profile'}", "--window-size=1280,2400", "--virtual-time-budget=10000",
        "--dump-dom", page.as_uri(),
    ]  # fmt: skip
    result = subprocess.run(command, capture_output=True, text=True, timeout=CHROMIUM_TIMEOUT)
    assert result.returncode == 0, result.stderr[-500:]
    start = result.stdout.index('<pre id="__probe">') + len('<pre id="__probe">')
    return json.loads(html.unescape(result.stdout[start : result.stdout.index("</pre>", start)]))


def test_page_loads_in_chromium_without_errors_and_shows_every_figure(report, tmp_path):
    probed = _probe(report, tmp_path)
    assert probed["errors"] == []
    expected = sorted(path.name for path in report.glob("*.png"))
    assert sorted(image["src"] for image in probed["images"]) == expected
    for image in probed["images"]:
        assert image["natural"] > 0 and image["width"] > 0 and image["height"] > 0, image


def test_a_missing_figure_is_caught_by_the_chromium_check(report, tmp_path):
    """The check above can fail: a figure removed from the folder shows as an error and a figure of no size."""
    probed = _probe(report, tmp_path, remove=("eta.png",))
    assert any("eta.png" in error for error in probed["errors"])
    assert [image["natural"] for image in probed["images"] if image["src"] == "eta.png"] == [0]


def test_a_points_cells_ladder_is_shown_as_its_own_section(tmp_path):
    from bayescal.kinematics.ladder import LadderFindings
    from bayescal.reports.review import ReviewInputs, render_review

    rungs = pd.DataFrame(
        [{"model": name, "mean_mm": mean, "sd_mm": 1.0, "max_mm": 9.0, "in_sample_mean_mm": mean - 0.2, "elpd": -1000.0 + i,
          "elpd_se": 20.0, "coverage_95": 0.94, "model_error_sd_mm": 1.0} for i, (name, mean) in enumerate([("frames", 16.03), ("full", 3.40)])]
    ).set_index("model")
    without = pd.DataFrame([{"without": "k_theta", "mean_mm": 3.67, "elpd_loss": 40.0, "elpd_loss_se": 9.0}]).set_index("without")
    steps = [{"from": "frames", "to": "full", "adds": ["theta"], "elpd_gain": 900.0, "elpd_gain_se": 30.0, "error_change_mm": -12.6, "named": True}]
    ladder = LadderFindings.from_json(json.loads(json.dumps(LadderFindings(rungs, steps, without, 10, "verdict: the data call for full").to_json())))
    files = render_review(ReviewInputs(sources={"critique": "ladder.json"}, ladder=ladder))
    text = files["summary.md"].decode()
    assert "Model ladder on measured points" in text and "16.03" in text and "21.33 / 9.71 / 63.41" in text
    assert "frames → full" in text and "9.09" in text and "Critique of the model" not in text


def test_the_review_does_not_import_scipy_stats():
    # scipy.stats was 0.46 s of the demo's 4.6 s review, loaded only for the model ladder's LADDER_KIND.
    import sys

    code = "import sys, bayescal.reports.review; print('scipy.stats' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "False"
