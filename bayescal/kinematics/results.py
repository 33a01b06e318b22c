"""What a kinematic calibration found: the posterior of every parameter, the residuals, predictions.

:class:`KinematicResults` holds the Gaussian posterior at the mode of a rung of
the ladder (:mod:`bayescal.kinematics.fit`) and gives the four verbs of every
result (``summary``, ``diagnostics``, ``to_json``, ``save``) and ``predict``:
marker positions of new configurations with their predictive covariance
(posterior plus the tracker's noise plus the learned model error).
:func:`results_from_dataset` rebuilds one from what it saved (:mod:`bayescal.kinematics.saved` reads the file).
"""

from __future__ import annotations

from dataclasses import dataclass
from os import PathLike

import numpy as np
import pandas as pd

from bayescal.errors import InputError
from bayescal.kinematics.model import PointModel
from bayescal.kinematics.positions import Positions

__all__ = ["KinematicResults", "results_from_dataset", "IDENTIFIED_RATIO", "KIND"]

IDENTIFIED_RATIO = 0.5
"""A parameter is identified when the data shrink its prior sd by at least half (posterior sd / prior sd below 0.5)."""

UNIDENTIFIED_RATIO = 0.9
"""Above this ratio the data say next to nothing of a parameter: it is reported as not identifiable, with why."""

KIND = "bayescal kinematic calibration"


