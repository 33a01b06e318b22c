"""Tests of bayescal/design/discriminate.py, separation.py and discriminating_search.py: plans that separate two candidates of the critique."""

from __future__ import annotations

import numpy as np
import pytest

from bayescal.design.constraints import load_design_space
from bayescal.design.discriminate import DiscriminatingDesigner
from bayescal.design.discriminating_search import RANKED_OUTRIGHT, _Exchange
from bayescal.design.separation import expected_z, ranked_fits, ranked_separation, separation, separation_bound, shares
from bayescal.design.optimise import PlanDesigner
from bayescal.errors import InputError


def test_separation_is_zero_for_a_rival_that_spans_the_candidate_and_half_the_residual_norm_otherwise():
    rng = np.random.default_rng(0)
    base, a = rng.normal(size=(40, 2)), rng.normal(size=(40, 1))
    b_same = np.column_stack([a[:, 0] * 2.0 + base[:, 0]])
    Z = np.hstack([base, a, b_same])
    blocks = (slice(0, 2), slice(2, 3), slice(3, 4))
    nats = separation(Z.T @ Z, blocks, np.array([1.5]), np.array([0.5]))
    assert nats == pytest.approx([0.0, 0.0], abs=1e-6)
    b_other = rng.normal(size=(40, 1))
    Z = np.hstack([base, a, b_other])
    nats = separation(Z.T @ Z, blocks, np.array([1.5]), np.array([0.5]))
    rival = np.hstack([base, b_other])
    residual = 1.5 * a[:, 0] - rival @ np.linalg.lstsq(rival, 1.5 * a[:, 0], rcond=None)[0]
    assert nats[0] == pytest.approx(0.5 * residual @ residual, rel=1e-6)


def test_the_configurations_shares_add_up_to_the_separation():
    rng = np.random.default_rng(1)
    per = np.array([Z.T @ Z for Z in rng.normal(size=(6, 8, 4))])
    blocks = (slice(0, 2), slice(2, 3), slice(3, 4))
    beta = (np.array([0.7]), np.array([-1.2]))
    assert 0.5 * shares(per, blocks, *beta).sum(axis=-1) == pytest.approx(separation(per.sum(axis=0), blocks, *beta), rel=1e-9)


RANKED_AGREEMENT = 1e-13
"""Relative difference allowed between the separations a search ranks by and those it keeps: the sums of ``vᵀ M v`` in
another order (measured: at most 4.4e-15 on 1,000 random plans of the discriminating search's 24 columns)."""


def test_the_ranked_separations_are_the_separations_to_rounding():
    rng = np.random.default_rng(2)
    Z = rng.normal(size=(200, 30, 24))
    information = np.swapaxes(Z, 1, 2) @ Z
    blocks = (slice(0, 6), slice(6, 18), slice(18, 24))
    for scale in (1.0, 1e3):
        beta = (rng.normal(size=12) * scale, rng.normal(size=6))
        kept, ranked = separation(information, blocks, *beta), ranked_separation(information, blocks, *beta)
        assert np.all(kept > 1.0)
        np.testing.assert_allclose(ranked, kept, rtol=RANKED_AGREEMENT, atol=0)


def _plans(rng, count, rows, columns=24):
    """(count, columns, columns) the information of ``count`` random plans of ``rows`` rows each."""
    Z = rng.normal(size=(count, rows, columns))
    return np.swapaxes(Z, 1, 2) @ Z


