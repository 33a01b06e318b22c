"""Posterior draws as ArviZ DataTrees: building, summarising, diagnosing, saving.

Posterior variables are stored in the units a user reads (mm, deg, N/mm,
μrad/(N·m)), each with a ``units`` attribute, so that a saved NetCDF file is
self-describing.  Intervals follow the paper: ``lo3``/``hi3`` are the mean
∓ 3 standard deviations.
"""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Callable, Mapping, Sequence
from datetime import datetime, timezone
from os import PathLike
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from bayescal import __version__
from bayescal.output import record_read
from bayescal.sampling.diagnostics import diagnose

if TYPE_CHECKING:
    import xarray as xr

__all__ = ["posterior_tree", "pooled_tree", "COMPONENT", "summarize", "diagnostics", "converged", "sample_until_converged", "warn_if_unconverged", "ConvergenceWarning", "parameters_json", "save", "load", "read_posterior", "read_posterior_of"]

R_HAT_LIMIT = 1.01
"""Largest rank-normalised split R-hat accepted as converged (Vehtari et al. 2021)."""
ESS_LIMIT = 400
"""Smallest bulk and tail ESS for stable intervals (Vehtari et al. 2021 recommend 100 per chain for 4 chains)."""


class ConvergenceWarning(UserWarning):
    """The sampler has not converged well enough for its intervals to be trusted."""

COMPONENT = "component"
"""Coordinate on the ``chain`` dimension of a pooled posterior (:func:`pooled_tree`): the fit each chain comes from."""

SUMMARY_COLUMNS = ["mean", "sd", "lo3", "hi3", "q_lo3", "q_hi3", "r_hat", "ess_bulk", "ess_tail", "unit"]
CENTRAL_3SIGMA = (0.00135, 0.99865)
"""Quantiles of the central 99.73 % interval: the ±3σ content of a Gaussian, for posteriors far from one."""


def posterior_tree(
    draws: Mapping[str, np.ndarray],
    *,
    units: Mapping[str, str],
    attrs: Mapping[str, Any] | None = None,
    observed: Mapping[str, np.ndarray] | None = None,
    dims: Mapping[str, Sequence[str]] | None = None,
    coords: Mapping[str, Sequence] | None = None,
) -> xr.DataTree:
    """Pack posterior draws into a DataTree laid out as ArviZ 1.x's ``from_dict`` lays it out.

    Built with xarray alone (importing ArviZ's converters takes a quarter of a
    second, much of a geometry fit): each group a Dataset, sample dimensions
    ``chain, draw``, unnamed dimensions ``<name>_dim_<i>``, every dimension
    with an index coordinate.

    Parameters
    ----------
    draws
        Variable name to array of shape ``(chain, draw, ...)``, in the unit given by ``units``.
    units
        Unit of every variable in ``draws`` (e.g. ``"mm"``); stored as its ``units`` attribute.
    attrs
        Attributes of the whole tree (e.g. the data file, the sampler, the seed).
    observed
        Observed data to keep beside the posterior (group ``observed_data``).
    dims, coords
        Named dimensions and coordinates of non-scalar variables.

    Returns
    -------
    xarray.DataTree
        With a ``posterior`` group (and ``observed_data`` when given).
    """
    missing = [name for name in draws if name not in units]
    if missing:
        raise ValueError(f"no unit given for {', '.join(missing)}")
    # xarray is imported by the three functions that build or read a tree: a tenth of a second of start-up that the
    # commands which only read results (critique, plan, simulate) do not pay.
    import xarray as xr

    dims, coords = dict(dims or {}), dict(coords or {})
    groups = {"posterior": _dataset({name: np.asarray(value, dtype=float) for name, value in draws.items()}, ["chain", "draw"], dims, coords)}
    if observed:
        groups["observed_data"] = _dataset({name: np.asarray(value) for name, value in observed.items()}, [], dims, coords)
    tree = xr.DataTree.from_dict(groups)
    tree.attrs.update(attrs or {})
    for name, unit in units.items():
        if name in draws:
            tree["posterior"][name].attrs["units"] = unit
    return tree


