"""Reports: Markdown and figures generated from the code and the data.

``geometry``, ``twin`` and ``elastostatic`` each regenerate one report under the
repository's ``reports/``; ``plots`` draws their figures.
"""
