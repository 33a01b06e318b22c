"""The review's sections for the JSON files it is given: numbers rounded to their own uncertainty, the JSON kept whole."""

import numpy as np

from bayescal.registration.register import RegistrationFindings
from bayescal.reports.page import Page
from bayescal.reports.review_files import registration_section

REGISTRATION = {
    "axes": {
        "1": {
            "direction": [-0.05033038, 0.06217209, -0.99679561],
            "direction_sd_mrad": 0.0830449,
            "point_mm": [-1850.879969, -3092.621475, -99.437866],
            "point_sd_mm": 0.2279402,
            "rms_mm": 0.0524656,
            "chi2": 88.5,
            "dof": 68,
            "reflectors": [{"marker": "R1", "height_mm": -1711.648446, "radius_mm": 1754.009724, "phase_deg": -2.7595788,
                            "rms_mm": 0.0520726, "z_rms": 1.0523758}],
        }
    },
    "frames": {"base": {"rotation": np.eye(3).tolist(), "rotation_sd_mrad": [0.0344, 0.1089, 0.0962],
                        "translation_mm": [-1850.880279, -3092.619527, -99.442312], "translation_sd_mm": [0.1958, 0.0457, 0.0543]}},
}


def _rows(page: Page, caption_start: str) -> list[list[str]]:
    lines = page.markdown[next(i for i, line in enumerate(page.markdown) if line.startswith(f"*{caption_start}")) + 4:]
    return [[cell.strip() for cell in line.strip("|").split("|")] for line in lines[: lines.index("")]]


def test_the_registration_rounds_each_coordinate_to_its_own_sd_and_keeps_the_numbers_in_the_json():
    page = Page("T")
    registration_section(page, RegistrationFindings.from_json(REGISTRATION), "reg.json")
    axis = _rows(page, "Joint axes")[0]
    # direction to 0.083 mrad (6 decimals), point to 0.23 mm (2 decimals), rms to 1 μm, χ²/dof to 0.01
    assert axis == ["1", "-0.050330", "0.062172", "-0.996796", "0.083", "-1850.88", "-3092.62", "-99.44", "0.23", "0.052", "1.30"]
    base = _rows(page, "The robot's frames")[0]
    assert base[7:] == ["-1850.88", "-3092.620", "-99.442", "0.20", "0.046", "0.054"]
    reflector = _rows(page, "Arc residuals")[0]
    assert reflector[2:] == ["-1711.648", "1754.010", "-2.760", "0.052", "1.05"]
    assert page.numbers["registration"]["axes"]["1"]["x (mm)"] == -1850.879969


def test_the_registration_shows_each_axis_s_student_t_interval_and_degrees_of_freedom():
    axis = {**REGISTRATION["axes"]["1"], "direction_dof": 3.4, "point_dof": 2.9,
            "half_width": {"direction_mrad": {"3": 0.6531}, "point_mm": {"3": 2.2427}}}
    page = Page("T")
    registration_section(page, RegistrationFindings.from_json({**REGISTRATION, "axes": {"1": axis}}), "reg.json")
    row = _rows(page, "Joint axes")[0]
    # ±3σ half-widths to the digits of their sds (0.083 mrad, 0.23 mm), the smaller degrees of freedom to 0.1.
    assert row[9:12] == ["0.653", "2.24", "2.9"]


def test_the_critique_says_its_ties_contests_and_explained_rivals_in_words():
    from bayescal.critique.results import CritiqueFindings
    from bayescal.reports.review_files import critique_section

    comparison = {"delta_elpd": 3.1, "se": 4.2, "n_configs": 15}
    critique = CritiqueFindings.from_json({
        "verdict": "misfit", "causes": ["backlash"], "evidence": {}, "gain": {},
        "tied_with": {"backlash": ["nonlinear_stiffness"]}, "contested_by": {"backlash": ["outliers"]},
        "explains": {"backlash": {"compensator": {"rival_added": comparison, "cause_added": comparison | {"delta_elpd": 40.5}}}},
    })
    page = Page("review")
    critique_section(page, critique, "tie.csv")
    text = "\n".join(page.markdown)
    assert "backlash is tied with nonlinear_stiffness: this campaign cannot tell them apart" in text
    assert "--criterion discriminate --between backlash,nonlinear_stiffness --campaign tie.csv" in text
    # outliers is a noise model, not a deflection: no plan separates it
    assert "backlash is contested by outliers: its held-out lead" in text and "--between backlash,outliers" not in text
    assert "backlash explains compensator: compensator adds 3.1 ± 4.2 nats on top of it, backlash 40.5 ± 4.2 on top of compensator" in text
    assert '"tied_with"' not in text and '"explains"' not in text  # in words, not as JSON
    assert page.numbers["critique"]["explains"]["backlash"]["compensator"]["cause_added"]["delta_elpd"] == 40.5


def test_the_critique_says_in_words_which_heavy_tail_is_the_arms_and_not_the_trackers():
    from bayescal.critique.results import CritiqueFindings
    from bayescal.reports.review_files import critique_section

    critique = CritiqueFindings.from_json({
        "verdict": "misfit", "causes": ["backlash", "unexplained"], "evidence": {}, "gain": {},
        "shared_by_state": {"outliers": {"delta_elpd": 71.8, "se": 16.1, "n_configs": 30, "meaning": "..."}},
    })
    page = Page("review")
    critique_section(page, critique, "play.csv")
    text = "\n".join(page.markdown)
    assert "outliers not named: its heavy tail is shared by every marker of a state, 71.8 ± 16.1 nats better" in text
    assert '"shared_by_state"' not in text
    assert page.numbers["critique"]["shared_by_state"]["outliers"]["delta_elpd"] == 71.8


def test_the_critique_says_in_words_which_cause_the_repeats_named_as_the_command_does():
    from bayescal.critique.document import by_repeats_sentence
    from bayescal.critique.results import CritiqueFindings
    from bayescal.reports.review_files import critique_section

    critique = CritiqueFindings.from_json({
        "verdict": "misfit", "causes": ["link_compliance"], "gain": {},
        "evidence": {"link_compliance": {"delta_elpd": 20.9, "se": 11.2, "n_configs": 15, "step": 1, "named": True}},
        "by_repeats": {"link_compliance": {"lack_of_fit": {"p_value": 0.0073}, "lack_of_fit_with_it": {"p_value": 0.37}, "meaning": "..."}},
        "rule": {"delta_elpd_over_se": 2.0, "floor_nats": 4.0, "decisive_nats": 25.0, "decisive_over_se": 1.0, "by_repeats_over_se": 1.0},
    })
    page = Page("review")
    critique_section(page, critique, "links.csv")
    text = "\n".join(page.markdown)
    assert by_repeats_sentence("link_compliance", 20.9, 11.2, 0.0073, 0.37) in text
    assert "link_compliance named by the repeats: without it the model misses them (lack of fit p = 0.0073)" in text
    assert "where the repeats show a misfit no cause passes for, > 1 SE and > 4 nats if the repeats are then fitted" in text
    assert '"by_repeats"' not in text
    assert page.numbers["critique"]["by_repeats"]["link_compliance"]["lack_of_fit_with_it"]["p_value"] == 0.37