def _dataset(
    variables: Mapping[str, np.ndarray], sample_dims: list[str], dims: Mapping[str, Sequence[str]], coords: Mapping[str, Sequence]
) -> xr.Dataset:
    import xarray as xr

    data_vars = {}
    for name, value in variables.items():
        named = list(dims.get(name, []))
        extra = [named[i] if i < len(named) else f"{name}_dim_{i}" for i in range(value.ndim - len(sample_dims))]
        data_vars[name] = ([*sample_dims, *extra], value)
    dataset = xr.Dataset(data_vars)
    index = {dim: coords[dim] if dim in coords else np.arange(size) for dim, size in dataset.sizes.items()}
    attrs = {
        "created_at": datetime.now(timezone.utc).isoformat(),
        "creation_library": "bayescal",
        "creation_library_version": __version__,
        "sample_dims": sample_dims,
    }
    return dataset.assign_coords(index).assign_attrs(attrs)


def pooled_tree(trees: Sequence[xr.DataTree]) -> xr.DataTree:
    """The posteriors of several fits pooled into one, an equal-weight mixture, each fit's chains kept as chains.

    Every fit gives as many chains as the fewest of them and as many draws per chain as the shortest (a longer chain
    thinned evenly), so that each carries the same weight.  The coordinate :data:`COMPONENT` on ``chain`` names the
    fit of each chain: :func:`summarize` then takes R-hat within each fit (the worst of them) and adds their ESS, since
    chains of different fits differ by design, not for want of convergence.  The tree's attributes are the first fit's.
    """
    import xarray as xr

    posteriors = [tree["posterior"].to_dataset() for tree in trees]
    chains = min(posterior.sizes["chain"] for posterior in posteriors)
    length = min(posterior.sizes["draw"] for posterior in posteriors)
    parts = []
    for k, posterior in enumerate(posteriors):
        kept = np.round(np.linspace(0, posterior.sizes["draw"] - 1, length)).astype(int)
        part = posterior.isel(chain=slice(0, chains), draw=kept)
        parts.append(part.assign_coords(draw=np.arange(length), **{COMPONENT: ("chain", np.full(chains, k))}))
    pooled = xr.concat(parts, dim="chain").assign_coords(chain=np.arange(chains * len(parts)))
    tree = xr.DataTree.from_dict({"posterior": pooled.assign_attrs(posteriors[0].attrs)})
    tree.attrs.update(trees[0].attrs)
    return tree


def summarize(tree: xr.DataTree, var_names: Sequence[str] | None = None) -> pd.DataFrame:
    """Mean, sd, ±3σ interval, central 99.73 % interval, R-hat and ESS of each posterior variable.

    Non-scalar variables give one row per element, named ``name[i]`` (or
    ``name[label]`` when the dimension has labels).

    Returns
    -------
    pandas.DataFrame
        Indexed by parameter, with columns ``mean, sd, lo3, hi3, q_lo3, q_hi3, r_hat, ess_bulk,
        ess_tail, unit``: ``lo3, hi3`` are mean ∓ 3 sd as in the paper, ``q_lo3, q_hi3`` the
        0.135 % and 99.865 % posterior quantiles.
    """
    posterior = tree["posterior"].to_dataset()
    names = list(var_names) if var_names is not None else list(posterior.data_vars)
    selected = posterior[names]
    r_hat, bulk, tail = _per_element(selected)
    rows = {}
    for name in names:
        values = selected[name]
        # NumPy on the (chain·draw, ...) array: xarray's reductions cost more than the arithmetic here.
        draws = values.transpose("chain", "draw", ...).values
        draws = draws.reshape((-1,) + draws.shape[2:])
        mean, sd = draws.mean(axis=0), draws.std(axis=0, ddof=1)
        quantiles = np.quantile(draws, list(CENTRAL_3SIGMA), axis=0)
        extra = [dim for dim in values.dims if dim not in ("chain", "draw")]
        unit = values.attrs.get("units", "")
        for label, index in _elements(values):
            at = tuple(index[dim] for dim in extra)
            m, s = float(mean[at]), float(sd[at])
            low, high = quantiles[(slice(None),) + at]
            rows[label] = {
                "mean": m,
                "sd": s,
                "lo3": m - 3 * s,
                "hi3": m + 3 * s,
                "q_lo3": float(low),
                "q_hi3": float(high),
                "r_hat": float(r_hat[name][tuple(index.values())]),
                "ess_bulk": float(bulk[name][tuple(index.values())]),
                "ess_tail": float(tail[name][tuple(index.values())]),
                "unit": unit,
            }
    frame = pd.DataFrame.from_dict(rows, orient="index", columns=SUMMARY_COLUMNS)
    frame.index.name = "parameter"
    return frame


