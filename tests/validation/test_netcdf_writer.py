"""The run's netCDF file written with its variables defined first equals xarray's own writing.

``write_netcdf`` writes the file's groups through xarray's stores, without building their tree,
and holds each variable's data until the variables are defined (``run_report._write_groups``);
the file must hold what ``DataTree.to_netcdf`` writes of the tree of those groups: the same
groups, dimensions, variables, attributes, encodings (filters, chunks) and data, in the same
order. A short virtual-rig run with raw and aligned streams kept (CF times, float32, strings)
and its diagnosis (``/why``, ``/diagnosis``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import netCDF4
import numpy as np
import pytest
import xarray as xr

from rigval.sample_data import RigSettings, simulate_rig
from rigval.validation.diagnosis.explain import attach_diagnosis
from rigval.validation.pipeline import run_scene
from rigval.validation.report import run_report
from rigval.validation.report.run_report import file_groups

pytestmark = pytest.mark.filterwarnings("ignore::rigval.acquisition.errors.DataWarning")


@pytest.fixture(scope="module")
def groups_and_encoding(tmp_path_factory: pytest.TempPathFactory
                        ) -> tuple[dict[str, xr.Dataset], dict[str, dict[str, Any]]]:
    folder = tmp_path_factory.mktemp("rig")
    simulate_rig(folder, RigSettings(speed=1.0, duration=12.0, seed=7))
    scene = next(folder.glob("*_scene.toml"))
    scene.write_text(scene.read_text() + "\n[output]\nraw = true\naligned = true\n")
    return file_groups(attach_diagnosis(run_scene(scene)))


def _attributes(item: netCDF4.Dataset | netCDF4.Group | netCDF4.Variable) -> list[tuple]:
    return [(name, repr(item.getncattr(name))) for name in item.ncattrs()]


def _group_record(group: netCDF4.Dataset | netCDF4.Group) -> list[tuple]:
    """Everything the file holds in a group and below, in the file's order."""
    record = [(group.path, "dims", [(name, len(d), d.isunlimited())
                                    for name, d in group.dimensions.items()]),
              (group.path, "attrs", _attributes(group))]
    for name, variable in group.variables.items():
        variable.set_auto_maskandscale(False)
        data = variable[...]
        values = repr(data.tolist()) if data.dtype == object else (str(data.dtype),
                                                                    data.tobytes())
        record.append((group.path, name, variable.dimensions, str(variable.dtype),
                       variable.filters(), variable.chunking(), variable.endian(),
                       _attributes(variable), values))
    record.append((group.path, "groups", list(group.groups)))
    for child in group.groups.values():
        record += _group_record(child)
    return record


def _file_record(path: Path) -> list[tuple]:
    with netCDF4.Dataset(path) as ds:
        return [("format", ds.data_model), *_group_record(ds)]


@pytest.mark.parametrize("held_bytes", [run_report.HELD_BYTES, 1])
def test_file_equals_xarrays_writing(
        groups_and_encoding: tuple[dict[str, xr.Dataset], dict[str, dict[str, Any]]],
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, held_bytes: int) -> None:
    # 1 byte: the held data are written after every variable, as xarray writes them
    monkeypatch.setattr(run_report, "HELD_BYTES", held_bytes)
    groups, encoding = groups_and_encoding
    tree = xr.DataTree.from_dict(groups)
    assert list(tree.groups) == list(groups)  # the tree lists them in the order written
    assert {"/raw", "/aligned", "/diagnosis", "/why", "/health"} <= set(groups)
    tree.to_netcdf(tmp_path / "xarray.nc", engine="netcdf4", encoding=encoding)
    run_report._write_groups(groups, tmp_path / "deferred.nc", encoding)
    expected = _file_record(tmp_path / "xarray.nc")
    found = _file_record(tmp_path / "deferred.nc")
    assert [entry[:2] for entry in found] == [entry[:2] for entry in expected]
    assert found == expected


def test_written_file_reads_back_as_the_groups(
        groups_and_encoding: tuple[dict[str, xr.Dataset], dict[str, dict[str, Any]]],
        tmp_path: Path) -> None:
    groups, encoding = groups_and_encoding
    run_report._write_groups(groups, tmp_path / "run.nc", encoding)
    with xr.open_datatree(tmp_path / "run.nc", engine="netcdf4") as back:
        assert list(back.groups) == list(groups)
        for path in ("/why", "/angle"):
            xr.testing.assert_identical(back[path].to_dataset().load(), groups[path])
        np.testing.assert_array_equal(back["/why"]["explained"], groups["/why"]["explained"])