@pytest.mark.parametrize("collinear", [False, True])
def test_the_bound_is_above_the_separation_of_every_plan_one_configuration_larger_and_tight_where_the_fit_stays(collinear):
    rng = np.random.default_rng(3)
    blocks = (slice(0, 6), slice(6, 18), slice(18, 24))
    beta = (rng.normal(size=12), rng.normal(size=6))
    partial, added = _plans(rng, 300, 40), _plans(rng, 300, 6)
    if collinear:
        # two of the rival's columns in proportion: its fit along their difference is the ridge's
        partial[:, 23, :] = partial[:, 22, :] * (1 + 1e-7)
        partial[:, :, 23] = partial[:, :, 22] * (1 + 1e-7)
        partial[:, 23, 23] = partial[:, 22, 22] * (1 + 1e-7) ** 2
    larger = partial + added
    # the bound from the partial plans' own fits, and from fits of other plans (as a search's last step leaves them)
    for fits in (ranked_fits(partial, blocks, *beta)[1], ranked_fits(partial[::-1], blocks, *beta)[1]):
        constant, weights = separation_bound(partial, fits, blocks)
        bound = 0.5 * np.maximum(constant + np.einsum("ktij,kij->kt", weights, added), 0.0)
        assert np.all(bound >= ranked_separation(larger, blocks, *beta) * (1 - 1e-12))
        assert np.all(bound >= separation(larger, blocks, *beta) * (1 - 1e-12))
    # a configuration that moves no column of A's rival leaves its fit where it was: the bound from that fit is the
    # separation, and the ridge's penalty
    constant, weights = separation_bound(partial, ranked_fits(partial, blocks, *beta)[1], blocks)
    own = np.zeros_like(added)
    own[:, blocks[1], blocks[1]] = added[:, blocks[1], blocks[1]]
    bound = 0.5 * np.maximum(constant + np.einsum("ktij,kij->kt", weights, own), 0.0)
    np.testing.assert_allclose(bound[:, 0], separation(partial + own, blocks, *beta)[:, 0], rtol=1e-7)