def diagnostics(tree: xr.DataTree, summary: pd.DataFrame | None = None) -> dict[str, float | int]:
    """Worst-case convergence diagnostics over all posterior variables.

    ``summary`` is the tree's :func:`summarize` when the caller has it already:
    R-hat and ESS are then not computed again.
    """
    posterior = tree["posterior"]
    if summary is None:
        summary = summarize(tree)
    # NaN (a variable whose chains never moved) propagates: it is the worst case, not a value to skip.
    return {
        "r_hat_max": float(summary["r_hat"].max(skipna=False)),
        "ess_bulk_min": float(summary["ess_bulk"].min(skipna=False)),
        "ess_tail_min": float(summary["ess_tail"].min(skipna=False)),
        "n_chains": int(posterior.sizes["chain"]),
        "n_draws": int(posterior.sizes["draw"]),
    }


def converged(report: dict[str, float | int]) -> bool:
    """Whether the diagnostics of :func:`diagnostics` meet the thresholds :func:`warn_if_unconverged` warns under."""
    return report["r_hat_max"] <= R_HAT_LIMIT and min(report["ess_bulk_min"], report["ess_tail_min"]) >= ESS_LIMIT


def sample_until_converged(run: Callable[[Any], tuple], sampler: Any, extensions: int, *, what: str, first: tuple | None = None):
    """``run(sampler)``, run again with the sampler's extension while the diagnostics fall short.

    A sampler's extension is what its ``extended()`` method returns, when it has
    one (:mod:`bayescal.sampling.protocol`); otherwise the same sampler with
    twice its ``n_draws``.

    Parameters
    ----------
    run
        Samples with the sampler it is given; returns a tuple whose first item is the posterior tree.
    sampler
        The first sampler: one with ``extended()`` or a dataclass with an ``n_draws`` field (others are run once).
    extensions
        Most runs after the first.
    what
        The posterior, as the user knows it, for the warning that announces an extension.
    first
        ``run(sampler)``'s output when it has been run already, so that it is not run again.

    Returns
    -------
    tuple
        ``run``'s last output, the tree's :func:`summarize` and the sampler that drew it.
    """
    for extension in range(extensions + 1):
        output = first if extension == 0 and first is not None else run(sampler)
        summary = summarize(output[0])
        report = diagnostics(output[0], summary)
        if converged(report) or extension == extensions:
            break
        if hasattr(sampler, "extended"):
            sampler = sampler.extended()
        elif hasattr(sampler, "n_draws"):
            sampler = dataclasses.replace(sampler, n_draws=2 * sampler.n_draws)
        else:
            break
    if extension:
        warnings.warn(
            f"{what} was sampled again ({type(sampler).__name__}, {report['n_draws']} draws per chain) to converge "
            f"(R-hat max {report['r_hat_max']:.3f}, ESS min {min(report['ess_bulk_min'], report['ess_tail_min']):.0f}): "
            "slow mixing often comes with a model that misfits its data, which bayescal critique tests",
            UserWarning,
            stacklevel=3,
        )
    return output, summary, sampler


def warn_if_unconverged(report: dict[str, float | int], *, what: str, stacklevel: int = 3) -> None:
    """Warn when the diagnostics of :func:`diagnostics` fall short of the usual thresholds.

    Parameters
    ----------
    report
        The output of :func:`diagnostics`.
    what
        The posterior, as the user knows it (e.g. ``"the geometry posterior"``).
    stacklevel
        The frame the warning names, as :func:`warnings.warn` counts it from this function (3: its caller's caller).
    """
    problems = []
    if not report["r_hat_max"] <= R_HAT_LIMIT:
        problems.append(f"R-hat {report['r_hat_max']:.3f} > {R_HAT_LIMIT}")
    for key, label in (("ess_bulk_min", "bulk"), ("ess_tail_min", "tail")):
        if not report[key] >= ESS_LIMIT:
            problems.append(f"{label} ESS {report[key]:.0f} < {ESS_LIMIT}")
    if problems:
        warnings.warn(
            f"{what} may not have converged ({', '.join(problems)}): draw more (e.g. --draws) before trusting its intervals",
            ConvergenceWarning,
            stacklevel=stacklevel,
        )


