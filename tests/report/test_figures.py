"""The figures, one function per paper figure: labels that carry their own power of ten, no
text drawn over other text, the detail window of long records, and the demo's Figs. 2–5 with
the run they show, units on every axis and the truth explained."""

from __future__ import annotations

from itertools import combinations
from pathlib import Path

import numpy as np
import pytest

from femupdate.report.canvas import png_bytes, tick_labels
from femupdate.report.figures import (
    DETAIL_SAMPLES,
    DETAIL_SECONDS,
    MAX_FIT_CHANNELS,
    detail_window,
    plot_beta,
    plot_fit,
    plot_parameters,
    plot_phi,
)
from femupdate.report.plots import plot_correlation, plot_spectra, plot_spread


def draw(fig) -> None:
    """Draw as the report does (ticks formatted, layout final), with a canvas to query."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    FigureCanvasAgg(fig)
    png_bytes(fig)


def texts(fig) -> list[tuple[str, object]]:
    """(owner, window extent) of every visible, non-empty text of a drawn figure: titles,
    labels, tick labels, legends (matplotlib has no public list of them: private attributes)."""
    renderer = fig.canvas.get_renderer()
    found = []
    for owner, text in [("suptitle", fig._suptitle), ("supxlabel", fig._supxlabel),
                        ("supylabel", fig._supylabel)]:
        if text is not None and text.get_text():
            found.append((owner, text.get_window_extent(renderer)))
    found += [(f"legend {i}", legend.get_window_extent(renderer))
              for i, legend in enumerate(fig.legends)]
    for i, ax in enumerate(fig.axes):
        if not ax.get_visible():
            continue
        for title in (ax.title, ax._left_title, ax._right_title):
            if title.get_text():
                found.append((f"axes {i} title", title.get_window_extent(renderer)))
        for axis in (ax.xaxis, ax.yaxis):
            if axis.label.get_text():
                found.append((f"axes {i} label", axis.label.get_window_extent(renderer)))
            # The ticks drawn: inside the view, their labels switched on.
            found += [(f"axes {i} ticks", label.get_window_extent(renderer))
                      for tick in axis._update_ticks() for label in (tick.label1, tick.label2)
                      if label.get_visible() and label.get_text()]
    return found


def overlaps(fig) -> list[str]:
    """Pairs of texts drawn over each other (tick labels of one axis may touch)."""
    draw(fig)
    clashes = []
    for (a, box_a), (b, box_b) in combinations(texts(fig), 2):
        if a == b and a.endswith("ticks"):
            continue
        # Boxes that only touch (a pixel of padding) do not count.
        if box_a.padded(-1.0).overlaps(box_b.padded(-1.0)):
            clashes.append(f"{a} over {b}")
    return clashes


def offset_texts(fig) -> list[str]:
    """The offset texts (``1e11`` at the end of an axis) of a drawn figure."""
    return [ax.xaxis.get_offset_text().get_text() + ax.yaxis.get_offset_text().get_text()
            for ax in fig.axes if (ax.xaxis.get_offset_text().get_text()
                                   or ax.yaxis.get_offset_text().get_text())]


def record(n: int = 2400, rate: float = 120.0, scale: float = 1e-5, k: int = 2
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    t = np.arange(n) / rate
    envelope = np.exp(-0.5 * ((t - 0.6 * t[-1]) / 1.0) ** 2)
    measured = scale * np.column_stack([envelope * np.sin(2 * np.pi * (3 + j) * t)
                                        for j in range(k)])
    return t, measured, 0.9 * measured


# ----------------------------------------------------------------------------- tick labels


@pytest.mark.parametrize(("locs", "labels"), [
    ([0.0, 2.5e-5, 5e-5], ["0", "2.5e−5", "5.0e−5"]),
    ([2.1e11, 2.15e11, 2.2e11], ["2.10e11", "2.15e11", "2.20e11"]),
    ([-1.0, -0.5, 0.0, 0.5], ["−1.0", "−0.5", "0", "0.5"]),
    ([1.0001, 1.0002], ["1.0001", "1.0002"]),
    ([0.0, 1000.0, 2000.0], ["0", "1000", "2000"]),
])
def test_tick_labels_carry_their_power_of_ten(locs: list[float], labels: list[str]) -> None:
    assert tick_labels(locs) == labels


def test_no_offset_text_over_the_titles() -> None:
    t, measured, predicted = record(scale=1e-5)
    fit = plot_fit(t, measured + 2.1e11, predicted + 2.1e11, channels=["a", "b"], unit="N",
                   title="huge and offset")
    assert overlaps(fit) == []
    assert offset_texts(fit) == []
    labels = [label.get_text() for label in fit.axes[0].get_yticklabels()]
    assert any("e11" in label for label in labels), labels
    # The check can fail: matplotlib's own formatter would write "1e11" above the axis.
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    plain = Figure()
    plain.add_subplot().plot(t, measured[:, 0] + 2.1e11)
    FigureCanvasAgg(plain).draw()
    assert plain.axes[0].yaxis.get_offset_text().get_text()


# ----------------------------------------------------------------------------- layout


def example_figure(name: str):
    """Each figure of the report, drawn from made-up data of the usual shapes."""
    rng = np.random.default_rng(0)
    names = ["k1", "k2", "c1", "c2"]
    fun = np.abs(rng.normal(size=300)) * np.logspace(0, -8, 300)
    if name == "phi":
        return plot_phi([fun, fun * 2], labels=["run 0", "run 1"], highlight=0, title="φ")
    if name == "beta":
        walk = np.exp(rng.normal(size=(300, 4)).cumsum(0) * 0.1)
        return plot_beta({"a": walk, "b": walk[::-1], "sigma": np.logspace(-0.5, -2, 300)},
                         names, title="run 0")
    if name == "parameters":
        return plot_parameters(rng.uniform(1e3, 5e3, (300, 4)), fun, names, units=["N/m"] * 4,
                               truth=[2e3] * 4, title="run 0")
    if name == "fit":
        t, measured, predicted = record(k=3)
        return plot_fit(t, measured, predicted, channels=["F1", "F2", "F3"], unit="m",
                        nmse_percent=[1.0, 2.0, 3.0], title="best run")
    if name == "spectra":
        return plot_spectra(np.linspace(0, 60, 200), np.abs(rng.normal(size=(200, 3))),
                            np.abs(rng.normal(size=(200, 3))), labels=["a", "b", "c"],
                            marks=[5.0, 12.0], truth_marks=[5.1, 12.2], title="spectra")
    if name == "spread":
        return plot_spread(rng.uniform(size=(5, 4)), names,
                           success=np.array([1, 1, 1, 0, 1], bool), truth=np.full(4, 0.5))
    return plot_correlation(np.eye(4), names)


@pytest.mark.parametrize("name", ["phi", "beta", "parameters", "fit", "spectra", "spread",
                                  "correlation"])
def test_the_figures_draw_no_text_over_text(name: str) -> None:
    fig = example_figure(name)
    assert overlaps(fig) == []
    assert offset_texts(fig) == []


def test_the_overlap_check_sees_a_clash() -> None:
    from matplotlib.figure import Figure

    fig = Figure(figsize=(3, 2))
    for _ in range(2):  # two axes on top of each other: their titles clash
        fig.add_axes((0.2, 0.2, 0.6, 0.6)).set_title("a title")
    assert "axes 0 title over axes 1 title" in overlaps(fig)


def test_many_parameters_share_one_panel() -> None:
    rng = np.random.default_rng(1)
    n = 200
    x = rng.uniform(0.0, 1.0, (20, n))
    fig = plot_parameters(x, rng.uniform(size=20), [f"p{i}" for i in range(n)],
                          bounds=[(0.0, 1.0)] * n, truth=[0.5] * n)
    assert len(fig.axes) == 1
    assert "all 200" in fig.axes[0].get_title()
    unbounded = plot_parameters(x, rng.uniform(size=20), [f"p{i}" for i in range(n)])
    assert len(unbounded.axes) == 1
    beta = plot_beta({"a": 1 + x, "b": 2 + x}, [f"p{i}" for i in range(n)])
    assert all(len(ax.lines) <= 1 for ax in beta.axes)  # one collection, not 200 lines
    assert beta.axes[0].get_legend() is None


# ----------------------------------------------------------------------------- the fit


def test_detail_window_of_a_long_record() -> None:
    t, measured, _ = record(n=2400, rate=120.0)  # 20 s: the peak at 12 s
    start, end = detail_window(t, measured)
    assert end - start == pytest.approx(DETAIL_SECONDS)
    assert start < 0.6 * t[-1] < end
    t_fast, fast, _ = record(n=4760, rate=1035.0)
    start, end = detail_window(t_fast, fast)
    assert end - start == pytest.approx(DETAIL_SAMPLES / 1035.0)
    assert detail_window(*record(n=501, rate=100.0)[:2]) is None
    # A peak at the very start: the window stays inside the record.
    early = np.zeros(2400)
    early[3] = 1.0
    start, end = detail_window(t, early)
    assert start == t[0] and end == pytest.approx(t[0] + DETAIL_SECONDS)


def test_fit_draws_residuals_and_a_detail_column() -> None:
    t, measured, predicted = record(n=2400, k=2)
    fig = plot_fit(t, measured, predicted, channels=["F1", "F2"], unit="m")
    assert len(fig.axes) == 8  # (signal, residual) × (whole, detail) × 2 channels
    residuals = [ax for ax in fig.axes if ax.get_ylabel() == "residual [m]"]
    assert len(residuals) == 4
    np.testing.assert_allclose(residuals[0].lines[0].get_ydata(),
                               measured[:, 0] - predicted[:, 0])
    details = [ax for ax in fig.axes if ax.get_title(loc="left").startswith("detail")]
    assert len(details) == 2 and details[0].get_xlim()[1] - details[0].get_xlim()[0] <= 2.5
    short = plot_fit(*record(n=500, k=1), channels=["y"], unit="−")
    assert len(short.axes) == 2


def test_fit_draws_at_most_the_first_channels() -> None:
    t, measured, predicted = record(n=300, k=MAX_FIT_CHANNELS + 4)
    fig = plot_fit(t, measured, predicted, channels=[f"c{j}" for j in range(10)], unit="m")
    assert len(fig.axes) == 2 * MAX_FIT_CHANNELS
    assert f"first {MAX_FIT_CHANNELS} of 10 channels" in fig._suptitle.get_text()


# ----------------------------------------------------------------------------- the demo


def test_demo_figures_say_which_run_with_units_and_the_truth(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from femupdate.paper.bench.dynamic import run_with_history
    from femupdate.report import dynamic

    drawn = {}

    def keep(fig, path: Path) -> Path:
        drawn[path.name] = fig
        return path

    monkeypatch.setattr(dynamic, "save_png", keep)
    outcome = run_with_history("ab", seed=0, run_index=1, max_evals=400)
    paths = dynamic.dynamic_figures(outcome, tmp_path, "ab")
    assert [p.name for p in paths] == ["fig2_phi_ab.png", "fig3_beta_ab.png",
                                       "fig4_parameters_ab.png", "fig5_response_ab.png"]
    for name, fig in drawn.items():
        title = fig._suptitle.get_text() if fig._suptitle else fig.axes[0].get_title()
        assert "AB, run 1 (root seed 0)" in title, name
        for ax in fig.axes:
            if not ax.get_visible():
                continue
            assert ax.get_ylabel().endswith("]") or "[" in ax.get_ylabel(), (name, ax)
            # Every axis that shows its x values says what they are (a shared one may not).
            shows_x = any(tick.label1.get_visible() for tick in ax.xaxis.get_major_ticks())
            has_x = ax.get_xlabel() or (fig._supxlabel and fig._supxlabel.get_text())
            assert has_x or not shows_x, (name, ax.get_ylabel())
        assert overlaps(fig) == [], name
        assert offset_texts(fig) == [], name
    fig4 = drawn["fig4_parameters_ab.png"]
    assert [ax.get_ylabel() for ax in fig4.axes] == [
        "ω1 [rad/s]", "ζ1 [−]", "A1 [−]", "θ1 [rad]", "ω2 [rad/s]", "ζ2 [−]", "A2 [−]",
        "θ2 [rad]"]
    legend = [t.get_text() for t in fig4.legends[0].get_texts()]
    assert legend == ["best so far", "truth"]
    fig5 = drawn["fig5_response_ab.png"]
    assert [ax.get_ylabel() for ax in fig5.axes] == ["y [−]", "residual [−]"]
    assert fig5.axes[1].get_xlabel() == "time [s]"
