"""bayescal: probabilistic identification of heavy industrial robots.

Geometric identification of a spring gravity compensator, elastostatic
identification of joint and compensator stiffness with honest posteriors, a
digital twin that simulates laser-tracker calibration campaigns, and the
propagation of the identified parameters to the positioning error at a test pose.

The names below are the entry points; each lives in the subpackage of its concern
(see docs/architecture.md) and is imported on first use, so that
``import bayescal`` stays light.
"""

from importlib import import_module

__version__ = "0.1.0"

_ENTRY_POINTS = {
    "InputError": "errors",
    "Compensator": "robot.compensator",
    "read_arc_points": "geometry.arcs",
    "CompensatorGeometryModel": "geometry.arcs",
    "GeometryPosteriorModel": "geometry.posterior",
    "load_cell": "cell.config",
    "read_plan": "cell.plan",
    "DigitalTwin": "twin.simulator",
    "read_campaign": "cell.campaign",
    "ElastostaticModel": "inference.elastostatic",
    "predict_test_pose": "compensation.testpose",
    "predict_cell_test_pose": "compensation.testpose",
    "PlanDesigner": "design.optimise",
}

__all__ = [*_ENTRY_POINTS, "__version__"]


def __getattr__(name: str):
    if name in _ENTRY_POINTS:
        return getattr(import_module(f".{_ENTRY_POINTS[name]}", __name__), name)
    raise AttributeError(f"module 'bayescal' has no attribute '{name}'")
