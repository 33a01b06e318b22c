"""The robot as a mechanism: Pinocchio kinematics, the spring compensator and the VJM stiffness.

Owns the URDF robot (``kinematics``), the spring compensator on one joint, joint 2 on the KR-270 (``compensator``,
eqs 4-9 and 35) and the static equilibrium and stiffness of the arm with gravity
(``stiffness``, eqs 1-3 and 8).  Everything here is SI and knows nothing of files.
"""