def test_the_search_takes_the_option_ranking_every_one_would_and_the_first_of_a_tie():
    rng = np.random.default_rng(4)
    blocks = (slice(0, 6), slice(6, 18), slice(18, 24))
    beta = (rng.normal(size=12), rng.normal(size=6))
    angles, per = 4, 40
    information = _plans(rng, angles * per, 6)
    group = np.repeat(np.arange(angles), per)
    pools = [np.flatnonzero(group == g) for g in range(angles)]
    assert angles * per > RANKED_OUTRIGHT
    partials = np.array([information[rng.choice(len(information), 30, replace=False)].sum(axis=0) for _ in range(angles)])
    options, owner = np.concatenate(pools), np.repeat(np.arange(angles), per)

    def every(information):
        ranked = ranked_separation(partials[owner] + information[options], blocks, *beta).min(axis=-1).reshape(angles, per)
        return [int(pool[np.argmax(row)]) for pool, row in zip(pools, ranked)], ranked.max(axis=1).tolist()

    best, _ = every(information)
    # the first angle's best option copied to its first option: a tie ranking every option resolves to the first
    assert best[0] != pools[0][0]
    information[pools[0][0]] = information[best[0]]
    expected, values = every(information)
    assert expected[0] == pools[0][0]
    search = _Exchange(information, group, np.tile([1.0, -1.0], angles * per // 2), np.arange(angles, dtype=float), 0.0, blocks, beta, rng)
    chosen, ranked, _ = search._best(partials, list(range(angles)), pools)
    assert chosen == expected and ranked == values


def test_a_move_fills_only_the_angles_that_could_beat_the_plan_and_finds_the_move_filling_every_one_finds():
    rng = np.random.default_rng(5)
    blocks = (slice(0, 6), slice(6, 18), slice(18, 24))
    beta = (rng.normal(size=12), rng.normal(size=6))
    angles, per, size = 8, 12, 4
    information = _plans(rng, angles * per, 6)
    group = np.repeat(np.arange(angles), per)
    search = _Exchange(information, group, np.tile([1.0, -1.0], angles * per // 2), np.arange(angles, dtype=float), 0.0, blocks, beta, rng)
    # group 0 to move, the six others a plan of 24 configurations
    chosen_angles = list(range(7))
    groups = [list(range(a * per, a * per + size)) for a in chosen_angles]
    others = list(range(1, angles))
    every = search._greedy_fills(others, size, [o for members in groups[1:] for o in members])
    # a plan better than half the fills: the move is the best of the others, the first of equals
    current = float(np.median([score for _, score in every]))
    better = [(angle, members, score) for angle, (members, score) in zip(others, every) if score > current * (1 + 1e-9)]
    expected = max(better, key=lambda move: move[2])
    assert search._move(groups, chosen_angles, 0, current) == expected
    (_, fills), = search._filled.values()
    assert len(fills) < len(others)


def test_a_separation_in_one_configuration_is_expected_within_its_own_standard_error_and_the_same_spread_far_clear_of_it():
    k, total = 15, 60.0
    spread = np.full(k, total / k)
    alone = np.zeros(k)
    alone[0] = total
    z_spread, z_alone = (expected_z(lam / 2, lam) for lam in (spread, alone))
    # spread evenly: Λ/2 over sqrt(Λ); in one configuration the SE is about the difference itself
    assert z_spread == pytest.approx(total / 2 / np.sqrt(total))
    assert z_alone < 1.0 < 2.0 < z_spread


def test_the_plan_separates_a_tied_pair_far_better_than_the_tied_campaign(cell, twin_campaign):
    # an eighth of the twin's default lost motion on Table III, where nonlinear stiffness explains it about as well
    tied = twin_campaign(("backlash=0.002",), seed=0)
    space = load_design_space(cell, mass_range=(50.0, 280.0))
    design = DiscriminatingDesigner(cell, ("backlash", "nonlinear_stiffness"), tied, space).optimise(5, 3, 0, starts=1, candidates_per_angle=2)
    assert len(design.plan) == 15 and len(np.unique(np.round(design.plan.q[:, 1], 6))) == 5
    assert design.planned.worst > 3 * design.campaign.worst, design.to_json()
    # and its held-out comparison is expected clear of 2 SE, further from it than the tied campaign's
    assert min(design.planned.z) > max(2.0, min(design.campaign.z)), design.to_json()
    assert np.all((design.plan.load_kg >= 50.0) & (design.plan.load_kg <= 280.0))
    assert PlanDesigner(cell, space, model="linear").violations(design.plan) == []
    payload = design.to_json()
    assert payload["between"] == ["backlash", "nonlinear_stiffness"] and payload["planned"]["worst_nats"] == pytest.approx(design.planned.worst, abs=1e-3)
    # the separation counts on the order of measurement, which the plan's user must keep
    assert "order written" in payload["order"] and "joint 2" in payload["order"]


def test_a_groups_slots_alternate_the_plan_joints_side_from_positive_and_take_either_where_one_side_runs_out():
    group = np.array([0, 0, 0, 0, 1, 1])
    side = np.array([-1.0, 1.0, -1.0, 1.0, 1.0, 1.0])
    search = _Exchange(np.zeros((6, 1, 1)), group, side, np.array([0.0, 1.0]), 0.0, (), (), np.random.default_rng(0))
    assert list(search._slot_pool(0, 0, [])) == [1, 3] and list(search._slot_pool(0, 1, [])) == [0, 2]
    assert list(search._slot_pool(0, 2, [1])) == [3]
    # a group whose loads all take the joint one way fills the other side's slots from it
    assert list(search._slot_pool(1, 1, [4])) == [5]


@pytest.mark.parametrize("between", [("backlash", "backlash"), ("backlash", "outliers"), ("backlash",)])
def test_a_pair_that_is_not_two_different_physical_candidates_is_an_input_error(cell, twin_campaign, between):
    with pytest.raises(InputError):
        DiscriminatingDesigner(cell, between, twin_campaign((), seed=0))


def test_each_option_is_scored_at_its_own_configuration(cell, twin_campaign, monkeypatch):
    # option o is candidate o // MASS_LEVELS at mass level o % MASS_LEVELS: its rows must carry that candidate's joints
    import bayescal.design.discriminate as discriminate

    seen, real = {}, discriminate.pose_rows

    def spy(cell, q, wrench, point, config=None):
        seen["q"], seen["option"] = q, config
        return real(cell, q, wrench, point, config=config)

    monkeypatch.setattr(discriminate, "pose_rows", spy)
    tied = twin_campaign(("backlash=0.002",), seed=0)
    space = load_design_space(cell, mass_range=(50.0, 280.0))
    DiscriminatingDesigner(cell, ("backlash", "nonlinear_stiffness"), tied, space).optimise(5, 3, 0, starts=1, candidates_per_angle=2)
    option, q = seen["option"], seen["q"]
    first = q[np.searchsorted(option, np.unique(option))].reshape(-1, discriminate.MASS_LEVELS, q.shape[1])
    assert np.all(first == first[:, :1])
    assert len(np.unique(first[:, 0], axis=0)) == len(first)
