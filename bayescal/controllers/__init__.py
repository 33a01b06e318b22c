"""What the robot's controller and the tools around it take: KUKA KRL and ABB RAPID programs, a calibrated URDF.

:mod:`~bayescal.controllers.program` states what a program reader returns and what its writer keeps;
:mod:`~bayescal.controllers.krl` and :mod:`~bayescal.controllers.rapid` read and write the languages,
:mod:`~bayescal.controllers.poses` and :mod:`~bayescal.controllers.configuration` hold their
conventions, :mod:`~bayescal.controllers.compensate` compensates a program's targets, and
:mod:`~bayescal.controllers.urdf` writes and reads the cell's URDF with a calibration in it.
"""
