"""One model quantity named and picked out of a result: what a comparison compares.

:class:`ModelOutput` names one quantity of the result contract (docs/model.md, *Result
contract*; the table is :data:`rigval.model.results.QUANTITIES`) with its item and axis, or a
joint force projected on a body's axis. :func:`with_axial_forces` adds the projected forces asked
for to a result, :func:`model_values` returns one named quantity as a plain vector over the
result's leading dim, and :func:`coarse_grid_error` the error of a coarser angle grid in each.
"""

from __future__ import annotations

from collections.abc import Hashable, Iterable, Mapping
from dataclasses import dataclass

import numpy as np
import xarray as xr

from rigval.model.mechanism import Mechanism
from rigval.model.results import QUANTITIES, axial_joint_force
from rigval.model.solver import interpolate_cycle

__all__ = ["ModelOutput", "axial_label", "coarse_grid_error", "model_values", "with_axial_forces"]


@dataclass(frozen=True)
class ModelOutput:
    """One model quantity (docs/model.md, *Result contract*).

    Parameters
    ----------
    quantity : str
        One of :data:`rigval.model.results.COMPARABLE`.
    item : str
        The body, point, joint or driver.
    axis : str or None
        ``x``, ``y`` or ``theta``; None for ``driver_torque`` and ``joint_axial_force``.
    body : str or None
        ``joint_axial_force`` only: the body whose axis the joint force is projected on.
    toward : str or None
        ``joint_axial_force`` only: the body's point that, with the joint's, gives the axis
        (None: the body's only other point).
    """

    quantity: str
    item: str
    axis: str | None = None
    body: str | None = None
    toward: str | None = None

    @property
    def units(self) -> str:
        """Unit of the model value (UDUNITS)."""
        return QUANTITIES[self.quantity].units[self.axis or ""]

    def __str__(self) -> str:
        suffix = f".{self.axis}" if self.axis else ""
        if self.body:
            suffix += f" on {self.body}" + (f" towards {self.toward}" if self.toward else "")
        return f"{self.quantity}[{self.item}]{suffix}"


def axial_label(output: ModelOutput) -> str:
    """Label of a ``joint_axial_force`` in the model Dataset's ``member`` dim."""
    return f"{output.item} on {output.body}" + (f" towards {output.toward}"
                                                 if output.toward else "")


def with_axial_forces(ds: xr.Dataset, mechanism: Mechanism,
                      outputs: Iterable[ModelOutput]) -> xr.Dataset:
    """Add ``joint_axial_force`` (dims angle, member; N, tension positive) for the outputs asked.

    Parameters
    ----------
    ds : xarray.Dataset
        A model result holding ``joint_force`` and ``position`` (for the body angles).
    mechanism : rigval.model.Mechanism
        The solved mechanism.
    outputs : iterable of ModelOutput
        Every output; those of quantity ``joint_axial_force`` are added once each, labelled by
        :func:`axial_label` in the ``member`` dim.

    Returns
    -------
    xarray.Dataset
        ``ds`` itself when no axial force is asked for, else a copy with ``joint_axial_force``.
    """
    wanted = list(dict.fromkeys(o for o in outputs if o.quantity == "joint_axial_force"))
    if not wanted:
        return ds
    forces = [axial_joint_force(ds, mechanism, o.item, o.body or "", o.toward) for o in wanted]
    stacked = xr.concat(forces, dim="member").transpose(..., "member")
    stacked = stacked.assign_coords(member=[axial_label(o) for o in wanted])
    stacked.attrs = {"units": "N", "long_name": "joint force projected on a body's axis, "
                                                "tension positive"}
    return ds.assign(joint_axial_force=stacked)


def model_values(model: xr.Dataset, output: ModelOutput) -> np.ndarray:
    """Return one model quantity (unscaled) as a float64 vector over the result's leading dim.

    Parameters
    ----------
    model : xarray.Dataset
        A model result (with ``joint_axial_force`` from :func:`with_axial_forces` where that is
        the quantity).
    output : ModelOutput
        Quantity, item and axis.
    """
    if output.quantity == "joint_axial_force":
        return _picked(model["joint_axial_force"], {"member": axial_label(output)})
    item_dim, axis_dim = QUANTITIES[output.quantity].item, QUANTITIES[output.quantity].axis
    labels = {item_dim: output.item}
    if axis_dim is not None:
        labels[axis_dim] = output.axis
    return _picked(model[output.quantity], labels)


def _picked(var: xr.DataArray, labels: Mapping[str, Hashable]) -> np.ndarray:
    """Return ``var.sel(labels).to_numpy()`` as a new float64 array, picked by position.

    One label per named dim (their coordinates' values are unique); the result's dims are the
    others in order. The positions come from the dims' indexes, the values from the array
    itself: what ``sel`` returns, without building a DataArray per pick (a comparison's model
    values are picked dozens of times a run).

    Raises
    ------
    KeyError
        For a label not in its dim's coordinate, as ``sel`` does.
    """
    where = tuple(_position(var, dim, labels[dim]) if dim in labels else slice(None)
                  for dim in var.dims)
    return np.array(var.to_numpy()[where], dtype=np.float64)


def _position(var: xr.DataArray, dim: str, label: Hashable) -> int:
    """Return the position of ``label`` in ``var``'s coordinate ``dim`` (KeyError if absent)."""
    position = var.get_index(dim).get_loc(label)
    if not isinstance(position, int):
        raise KeyError(f"{label!r} is not one value of {dim!r}")
    return position



def coarse_grid_error(fine: xr.Dataset, outputs: Mapping[str, ModelOutput], step: int
                      ) -> dict[str, float]:
    """Return the error of every ``step``-th angle of a result, per named output.

    The result on the coarse grid, interpolated back onto the fine one with a periodic cubic
    spline (:func:`rigval.model.solver.interpolate_cycle`), against the result on the fine grid:
    the largest difference over the output's range (its peak-to-peak; 1 for a constant output).

    Parameters
    ----------
    fine : xarray.Dataset
        A result over one revolution with dim ``angle`` (rad), holding every output's quantity.
    outputs : mapping of str to ModelOutput
        Name (e.g. a comparison's) to the output it names.
    step : int
        The coarse grid is every ``step``-th angle of the fine one.

    Returns
    -------
    dict of str to float
        Name to the relative error (1).
    """
    needed = sorted({output.quantity for output in outputs.values()})
    coarse = interpolate_cycle(fine[needed].isel(angle=slice(None, None, step)),
                               fine["angle"].to_numpy())
    errors = {}
    for name, output in outputs.items():
        values = model_values(fine, output)
        span = float(np.ptp(values)) or 1.0
        error = model_values(coarse, output) - values
        errors[name] = float(np.max(np.abs(error)) / span)
    return errors
