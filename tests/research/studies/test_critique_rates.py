from concurrent.futures import ThreadPoolExecutor

import pytest

from bayescal.critique.extensions import CATALOGUE
from bayescal_studies.studies.critique_rates import GENERATORS, SET_ON, judged, confusion, critique_rates, markdown_rates, rates
from bayescal.twin.beams import EFFECTS as BEAMS_EFFECTS
from bayescal.twin.effects import EFFECTS as TWIN_EFFECTS


def test_every_effect_of_each_generator_has_a_right_verdict():
    assert set(GENERATORS["beams"].expected) == set(BEAMS_EFFECTS)
    assert set(GENERATORS["twin"].expected) == set(TWIN_EFFECTS) | {"none", "drift"}
    for generator in GENERATORS.values():
        assert set(generator.expected.values()) <= set(CATALOGUE) | {"adequate", "unexplained"}
    assert set(SET_ON) == set(GENERATORS)
    # the same generator on its arm made rigid: every effect but the one that softens the beams it no longer has
    assert GENERATORS["beams_rigid"].expected == {k: v for k, v in GENERATORS["beams"].expected.items() if k != "link_compliance"}


def test_the_independent_generators_right_verdicts_are_its_effects_causes():
    from bayescal_studies.studies.independent_detection import INDEPENDENT_EFFECTS
    from bayescal.twin.independent import EFFECTS

    expected = dict(GENERATORS["independent"].expected)
    assert expected.pop("none") == "adequate"
    assert expected == {name: EFFECTS[name].cause or "unexplained" for name in INDEPENDENT_EFFECTS}


def test_a_tie_is_right_but_not_alone_and_a_lone_wrong_cause_is_wrong():
    tied = judged(["outliers", "backlash"], {"outliers": ["backlash"]}, {}, "backlash")
    assert (tied["first"], tied["partners"], tied["right"], tied["alone"], tied["wrong_single"]) == ("outliers", "backlash", True, False, False)
    alone = judged(["backlash", "unexplained"], {}, {}, "backlash")
    assert alone["alone"] and alone["right"] and not alone["wrong_single"]
    wrong = judged(["unexplained"], {}, {}, "backlash")
    assert wrong["wrong_single"] and not wrong["right"]
    false_alarm = judged(["outliers"], {}, {}, "adequate")
    assert false_alarm["wrong_single"] and false_alarm["first"] == "outliers"
    assert judged([], {}, {}, "adequate")["alone"]
    assert not judged(["link_compliance", "unexplained"], {}, {}, "unexplained")["alone"]


def test_the_harness_runs_the_third_generator_with_and_without_nests(data_dir):
    with ThreadPoolExecutor(1) as executor:
        table = critique_rates(data_dir / "kr270.toml", data_dir / "table3_plan.csv", "beams", ("none", "drift"),
                               nests=(False, True), seeds=(3,), executor=executor)
    assert len(table) == 4
    expected = dict(zip(zip(table.effect, table.nests), table.expected))
    # with nests the drift is measured and removed before the critique: nothing is left to name
    assert expected == {("none", False): "adequate", ("drift", False): "drift", ("none", True): "adequate", ("drift", True): "adequate"}
    summary = rates(table)
    assert len(summary) == 4 and (summary["n"] == 1).all()
    assert {"alone", "alone_se", "right", "right_se", "wrong_single", "wrong_single_se", "adequate", "adequate_se"} <= set(summary)
    assert confusion(table)["campaigns"].sum() == 4
    assert markdown_rates(table).count("\n| beams |") == 4


def test_an_unknown_generator_or_effect_is_refused(data_dir):
    with pytest.raises(ValueError, match="unknown generator"):
        critique_rates(data_dir / "kr270.toml", data_dir / "table3_plan.csv", "nowhere", ("none",))
    with pytest.raises(ValueError, match="gear_play"):
        critique_rates(data_dir / "kr270.toml", data_dir / "table3_plan.csv", "beams", ("gear_play",))


@pytest.mark.slow
def test_on_the_third_generator_the_compliances_and_outliers_meet_the_bounds(data_dir):
    # Seeds 0-9 of the rates in docs/critique.md: the cases of the third generator where the bounds hold there
    # (nothing planted is not one: its arm's own beams are a misfit the repeats show, see docs/critique.md).
    effects = ("none", "link_compliance", "tool_compliance", "outliers")
    with ThreadPoolExecutor(2) as executor:
        table = critique_rates(data_dir / "kr270.toml", data_dir / "table3_plan.csv", "beams", effects, seeds=range(10), executor=executor)
    summary = rates(table).set_index("effect")
    assert list(summary.index) == list(effects) and (summary["n"] == 10).all()
    assert summary.loc["outliers", "alone"] >= 0.8
    for effect in effects[1:]:
        assert summary.loc[effect, "right"] >= 0.95 and summary.loc[effect, "wrong_single"] <= 0.05
    # on the arm without a planted effect its own misfits are named only as its beams and its tool mount's hinge are
    # (where the repeats show them and such a candidate leaves the repeats fitted) or called unexplained
    assert set(table.loc[table.effect == "none", "first"]) <= {"adequate", "unexplained", "link_compliance", "tool_compliance"}


