"""The benchmark's charts (tools/bench/charts.py) as the levels show them: a log axis's tick labels never run
into each other ("100k10M" on a narrow panel, issue 42 item 9)."""
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from tools.bench import charts  # noqa: E402


def narrow_axes(width_inches):
    fig = plt.figure(figsize=(width_inches, 2.0), dpi=100)
    return fig, fig.add_axes([0.25, 0.25, 0.65, 0.6])


def test_a_narrow_log_axis_drops_ticks_until_its_labels_part():
    fig, ax = narrow_axes(1.6)
    # What log_axis labelled before: every other decade of 1k to 1G, which touch at this width.
    ax.set_xscale("log")
    ax.set_xticks([1e3, 1e5, 1e7, 1e9], ["1k", "100k", "10M", "1G"])
    assert charts.labels_overlap(ax, "x")
    charts.log_axis(ax, "x", [1e3, 1e9])
    labels = [t.get_text() for t in ax.get_xticklabels() if t.get_text()]
    assert len(labels) >= 2 and not charts.labels_overlap(ax, "x"), labels
    plt.close(fig)


def test_a_wide_log_axis_keeps_its_ticks():
    fig, ax = narrow_axes(8.0)
    charts.log_axis(ax, "x", [1e3, 1e9])
    assert [t.get_text() for t in ax.get_xticklabels()] == ["1k", "100k", "10M", "1G"]
    plt.close(fig)
