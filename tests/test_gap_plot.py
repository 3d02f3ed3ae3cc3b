"""GapReport.plot draws what it says: the gap, one family of shares per axis, the placebos."""

import numpy as np
import pandas as pd
import pytest

from greyml import make_test_index
from greyml.gap import diagnose_gap

plt = pytest.importorskip("matplotlib.pyplot")


@pytest.fixture(scope="module")
def report():
    # three tests whose probe drifts by 0.5 µm/h, which the simulation lacks
    t = np.arange(120) * 60.0
    index = make_test_index(tests=np.repeat(["A", "B", "C"], 120), times=np.tile(t, 3))
    sim = pd.DataFrame({"dz_um": np.tile(5 * (1 - np.exp(-t / 3600)), 3)}, index=index)
    noise = 0.01 * np.random.default_rng(0).standard_normal(360)
    real = sim.assign(dz_um=sim["dz_um"] + 0.5 * np.tile(t, 3) / 3600 + noise)
    return diagnose_gap(real, sim, target="dz_um", random_state=0)


def test_four_panels_each_labelled_for_what_it_draws(report):
    fig = report.plot()
    try:
        ax_time, ax_first, ax_band, ax_rank = fig.axes[:4]
        labels = [
            line.get_label() for line in ax_time.get_lines() if not line.get_label().startswith("_")
        ]
        assert labels == [
            "gap: measured − simulated",
            "left after the named effects (held-out tests)",
        ]
        # the raw gap is drawn as the gap, not as a held-out one
        assert "held-out gap" not in ax_time.get_title()
        assert ax_time.get_ylabel() == "dz_um (µm)"
        # the first line of the time panel is the gap itself, test A first
        gap_a = report.gap.xs("A", level="test").to_numpy()
        np.testing.assert_allclose(ax_time.get_lines()[0].get_ydata(), gap_a)
        # one family per axis: without drivers there are no phases, so the time since
        # the start; each family's shares sum to 1 on its own axis
        where = report.where
        for ax, by in ((ax_first, "time"), (ax_band, "band")):
            widths = [bar.get_width() for bar in ax.patches]
            assert sum(widths) == pytest.approx(1.0)
            assert sorted(widths) == pytest.approx(sorted(where.loc[where["by"] == by, "share"]))
        assert "time since start" in ax_first.get_title()
        assert "period" in ax_band.get_title()
    finally:
        plt.close(fig)


def test_the_effects_panel_draws_each_steps_best_placebo(report):
    fig = report.plot()
    try:
        ax_rank = fig.axes[3]
        ranked = report.causes.dropna(subset=["shrinkage"])
        (markers,) = ax_rank.collections
        # each bar's placebo at the bar's height, best effect on top
        np.testing.assert_allclose(
            markers.get_offsets()[:, 0], ranked["placebo_shrinkage"].to_numpy()[::-1]
        )
        assert [tick.get_text() for tick in ax_rank.get_yticklabels()] == list(
            ranked["effect"][::-1]
        )
        shrinkage = [bar.get_width() for bar in ax_rank.patches]
        assert shrinkage == pytest.approx(list(ranked["shrinkage"][::-1]))
        assert "placebo" in ax_rank.get_legend().get_texts()[0].get_text()
    finally:
        plt.close(fig)


def test_axes_of_the_wrong_number_are_refused(report):
    fig, axes = plt.subplots(1, 3)
    try:
        with pytest.raises(ValueError, match=r"^GapReport.plot: axes must hold 4 Axes .*got 3\.$"):
            report.plot(axes=axes)
    finally:
        plt.close(fig)
