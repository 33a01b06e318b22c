"""The calibration cell and the files it exchanges.

Owns the cell TOML (``config``: robot, stiffness, compensator, tool, tracker, test
pose), the laser tracker's noise model (``tracker``), the plan CSV (``plan``) and the
campaign CSV, the exchange format of measured data (``campaign``).
"""
