"""A saved kinematic calibration read back: the whole result for a cell, or the joint corrections alone.

:func:`load_kinematic_calibration` rebuilds what :meth:`KinematicResults.save
<bayescal.kinematics.results.KinematicResults.save>` or
:meth:`~bayescal.kinematics.elastic.ElasticKinematicResults.save` wrote; the
file says which.  It sits above both result kinds, so that neither imports the other's reader.
:func:`read_joint_corrections` reads the joint placements alone, for a cell without the points.
"""

from __future__ import annotations

from os import PathLike
from pathlib import Path

import numpy as np

from bayescal.errors import InputError
from bayescal.kinematics.cell import PointsCell
from bayescal.kinematics.elastic import ElasticKinematicResults, elastic_results_from_dataset
from bayescal.kinematics.model import PointModel
from bayescal.kinematics.results import KIND, KinematicResults, results_from_dataset
from bayescal.output import record_read

__all__ = ["load_kinematic_calibration", "read_joint_corrections"]


def load_kinematic_calibration(path: str | PathLike[str], cell: PointsCell) -> KinematicResults | ElasticKinematicResults:
    """Read a calibration written by :meth:`KinematicResults.save` for ``cell``.

    A calibration on top of an elastostatic one (:meth:`~bayescal.kinematics.elastic.ElasticKinematicResults.save`)
    is read as :class:`~bayescal.kinematics.elastic.ElasticKinematicResults`.

    Raises
    ------
    InputError
        A file that is not such a calibration, or one whose parameters are not the cell's.
    """
    source, dataset = str(path), _read_dataset(path)
    if "elastic_cell" in dataset.attrs:
        return elastic_results_from_dataset(dataset, cell, source)
    without = tuple(x for x in str(dataset.attrs.get("without", "")).split(",") if x)
    return results_from_dataset(dataset, PointModel(cell, str(dataset.attrs["rung"]), without=without), source)


def _read_dataset(path: str | PathLike[str]):
    """The ``xarray.Dataset`` a kinematic calibration file holds; an :class:`InputError` naming ``path`` otherwise."""
    import xarray as xr

    source = str(path)
    record_read(path, "the kinematic calibration")
    if not Path(path).is_file():
        what = "is a folder" if Path(path).is_dir() else "file not found"
        raise InputError(f"{what}; expected a kinematic calibration (NetCDF from `bayescal kinematics -o`)", source=source)
    try:
        with xr.open_dataset(path, engine="netcdf4") as opened:
            dataset = opened.load()
    except (OSError, ValueError) as exc:
        raise InputError(f"cannot read a kinematic calibration (NetCDF from `bayescal kinematics -o`): {exc}", source=source) from None
    if dataset.attrs.get("kind") != KIND:
        raise InputError("not a kinematic calibration (expected a file from `bayescal kinematics -o`)", source=source)
    return dataset


def read_joint_corrections(path: str | PathLike[str], joint_names: tuple[str, ...]) -> tuple[np.ndarray, tuple[str, ...]]:
    """Each joint's placement correction a saved kinematic calibration identified, for a robot with ``joint_names``.

    The corrections are the posterior means of the ``<joint>.<tx..rz>`` parameters, in the frame where the joint's
    axis is z (:func:`~bayescal.kinematics.axes.axis_frame`), as
    :meth:`~bayescal.kinematics.elastic.ElasticKinematicResults.corrections` gives them; a component the
    calibration's rung leaves out, or a joint it does not correct, is 0.  Read from the file's parameter names alone,
    it needs neither the points cell nor the elastostatic cell the calibration was made with.

    Parameters
    ----------
    path
        A file :meth:`KinematicResults.save` or :meth:`ElasticKinematicResults.save` wrote.
    joint_names
        ``(nq,)`` the robot's chain joints, in order.

    Returns
    -------
    corrections : numpy.ndarray
        ``(nq, 6)`` ``(tx, ty, tz, rx, ry, rz)`` per joint (m, rad).
    corrected : tuple of str
        The joints the file corrects, in the robot's order.

    Raises
    ------
    InputError
        Not a kinematic calibration, one that corrects a joint the robot lacks, or one that corrects none.
    """
    components = ("tx", "ty", "tz", "rx", "ry", "rz")
    source, dataset = str(path), _read_dataset(path)
    names = [str(n) for n in dataset["parameter"].values]
    means = dict(zip(names, (float(v) for v in dataset["mean"].values)))
    # The base (tracker to robot) and free frames carry the same components under their own prefixes.
    joints = {name.rsplit(".", 1)[0] for name in names
              if name.rsplit(".", 1)[-1] in components and name.split(".", 1)[0] not in ("base", "frame")}
    foreign = sorted(joints - set(joint_names))
    if foreign:
        raise InputError(f"the kinematic calibration corrects joint(s) {', '.join(foreign)}, which the robot lacks (its joints: "
                         f"{', '.join(joint_names)}): it is another robot's", source=source)
    if not joints:
        raise InputError("the kinematic calibration corrects no joint placement (its rung identifies only the base and "
                         "markers)", source=source)
    corrections = np.array([[means.get(f"{joint}.{c}", 0.0) for c in components] for joint in joint_names])
    return corrections, tuple(joint for joint in joint_names if joint in joints)
