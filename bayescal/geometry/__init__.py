"""Compensator geometry from laser-tracker arcs (Klimchik et al., section IV, eqs 10-29).

Owns the marker-point files, the closed-form arc fits (``arcs``), classical circle
fits and their Cramér-Rao bounds (``circle``), and the Bayesian geometry posterior
(``posterior``).
"""
