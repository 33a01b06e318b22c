"""bayescal: probabilistic identification of heavy industrial robots.

Geometric identification of a spring gravity compensator, elastostatic
identification of joint and compensator stiffness with honest posteriors, a
digital twin that simulates laser-tracker calibration campaigns, and the
propagation of the identified parameters to the positioning error at a test pose.
"""

from .errors import InputError

__all__ = ["InputError", "__version__"]

__version__ = "0.1.0"