def test_play_the_model_misses_in_whole_states_is_no_gross_tracker_error(data_dir):
    # The independent generator's approach_play campaign of seed 9000 named backlash contested by outliers when the
    # Student-t tail was per equation; every marker of a state shares the misfit, so it is the arm's (docs/critique.md).
    with ThreadPoolExecutor(1) as executor:
        table = critique_rates(data_dir / "kr270.toml", data_dir / "table3_plan.csv", "independent", ("approach_play",),
                               seeds=[9000], executor=executor)
    assert table["first"].tolist() == ["backlash"] and table["alone"].all()
    assert "outliers" not in table["causes"].iloc[0]


@pytest.mark.slow
def test_on_the_independent_generator_lost_motion_is_first_and_alone(data_dir):
    # Seeds 9000-9019 of the rates in docs/critique.md, where the rule that a heavy tail every marker of a state shares
    # is the arm's was judged: with the variants integrated out of the held-out score (A variant chosen on the scores
    # that judge it), gear_play alone in 18 of 20 and right in 20, approach_play alone in 16 and right in 19 (seed 9001
    # unexplained).  At a true rate of 90 %, 20 campaigns fall below 15 in 1 % of runs.
    with ThreadPoolExecutor(2) as executor:
        table = critique_rates(data_dir / "kr270.toml", data_dir / "table3_plan.csv", "independent",
                               ("gear_play", "approach_play"), seeds=range(9000, 9020), executor=executor)
    summary = rates(table).set_index("effect")
    assert (summary["alone"] >= 0.75).all() and (summary["right"] >= 0.95).all() and (summary["wrong_single"] <= 0.05).all()


@pytest.mark.slow
def test_the_repeats_name_the_twins_link_compliance_and_no_cause_for_a_misfit_of_no_candidates_shape(data_dir):
    # docs/critique.md, Named by the repeats: the twin's link compliance right in 40 of 40 (36 before, 4 unexplained),
    # the independent generator's random field unexplained alone in 40 of 40 as before (seeds 9000-9009 here).
    with ThreadPoolExecutor(2) as executor:
        twin = critique_rates(data_dir / "kr270.toml", data_dir / "table3_plan.csv", "twin", ("link_compliance",),
                              seeds=range(40), executor=executor)
        field = critique_rates(data_dir / "kr270.toml", data_dir / "table3_plan.csv", "independent", ("random_field",),
                               seeds=range(9000, 9010), executor=executor)
    assert rates(twin)["right"].iloc[0] >= 0.95 and rates(twin)["wrong_single"].iloc[0] <= 0.05
    assert (field["causes"] == "unexplained").all()


@pytest.mark.slow
def test_a_drift_repeats_back_to_back_show_is_named_first_and_alone(data_dir):
    # docs/critique.md, The drift's column from a steady rate: the independent generator's thermal drift first and
    # alone in 35 of 40 (14 with the walk alone), never a wrong cause; the twin's drift, a walk about a steady rate, no
    # less often right at twice its default than at it (4 and 15 of 40).  At a true rate of 87.5 %, 40 campaigns fall
    # below 30 in 1 % of runs.
    with ThreadPoolExecutor(2) as executor:
        thermal = critique_rates(data_dir / "kr270.toml", data_dir / "table3_plan.csv", "independent",
                                 ("thermal_drift",), seeds=range(9000, 9040), executor=executor)
        twin = critique_rates(data_dir / "kr270.toml", data_dir / "table3_plan.csv", "twin", ("drift",),
                              multiples=[1, 2], seeds=range(40), executor=executor)
    assert rates(thermal)["alone"].iloc[0] >= 0.75 and rates(thermal)["wrong_single"].iloc[0] == 0.0
    by_multiple = rates(twin).set_index("multiple")["right"]
    assert by_multiple[2] >= by_multiple[1] > 0.0


@pytest.mark.slow
def test_on_the_third_generators_rigid_arm_nothing_planted_is_adequate(data_dir):
    # The false-alarm rate, measured where no rule was set: 100 campaigns of the third generator on its arm with the
    # beams made rigid (docs/critique.md).  At a true rate of 95 %, 100 campaigns fall below 91 in 3 % of runs.
    with ThreadPoolExecutor(2) as executor:
        table = critique_rates(data_dir / "kr270.toml", data_dir / "table3_plan.csv", "beams_rigid", ("none",),
                               seeds=range(100), executor=executor)
    assert rates(table)["adequate"].iloc[0] >= 0.91


def test_each_generators_campaigns_are_read_with_the_tool_weight_it_simulates(cell):
    from dataclasses import replace

    from bayescal_studies.studies.critique_rates import weighed_cell

    beams = weighed_cell(cell, GENERATORS["beams"], "lost_motion")
    assert beams.robot.tool_mass == 38.0 and beams.robot.tool_centre == pytest.approx([0.17, 0.0, 0.09])
    assert weighed_cell(cell, GENERATORS["independent"], "tool_mount").robot.tool_mass == 30.0
    assert weighed_cell(cell, GENERATORS["independent"], "gear_play") is cell and weighed_cell(cell, GENERATORS["twin"], "backlash") is cell
    with pytest.raises(ValueError, match="weighs a tool already"):
        weighed_cell(replace(cell, robot=cell.robot.with_tool(5.0, [0.1, 0.0, 0.0])), GENERATORS["beams"], "none")
