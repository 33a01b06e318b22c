"""Design of calibration experiments (Klimchik et al., section V.C, eqs 36-41).

``criteria`` scores a plan before it is measured (the eq-37 information, the
test-pose error of eqs 38-40, the compensator's identifiability, D-optimality),
``prediction`` what a plan's information matrix predicts (``PlanPrediction``),
``linearisation`` the exact model's designs (``ExactLinearisation``),
``constraints`` says which configurations a campaign can use, and ``optimise``
finds the best plan (``PlanDesigner``).
"""
