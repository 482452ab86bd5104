"""Read the truth of a virtual-rig run back: parameters and true signals at every sample.

The truth JSON holds the clock of each stream (nominal and true rate, drift, gap-free segments with
their true start and recorded start time), the gaps, every sensor's parameters, the optical pulses'
true edges (present, missing, spurious), and the drive law; the ``.npz`` holds the true physical
value of every analog channel at its samples. :func:`load_truth` joins both into one
:class:`xarray.Dataset` per stream.
"""

from __future__ import annotations

import json
import logging
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from rigval.acquisition.errors import ConfigError, DataFileError
from rigval.sample_data.drive import DriveMotion, Harmonic, SpeedWander

__all__ = ["RunTruth", "load_truth"]

logger = logging.getLogger(__name__)

#: Encoder channel -> the drive angle it counts.
_ENCODER_DRIVES = {"enc1": "theta_F", "enc2": "theta_H"}


@dataclass(frozen=True)
class RunTruth:
    """The truth of one run.

    Parameters
    ----------
    record : dict
        The truth JSON as written (clocks, gaps, sensors, pulses, drive law, settings).
    drive : DriveMotion
        The true drive motion.
    streams : dict of str to xarray.Dataset
        Per stream: dim ``time`` with coordinates ``time_true`` (s of true time),
        ``time_device`` (s from the first recorded start, as a reader builds it) and ``segment``;
        variables: the true physical value of each analog channel (float32, units attribute) and
        the true drive angle of each encoder (float64, rad).
    """

    record: dict[str, Any]
    drive: DriveMotion
    streams: dict[str, xr.Dataset]

    def clock_on_reference(self, stream: str, reference: str = "cdaq"
                           ) -> tuple[tuple[float, ...], float]:
        """Return the exact clock model of a stream on a reference stream's own clock.

        That is what a clock alignment should recover: ``t_ref = offsets[j] + (1 + drift) u``
        for a sample of segment j at device time u (the time axis a reader builds), where
        ``t_ref`` is the reference device's time axis, which drifts too. The reference reads
        ``u_r0 + (1 + d_r) (t - s_r0)`` at true time t, and sample k of segment j was taken at
        ``t = s_j + k / (fs (1 + d))`` and is stamped ``u = u_j + k / fs``, so the drift is
        ``(1 + d_r) / (1 + d) - 1`` and ``offsets[j] = u_r0 + (1 + d_r) (s_j - s_r0)
        - (1 + drift) u_j`` (no input delay: that is each channel's own).

        Parameters
        ----------
        stream : str
            Stream name (``"wls1"``, ...).
        reference : str, default "cdaq"
            The reference stream; it must be gap-free.

        Returns
        -------
        offsets : tuple of float
            Offset in s (reference clock) per gap-free segment of the stream.
        drift : float
            Relative rate ``b - 1`` (1, times 1e6 for ppm).

        Raises
        ------
        ConfigError
            If either stream is unknown or the reference has gaps.
        """
        clocks = self.record["streams"]
        for name in (stream, reference):
            if name not in clocks:
                raise ConfigError(f"no stream {name!r} in the truth", where={"key": name},
                                  hint=f"use one of {sorted(clocks)}")
        if len(clocks[reference]["segments"]) != 1:
            raise ConfigError(f"reference {reference!r} has gaps: its clock is not one line",
                              where={"key": reference}, hint="use a gap-free reference stream")
        first = clocks[reference]["segments"][0]
        ref_rate = 1.0 + clocks[reference]["drift_ppm"] * 1e-6
        ratio = ref_rate / (1.0 + clocks[stream]["drift_ppm"] * 1e-6)
        offsets = tuple(first["device_start_s"] + ref_rate * (s["true_start_s"]
                                                              - first["true_start_s"])
                        - ratio * s["device_start_s"] for s in clocks[stream]["segments"])
        return offsets, ratio - 1.0


def _drive(record: dict[str, Any]) -> DriveMotion:
    d = record["drive"]
    return DriveMotion(d["speed"], d["theta_f0"], d["theta_h0"],
                       tuple(Harmonic(**h) for h in d["ripple_f"]),
                       tuple(Harmonic(**h) for h in d["ripple_h"]),
                       tuple(SpeedWander(**w) for w in d["wander"]))


def load_truth(path: str | Path, *, signals: bool = True) -> RunTruth:
    """Load a run's truth from its ``*_truth.json`` (the ``.npz`` next to it is read as well).

    Parameters
    ----------
    path : str or Path
        The truth JSON.
    signals : bool, default True
        Build the true signals of every sample (``RunTruth.streams``). False reads the JSON
        alone: parameters, clocks (:meth:`RunTruth.clock_on_reference`) and drive law, without
        the whole record's arrays (an hour's truth needs about 2 GiB as signals).

    Returns
    -------
    RunTruth
        Parameters and true signals (``streams`` empty when ``signals`` is False).

    Raises
    ------
    DataFileError
        If the JSON or its arrays file is missing or not a virtual-rig truth file.
    """
    path = Path(path)
    try:
        record = json.loads(path.read_text(encoding="utf-8"))
        arrays = np.load(path.parent / record["arrays"]) if signals else None
    except (OSError, KeyError, ValueError) as exc:
        raise DataFileError(f"cannot read virtual-rig truth: {exc}", where={"file": str(path)},
                            hint="pass the *_truth.json of a run written by simulate-rig") from exc
    drive = _drive(record)
    if arrays is None:
        return RunTruth(record, drive, {})
    streams = {}
    with arrays:
        for name, info in record["streams"].items():
            segments = info["segments"]
            true = np.concatenate([s["true_start_s"] + np.arange(s["n_samples"]) / info["fs_true"]
                                   for s in segments])
            device = np.concatenate([s["device_start_s"]
                                     + np.arange(s["n_samples"]) / info["fs_nominal"]
                                     for s in segments])
            segment = np.concatenate([np.full(s["n_samples"], i, dtype=np.int32)
                                      for i, s in enumerate(segments)])
            variables = {}
            for channel, meta in info["channels"].items():
                key = f"{name}.{channel}"
                if key in arrays:
                    variables[channel] = ("time", arrays[key], {"units": meta["truth_unit"]})
                elif channel in _ENCODER_DRIVES:
                    angle = drive.angles(true)[_ENCODER_DRIVES[channel]][0]
                    variables[channel] = ("time", angle, {"units": "rad"})
            streams[name] = xr.Dataset(
                variables, coords={"time_true": ("time", true), "time_device": ("time", device),
                                   "segment": ("time", segment)},
                attrs={"device": info["device"], "drift_ppm": info["drift_ppm"],
                       "fs_nominal": info["fs_nominal"]})
    return RunTruth(record, drive, streams)
