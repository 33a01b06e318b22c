import numpy as np
import pandas as pd
from matplotlib.colors import to_rgba

from bayescal.reports.figures import AXIS_COLOURS, plot_error_distribution, plot_evidence, plot_pairs, plot_rank, plot_residuals


def visible_axes(figure):
    return [ax for ax in figure.axes if ax.get_visible()]


def test_rank_plot_is_flat_for_mixed_chains_and_piled_up_for_a_stuck_one():
    rng = np.random.default_rng(0)
    mixed = rng.normal(size=(4, 2000))
    stuck = mixed.copy()
    stuck[0] += 3.0  # one chain elsewhere: its ranks pile up at the top
    figure = plot_rank({"mixed [mm]": mixed, "stuck [mm]": stuck})
    axes = visible_axes(figure)
    assert [ax.get_title() for ax in axes] == ["mixed [mm]", "stuck [mm]"]
    assert all(ax.get_xlabel() and ax.get_ylabel() for ax in axes)
    heights = [np.concatenate([patch.get_data().values for patch in ax.patches]) for ax in axes]
    assert np.all(np.abs(heights[0] - 1) < 0.5)
    assert heights[1].max() > 3.5


def test_pair_plot_labels_the_outer_axes_and_shows_the_correlation():
    rng = np.random.default_rng(1)
    x = rng.normal(size=5000)
    figure = plot_pairs({"a [mm]": x, "b [mm]": x + 0.1 * rng.normal(size=5000)}, reference={"a [mm]": 0.0}, reference_label="Table II")
    axes = visible_axes(figure)
    assert len(axes) == 3
    texts = [text.get_text() for ax in axes for text in ax.texts]
    assert texts == ["ρ = +1.00"]
    assert {ax.get_xlabel() for ax in axes} >= {"a [mm]", "b [mm]"}
    assert [text.get_text() for legend in figure.legends for text in legend.get_texts()] == ["Table II"]


def test_residual_plot_draws_each_axis_in_its_colour():
    table = pd.DataFrame({"q2_deg": [-100.0, -50.0], "residual_x_um": [1.0, -1.0], "residual_y_um": [2.0, 0.0], "residual_z_um": [0.0, 3.0]})
    figure = plot_residuals(table, {"q2_deg": "q2 [deg]"}, noise_um=[10.0, 12.0])
    ax = visible_axes(figure)[0]
    assert ax.get_xlabel() == "q2 [deg]" and ax.get_ylabel() == "residual [μm]"
    colours = {line.get_label(): line.get_color() for line in ax.lines}
    assert all(colours[f"{axis} residual"] == colour for axis, colour in AXIS_COLOURS.items())


def test_error_distribution_and_evidence_mark_what_they_claim():
    figure = plot_error_distribution(np.abs(np.random.default_rng(2).normal(size=500)), rms_um=1.0, q95_um=2.0, q9973_um=3.0)
    labels = figure.axes[0].get_legend_handles_labels()[1]
    assert any("99.73 % quantile: 3.0 μm" in label for label in labels)
    figure = plot_evidence(["clear", "unclear"], [6.0, 1.0], [1.0, 1.0])
    colours = [patch.get_facecolor() for patch in figure.axes[0].patches]
    assert colours[0] == to_rgba("C2") and colours[1] == to_rgba("0.5")


def test_rank_plot_draws_what_stairs_draws():
    # The chains' step patches are added with their limits set once: the same limits, colours and pixels as ax.stairs()'s.
    import io

    from matplotlib.figure import Figure

    draws = np.random.default_rng(2).normal(size=(12, 300))
    figure = plot_rank({"x [mm]": draws}, columns=1)
    ranks = np.argsort(np.argsort(draws, axis=None)).reshape(draws.shape)
    edges = np.linspace(0, draws.size, 21)
    reference = Figure(figsize=figure.get_size_inches(), layout="constrained")
    ax = reference.add_subplot()
    for chain in range(draws.shape[0]):
        ax.stairs(np.histogram(ranks[chain], bins=edges)[0] / (draws.shape[1] / 20), edges / draws.size, baseline=None, lw=1.0,
                  label=f"chain {chain + 1}")
    ax.axhline(1.0, color="0.5", lw=0.8, ls="--")
    ax.set_title("x [mm]", fontsize=9)
    ax.set_xlabel("rank quantile [-]", fontsize=8)
    ax.set_ylabel("count / uniform [-]", fontsize=8)
    ax.set_ylim(0, None)
    ax.tick_params(labelsize=7)
    reference.legend(*ax.get_legend_handles_labels(), loc="outside upper center", ncols=8, fontsize=8)
    drawn = figure.axes[0]
    assert drawn.get_xlim() == ax.get_xlim() and drawn.get_ylim() == ax.get_ylim()
    assert [patch.get_edgecolor() for patch in drawn.patches] == [patch.get_edgecolor() for patch in ax.patches]
    images = []
    for each in (figure, reference):
        buffer = io.BytesIO()
        each.savefig(buffer, format="png", dpi=60)
        images.append(buffer.getvalue())
    assert images[0] == images[1]