@dataclass(frozen=True)
class KinematicResults:
    """The posterior of a rung's parameters (Gaussian at the mode), SI inside.

    Attributes
    ----------
    model : PointModel
    mean : numpy.ndarray
        ``(P,)`` the posterior mode (and mean of the Gaussian approximation).
    covariance : numpy.ndarray
        ``(P, P)``.
    information : numpy.ndarray or None
        ``(P, P)`` the data's part of the posterior precision (``None`` when loaded from a file).
    model_sd : float
        The learned model error's sd per coordinate (m).
    residuals : numpy.ndarray or None
        ``(N, M, 3)`` measured minus predicted (m) at the mode.
    positions : Positions or None
    iterations : int
    """

    model: PointModel
    mean: np.ndarray
    covariance: np.ndarray
    information: np.ndarray | None
    model_sd: float
    residuals: np.ndarray | None
    positions: Positions | None
    iterations: int = 0

    @property
    def sd(self) -> np.ndarray:
        return np.sqrt(np.diag(self.covariance))

    def errors(self) -> np.ndarray:
        """``(N, M)`` the distance (m) between each measured and predicted marker."""
        return np.linalg.norm(self.residuals, axis=-1)

    def predict(self, joints: np.ndarray, added_jacobian: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Marker positions of commanded configurations and their predictive covariance.

        Parameters
        ----------
        joints
            ``(N, n_commanded)`` commanded joint angles (rad).
        added_jacobian
            ``(N, M, 3, P)`` the derivatives in the parameters of a displacement the caller adds to the positions
            (a load's deflection, m per SI unit): they join the model's in the posterior's part of the covariance.

        Returns
        -------
        mean : numpy.ndarray
            ``(N, M, 3)`` positions in the tracker frame (m).
        covariance : numpy.ndarray
            ``(N, M, 3, 3)`` (m²): the posterior's, the tracker's and the model error's.
        """
        cell = self.model.cell
        predicted, jacobian = self.model.predict(self.mean, cell.model_configuration(joints))
        if added_jacobian is not None:
            jacobian = jacobian + added_jacobian
        covariance = np.einsum("nmap,pq,nmbq->nmab", jacobian, self.covariance, jacobian, optimize=True)
        noise = cell.tracker.sigma(predicted) ** 2 + self.model_sd**2
        return predicted, covariance + noise[..., None, None] * np.eye(3)

    def identifiability(self) -> list[dict]:
        """Each parameter the data leave near its prior (sd ratio above :data:`UNIDENTIFIED_RATIO`), with why."""
        prior = self.model.sd
        ratio = self.sd / prior
        out = []
        scaled = self.covariance / np.outer(self.sd, self.sd)
        for i in np.flatnonzero(ratio > UNIDENTIFIED_RATIO):
            if self.information is not None and self.information[i, i] * prior[i] ** 2 < 1e-6:
                why = "it moves no measured marker in these configurations"
            else:
                others = np.abs(scaled[i]).copy()
                others[i] = 0.0
                partner = int(np.argmax(others))
                why = (f"its effect is shared with {self.model.names[partner]} (posterior correlation {scaled[i, partner]:+.2f})"
                       if others[partner] > 0.3 else "the configurations barely move the markers along its effect")
            out.append({"parameter": self.model.names[i], "sd_ratio": float(ratio[i]), "why": why})
        return out

    def document(self):
        """The calibration as one document (:mod:`bayescal.summary`): the text ``bayescal kinematics`` prints, and its
        Markdown, HTML and JSON (:func:`~bayescal.kinematics.document.kinematic_document`)."""
        from bayescal.kinematics.document import kinematic_document

        return kinematic_document(self)

    def summary(self) -> pd.DataFrame:
        """One row per parameter: group, unit, prior mean and sd, posterior mean and sd, ±3σ, the sd ratio (edge units)."""
        scale = np.array([p.scale for p in self.model.parameters])
        frame = pd.DataFrame({
            "parameter": self.model.names,
            "group": [p.group for p in self.model.parameters],
            "unit": [p.unit for p in self.model.parameters],
            "prior_mean": self.model.mean / scale,
            "prior_sd": self.model.sd / scale,
            "mean": self.mean / scale,
            "sd": self.sd / scale,
        })
        frame["lower_3sd"] = frame["mean"] - 3 * frame["sd"]
        frame["upper_3sd"] = frame["mean"] + 3 * frame["sd"]
        frame["sd_ratio"] = self.sd / self.model.sd
        frame["identified"] = frame["sd_ratio"] < IDENTIFIED_RATIO
        return frame.set_index("parameter")

    def diagnostics(self) -> dict:
        """The fit's residuals (mm), the learned model error, the identified share, the iterations."""
        out = {"rung": self.model.rung, "without": list(self.model.without), "parameters": self.model.size,
               "identified": int(np.sum(self.sd / self.model.sd < IDENTIFIED_RATIO)), "iterations": self.iterations,
               "model_error_sd_mm": self.model_sd * 1e3}
        if self.residuals is not None:
            errors = self.errors() * 1e3
            out |= {"configurations": int(errors.shape[0]), "error_mean_mm": float(errors.mean()), "error_sd_mm": float(errors.std()),
                    "error_max_mm": float(errors.max()), "rms_per_coordinate_mm": float(np.sqrt(np.mean(self.residuals**2)) * 1e3)}
        return out

    def to_json(self) -> dict:
        """A JSON-ready dict: the diagnostics, every parameter's row, the parameters the data do not identify."""
        table = self.summary().reset_index()
        return {"kind": KIND, "diagnostics": self.diagnostics(), "parameters": table.to_dict(orient="records"),
                "not_identifiable": self.identifiability()}

    def save(self, path: str | PathLike[str]) -> None:
        """Write the posterior as NetCDF (:meth:`dataset`)."""
        self.dataset().to_netcdf(path, engine="netcdf4")

    def dataset(self):
        """The posterior as an ``xarray.Dataset``: names, units, prior, mean and covariance (SI), the model error, the rung."""
        import xarray as xr

        names = list(self.model.names)
        return xr.Dataset(
            {"mean": ("parameter", self.mean), "prior_mean": ("parameter", self.model.mean), "prior_sd": ("parameter", self.model.sd),
             "covariance": (("parameter", "parameter_b"), self.covariance)},
            coords={"parameter": names, "parameter_b": names},
            attrs={"kind": KIND, "rung": self.model.rung, "without": ",".join(self.model.without), "model_sd_m": self.model_sd,
                   "cell": self.model.cell.source, "units": "SI (m, rad, rad/(N·m), kg, kg·m)"},
        )


def results_from_dataset(dataset, model, source: str) -> KinematicResults:
    """The posterior of ``model`` a saved ``dataset`` (:meth:`KinematicResults.dataset`) holds, read from ``source``."""
    names = [str(n) for n in dataset["parameter"].values]
    if names != list(model.names):
        missing = next((n for n in model.names if n not in names), None) or next(n for n in names if n not in model.names)
        raise InputError(f"the calibration's parameters are not this cell's (first difference: '{missing}'); "
                         f"was it made with another cell than {model.cell.source}?", source=source)
    return KinematicResults(model=model, mean=dataset["mean"].values, covariance=dataset["covariance"].values, information=None,
                            model_sd=float(dataset.attrs["model_sd_m"]), residuals=None, positions=None)
