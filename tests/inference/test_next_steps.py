"""The calibration's next step follows from its results, in order: convergence, lack of fit, identifiability, use."""

from bayescal.inference.next_steps import calibration_next_steps, critique_next_steps

FIT = {"model": "exact", "lack_of_fit": {"p_value": 0.4, "factor": 1.1}}


def test_an_unconverged_posterior_asks_for_more_draws_before_anything_else():
    text = calibration_next_steps({"model": "linear", "lack_of_fit": {"p_value": 1e-9, "factor": 9.0}}, ["k1"], 0.05, False)
    assert "--draws" in text and "do not use" in text and "critique" not in text


def test_lack_of_fit_sends_to_the_critique_and_the_other_model():
    text = calibration_next_steps({"model": "linear", "lack_of_fit": {"p_value": 1e-6, "factor": 3.2}}, [], 0.05, True)
    assert "bayescal critique" in text and "--model exact" in text and "3.2 times" in text and "do not compensate" in text


def test_a_good_fit_names_what_is_not_identified_and_the_error_to_compare_with_the_tolerance():
    text = calibration_next_steps(FIT, ["K_c", "k1"], 0.0431, True)
    assert "K_c, k1 cannot be told" in text and "bayescal plan" in text and "43.1 μm (99.73 % at the test pose, everything counted)" in text and "bayescal compensate" in text
    # a parameter no campaign of the cell can identify is not sent to a new plan
    text = calibration_next_steps(FIT, ["K_c", "k1", "s0"], 0.0431, True, cell_limited=["k1"])
    assert "K_c, s0 cannot be told" in text and "k1 keeps the config's value, its prior in the error bounds: no campaign of this cell" in text
    assert calibration_next_steps(FIT | {"lack_of_fit": None}, [], None, True).startswith("Next: the fit is consistent")


def test_the_critique_s_next_step_follows_its_verdict_causes_and_repeats():
    assert "classical model is enough" in critique_next_steps([], False, 0.002)
    assert "no cause of the catalogue" in critique_next_steps([], True, 0.002)
    assert "no cause of the catalogue" in critique_next_steps(["unexplained"], True, 0.002)
    text = critique_next_steps(["outliers", "unexplained"], True, 0.0123)
    assert "misses outliers (" in text and "12 μm" in text and "tolerance" in text


def test_a_cause_too_small_to_matter_is_said_so_and_sends_no_one_to_re_measure():
    text = critique_next_steps(["compensator"], False, 0.0022, negligible=["compensator"])
    assert "too small to matter" in text and "2 μm" in text and "do not re-measure" in text
    # one cause that matters beside it: the usual advice
    assert "misses compensator, backlash" in critique_next_steps(["compensator", "backlash"], False, 0.05, negligible=["compensator"])