def parameters_json(summary: pd.DataFrame) -> dict[str, dict[str, float | str]]:
    """The ``{"name": {"mean", "sd", "lo3", "hi3", "q_lo3", "q_hi3", "unit"}}`` block of the CLI's JSON output."""
    keys = ("mean", "sd", "lo3", "hi3", "q_lo3", "q_hi3", "unit")
    return {
        str(name): {key: (row[key] if key == "unit" else float(row[key])) for key in keys}
        for name, row in summary.iterrows()
    }


def save(tree: xr.DataTree, path: str | PathLike[str]) -> None:
    """Write the tree to a NetCDF file (one group per DataTree node)."""
    tree.to_netcdf(path, engine="netcdf4")


def load(path: str | PathLike[str]) -> xr.DataTree:
    """Read a tree written by :func:`save`, wholly into memory, and close the file.

    An open file would stay shared by every tree read from the same path: the
    first of them to be garbage-collected closes it under the others.
    """
    import xarray as xr

    record_read(path, "a posterior")
    with xr.open_datatree(path, engine="netcdf4") as tree:
        return tree.load()


def read_posterior(path: str | PathLike[str], what: str = "a posterior DataTree") -> tuple[xr.DataTree, xr.DataTree]:
    """A saved tree (:func:`load`) and its ``posterior`` group, for the readers of a user's file.

    Raises
    ------
    InputError
        Naming the file and ``what`` was expected, when it cannot be read or has no posterior group.
    """
    from bayescal.errors import InputError

    try:
        tree = load(path)
        return tree, tree["posterior"]
    except (OSError, KeyError, ValueError) as exc:
        raise InputError(f"cannot read {what} ({type(exc).__name__})", source=str(path)) from None


def read_posterior_of(path: str, option: str, needs: Sequence[str], foreign: str, other: str) -> xr.DataTree:
    """The saved tree at ``path`` that ``option`` expects, refused when it lacks a variable of ``needs``, has ``foreign``, a
    variable only the posterior ``other`` expects has (an elastostatic posterior also holds the geometry it sampled), or
    non-finite draws.

    Raises
    ------
    InputError
        Naming the file, and the variable or ``option`` and ``other``.
    """
    from bayescal.errors import InputError

    tree, posterior = read_posterior(path)
    missing = [name for name in needs if name not in posterior]
    if missing:
        raise InputError(f"the posterior has no variable {', '.join(repr(m) for m in missing)}: is it the file {option} expects?", source=path)
    if foreign in posterior:
        raise InputError(f"the posterior has the variable '{foreign}' of a {other} posterior: is it the file {option} expects?", source=path)
    for name, values in posterior.data_vars.items():
        bad = int(np.count_nonzero(~np.isfinite(np.asarray(values.values, dtype=float))))
        if bad:
            raise InputError(f"the variable has {bad} non-finite draws; expected finite draws", source=path, column=str(name))
    return tree


def _elements(values: xr.DataArray):
    extra = [dim for dim in values.dims if dim not in ("chain", "draw")]
    if not extra:
        yield values.name, {}
        return
    shape = [values.sizes[dim] for dim in extra]
    for position in np.ndindex(*shape):
        index = dict(zip(extra, position))
        labels = [str(values[dim].values[i]) for dim, i in index.items()]
        yield f"{values.name}[{','.join(labels)}]", index


def _per_element(dataset: xr.Dataset) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray], dict[str, np.ndarray]]:
    """R-hat, bulk ESS and tail ESS of the ``(chain, draw)`` draws of every element of every variable, by variable."""
    out = ({}, {}, {})
    components = dataset[COMPONENT].values if COMPONENT in dataset.coords else None
    for name, values in dataset.data_vars.items():
        draws = values.transpose("chain", "draw", ...).values
        flat = draws.reshape(draws.shape[0], draws.shape[1], -1)
        table = np.array([_diagnose_pooled(flat[:, :, i], components) for i in range(flat.shape[-1])]).reshape(-1, 3)
        for column, target in enumerate(out):
            target[name] = table[:, column].reshape(draws.shape[2:])
    return out


def _diagnose_pooled(draws: np.ndarray, components: np.ndarray | None) -> tuple[float, float, float]:
    """R-hat, bulk and tail ESS of ``draws`` (chain, draw); with ``components`` (chain,), the fit of each chain, the worst
    R-hat of any fit and the sum of their ESS (:func:`pooled_tree`)."""
    if components is None:
        return diagnose(draws)
    each = np.array([diagnose(draws[components == k]) for k in np.unique(components)])
    return float(np.max(each[:, 0])), float(np.sum(each[:, 1])), float(np.sum(each[:, 2]))
