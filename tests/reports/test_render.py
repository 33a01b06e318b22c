import numpy as np
from matplotlib.figure import Figure

from bayescal import forked
from bayescal.reports import render


def _figures(n):
    figures = {}
    for k in range(n):
        figure = Figure(figsize=(3, 2), layout="constrained")
        figure.add_subplot().plot(np.arange(10), np.arange(10) ** (1 + k / 4), label=f"figure {k}")
        figures[f"f{k}.png"] = figure
    return figures


def test_the_figures_drawn_in_worker_processes_are_those_drawn_one_after_another(monkeypatch):
    figures = _figures(4)
    alone = {name: render.png(figure) for name, figure in figures.items()}
    monkeypatch.setattr(render, "available_cores", lambda: 2)
    monkeypatch.setattr(forked, "_single_threaded", lambda: True)
    shared = render.png_files(figures)
    assert list(shared) == list(figures) and shared == alone
    assert len(set(shared.values())) == 4 and all(png.startswith(b"\x89PNG") for png in shared.values())
    assert forked._FORKED == []
