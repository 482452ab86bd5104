"""The root group of the validation netCDF file: the verdicts and where the data are.

``xr.open_dataset`` opens only the root group of a netCDF-4 file. So that it shows more than
attributes, the root holds a short summary (docs/scene.md, output files):

- ``comparison`` and ``passed`` on dim ``verdict``: each comparison's name and whether it met
  every threshold (1) or not (0), with ``thresholds`` (how many were checked);
- ``input_file`` and ``input_sha256`` on dim ``input``: the data files and their SHA-256;
- the attributes ``summary`` (one sentence: how many comparisons passed, which failed, the
  groups and how to open them) and ``groups`` (the group paths, space-separated).

No coordinate variables: DataTree nodes inherit the root's coordinates, these stay in the root.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
import xarray as xr

from rigval.validation.results import ValidationResult

__all__ = ["root_summary"]


def root_summary(result: ValidationResult, root: xr.Dataset, groups: Sequence[str],
                 inputs: Sequence[tuple[Path, str]]) -> xr.Dataset:
    """Return the Dataset for the root group of the validation file.

    Parameters
    ----------
    result : ValidationResult
        The run's result (comparisons and their threshold checks).
    root : xarray.Dataset
        What the root of the tree to be written holds (its ``history``, ...).
    groups : sequence of str
        The paths of the tree's groups that hold data, in the tree's order (listed).
    inputs : sequence of (path, sha256)
        The input data files and their checksums.

    Returns
    -------
    xarray.Dataset
        ``root`` with the summary added: data variables and attributes only (no coordinates).
    """
    names = [c.name for c in result.comparisons]
    passed = [c.passed for c in result.comparisons]
    failed = [n for n, ok in zip(names, passed, strict=True) if not ok]
    verdict = (f"{sum(passed)} of {len(names)} comparisons pass their thresholds"
               + (f" (failed: {', '.join(failed)})" if failed else ""))
    text = (f"{verdict}. Data groups: {', '.join(groups)}. This root holds only this summary: "
            "open the whole file with xarray.open_datatree(path), or one group with "
            "xarray.open_dataset(path, group='/angle').")
    return root.assign(
        {
            "comparison": ("verdict", np.array(names, dtype=object),
                           {"long_name": "comparison name (scene [[comparison]])"}),
            "passed": ("verdict", np.array(passed, dtype=np.int8), {
                "long_name": "every threshold of the comparison is met",
                "flag_values": np.array([0, 1], dtype=np.int8),
                "flag_meanings": "failed passed"}),
            "thresholds": ("verdict", np.array([len(c.checks) for c in result.comparisons],
                                               dtype=np.int32),
                           {"long_name": "thresholds checked", "units": "1"}),
            "input_file": ("input", np.array([str(p) for p, _ in inputs], dtype=object),
                           {"long_name": "input data file"}),
            "input_sha256": ("input", np.array([s for _, s in inputs], dtype=object),
                             {"long_name": "SHA-256 of the input data file"}),
        },
    ).assign_attrs(summary=text, groups=" ".join(groups))
