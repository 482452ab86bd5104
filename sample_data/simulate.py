"""Run the virtual rig and write a run folder: measurement files, truth, scene and note.

Layout of a run folder for stem ``run_0p8`` (speed 0.8 rev/s):

=========================  =====================================================================
file                       content
=========================  =====================================================================
``run_0p8_cdaq.tdms``      cDAQ-9172, NI-DAQmx raw TDMS, group ``cDAQ1 task``: acc1-3, str1, opt1
                           (int16/int32 codes with linear scaling), enc1, enc2 (uint32 counts)
``run_0p8_wls1.tdms``      WLS-9163 #1, group ``WLS1 task``: tor1, tor2, opt2 (int32 codes, V/V);
                           a restart after a dropout appends segments with a new wf_start_time
``run_0p8_wls2.csv``       WLS-9163 #2 as a LabVIEW app on a European PC writes it: tor3, tor4,
                           opt3; ``;`` separator, decimal comma, time column in s
``run_0p8_scene.toml``     the scene that validates the run (docs/scene.md)
``run_0p8_note.txt``       the operator's note
``run_0p8_truth.json``     clock parameters, gaps, sensor parameters, pulse truth, drive law
``run_0p8_truth.npz``      true physical value of every analog channel at its samples (float32)
=========================  =====================================================================

Read the truth back with :func:`rigval.sample_data.load_truth`.
"""

from __future__ import annotations

import dataclasses
import logging
import tempfile
import tomllib
from collections.abc import Callable
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rigval.acquisition.errors import ConfigError
from rigval.acquisition.json_values import json_ready
from rigval.acquisition.outputs import write_text_atomic
from rigval.model.mechanism import load_mechanism
from rigval.sample_data.departures import departed_grid
from rigval.sample_data.devices import Stream, StreamPiece
from rigval.sample_data.drive import DriveMotion, Harmonic
from rigval.sample_data.faults import FaultInjector
from rigval.sample_data.rig import RigDraw, RigSettings, RunFiles, draw_rig, run_stem
from rigval.sample_data.scene_text import local_time, note_text, scene_text
from rigval.sample_data.streams import (
    SAMPLED_QUANTITIES,
    SampledTruth,
    sampled_truth,
    stream_pieces,
)
from rigval.sample_data.tdms_writer import Acquisition, DaqmxTdmsWriter, RawChannel
from rigval.sample_data.truth import TruthGrid, model_truth
from rigval.sample_data.truth_store import TruthStore, UniformGrid, store_truth
from rigval.sample_data.writers import (
    NpyAppender,
    european_csv_head,
    european_csv_rows,
    write_json,
    write_npz_from_files,
)

__all__ = ["GROUPS", "TruthProvider", "default_mechanism", "mechanism_drivers",
           "simulate_rig"]

logger = logging.getLogger(__name__)

#: TDMS group (task name) of each TDMS stream.
GROUPS = {"cdaq": "cDAQ1 task", "wls1": "WLS1 task"}
#: Window of true time (s) the streams are sampled and written in (the truth of a long record is
#: read back from files a window at a time).
WINDOW_S = 60.0
#: Truth grid points solved at a time (the solver needs about 2 kB per point; the model is
#: solved point by point, so the pieces join to rounding, 1e-14 of a signal's range); a grid
#: of more points is computed a piece at a time into files (:func:`_sampled_truth`).
TRUTH_POINTS = 1 << 16
#: Version of the truth file layout.
TRUTH_SCHEMA = "rigval-rig-truth/1"

#: A function giving the model truth grid for a drive motion at uniform true times.
TruthProvider = Callable[[DriveMotion, NDArray[np.float64]], TruthGrid]


def default_mechanism() -> Path:
    """Return the path of rigval's built-in ``pendulum.toml``."""
    return Path(str(resources.files("rigval.model") / "mechanisms" / "pendulum.toml"))


def mechanism_drivers(path: str | Path) -> dict[str, tuple[float, tuple[Harmonic, ...]]]:
    """Read the drivers theta_F and theta_H of a mechanism file as drive-motion parameters.

    Parameters
    ----------
    path : str or Path
        Mechanism file (schema ``rigval-mechanism/1``).

    Returns
    -------
    dict
        ``{name: (theta0, harmonics)}``; each harmonic's order is its angular frequency over the
        main driver's speed.

    Raises
    ------
    ConfigError
        If the file is not a valid mechanism (:class:`~rigval.model.errors.MechanismError`),
        lacks a driver theta_F or theta_H, or a harmonic is not a whole multiple of the main
        speed.
    """
    mechanism = load_mechanism(path)
    missing = sorted({"theta_F", "theta_H"} - set(mechanism.driver_names))
    if missing:
        raise ConfigError(f"mechanism has no driver {missing}; the rig drives theta_F "
                          f"and theta_H", where={"file": str(path), "key": "drivers"})
    excitation = mechanism.excitation("theta_F")
    out = {}
    for name in ("theta_F", "theta_H"):
        law = excitation.law(name)
        for k, term in enumerate(law.harmonics):
            if abs(term.order - round(term.order)) > 1e-9 or round(term.order) < 1:
                raise ConfigError(f"harmonic {k} of {name} turns {term.order:g} times per main "
                                  "revolution, not a whole number",
                                  where={"file": str(path),
                                         "key": f"drivers.{name}.harmonics[{k}]"})
        out[name] = (law.theta0 + law.phase, tuple(
            Harmonic(order=round(h.order), amplitude=h.amplitude, phase=h.phase)
            for h in law.harmonics))
    return out


def _stamp(draw: RigDraw, seconds: float) -> np.datetime64:
    return draw.start_time + np.timedelta64(round(seconds * 1e9), "ns")


class _StreamFiles:
    """Writes the pieces of the rig's streams to their files as they come (bounded memory).

    The cDAQ and WLS #1 go to DAQmx raw TDMS files, WLS #2 to the European CSV; the truth of
    every analog channel goes to one temporary ``.npy`` file each (in ``scratch``, written in
    order, not memory-mapped: :class:`~rigval.sample_data.writers.NpyAppender`), copied into
    the truth ``.npz`` by :meth:`write_truth`.
    """

    def __init__(self, streams: dict[str, Stream], draw: RigDraw, files: RunFiles,
                 scratch: Path) -> None:
        self.streams, self.draw, self.files, self.scratch = streams, draw, files, scratch
        self.truth: dict[str, Path] = {}
        self._truth_files: dict[str, NpyAppender] = {}
        self._tdms: DaqmxTdmsWriter | None = None
        self._csv: Any = None

    def _open(self, name: str) -> None:
        stream = self.streams[name]
        n_total = sum(seg.n_samples for seg in stream.clock.segments)
        for c in stream.channels:
            if c.truth_unit is not None:
                key = f"{name}.{c.name}"
                self.truth[key] = self.scratch / f"{key}.npy"
                self._truth_files[key] = NpyAppender(self.truth[key], n_total,
                                                     np.dtype(np.float32))
        if name == "wls2":
            clock = stream.clock
            first = clock.segments[0]
            start = local_time(_stamp(self.draw, first.true_start + first.stamp_error))
            stamp = start.strftime("%d.%m.%Y %H:%M:%S,") + f"{start.microsecond // 1000:03d}"
            header = [("Device", "WLS-9163 #2, NI 9237 (lifting shafts)"), ("Start time", stamp)]
            self._csv = self.files.path("wls2.csv").open("wb")
            self._csv.write(european_csv_head(
                header, [(c.name, c.unit or "1") for c in stream.channels]).encode("utf-8"))
        else:
            path = self.files.path(f"{name}.tdms")
            self._tdms = DaqmxTdmsWriter(path, file_name=path.stem)

    def close(self) -> None:
        """Close the stream file being written."""
        if self._tdms is not None:
            self._tdms.close()
            self._tdms = None
        if self._csv is not None:
            self._csv.close()
            self._csv = None
        for file in self._truth_files.values():
            file.close()
        self._truth_files = {}

    def write(self, piece: StreamPiece, opening: bool) -> None:
        """Write one piece; ``opening``: the first piece of its stream."""
        if opening:
            self.close()
            self._open(piece.stream)
        stream = self.streams[piece.stream]
        clock = stream.clock
        for key, values in piece.truth.items():
            self._truth_files[f"{piece.stream}.{key}"].append(values)
        for j, (i, k0) in enumerate(piece.parts):
            raw = [piece.raw[c.name][j] for c in stream.channels]
            if self._csv is not None:
                seg, first = clock.segments[i], clock.segments[0]
                time = ((seg.true_start + seg.stamp_error - first.true_start - first.stamp_error)
                        + np.arange(k0, k0 + raw[0].size) / clock.fs_nominal)
                self._csv.write(european_csv_rows(time, [
                    (r.astype(np.float64) * c.slope, "%.6E")
                    for r, c in zip(raw, stream.channels, strict=True)]).encode("utf-8"))
            elif k0 == 0:  # a task start
                seg = clock.segments[i]
                assert self._tdms is not None
                self._tdms.start(Acquisition(
                    GROUPS[stream.name], _stamp(self.draw, seg.true_start + seg.stamp_error),
                    1.0 / clock.fs_nominal,
                    tuple(RawChannel(c.name, r, c.slope, 0.0, c.unit)
                          for r, c in zip(raw, stream.channels, strict=True))))
            else:
                assert self._tdms is not None
                self._tdms.append(raw)

    def write_truth(self, path: Path) -> None:
        """Write the truth ``.npz`` from the temporary files."""
        write_npz_from_files(path, self.truth)


def _truth_record(settings: RigSettings, draw: RigDraw, streams: dict[str, Stream],
                  pulses: dict[str, dict[str, list[float]]], files: RunFiles,
                  references: dict[str, float], mode: dict[str, Any]) -> dict[str, Any]:
    sensors: dict[str, Any] = {**draw.accelerometers, "str1": draw.str1, **draw.bending,
                               **draw.torsion, **draw.encoders, **draw.optical}
    out_streams = {}
    for name, stream in streams.items():
        clock = stream.clock
        file = files.path("wls2.csv" if name == "wls2" else f"{name}.tdms").name
        first = clock.segments[0].true_start + clock.segments[0].stamp_error
        segments = [{"true_start_s": s.true_start, "n_samples": s.n_samples,
                     "stamp_error_s": s.stamp_error,
                     "recorded_start_time": str(_stamp(draw, s.true_start + s.stamp_error)),
                     "device_start_s": s.true_start + s.stamp_error - first}
                    for s in clock.segments]
        gaps = [{"after_true_s": a.true_start + a.n_samples / clock.fs_true,
                 "duration_true_s": b.true_start - a.true_start - a.n_samples / clock.fs_true,
                 "samples_missing": round((b.true_start - a.true_start) * clock.fs_true)
                 - a.n_samples}
                for a, b in zip(clock.segments[:-1], clock.segments[1:], strict=True)]
        out_streams[name] = {
            "file": file, "device": stream.device, "group": GROUPS.get(name),
            "fs_nominal": clock.fs_nominal, "fs_true": clock.fs_true,
            "drift_ppm": clock.drift_ppm, "host_clock_offset_s": clock.host_offset,
            "segments": segments, "gaps": gaps,
            "channels": {c.name: {"module": c.module, "file_unit": c.unit, "slope": c.slope,
                                  "input_delay_s": c.delay, "truth_unit": c.truth_unit,
                                  "sensor": json_ready(sensors[c.name]),
                                  **_channel_departures(draw, c.name)}
                         for c in stream.channels}}
    settings_record = json_ready(dataclasses.replace(settings, mechanism=None))
    extra = {}
    if settings.departures.active:
        extra = {"departures": {**settings.departures.record(), "mode": mode}}
    else:  # the default rig's truth file as before the departures existed
        del settings_record["departures"]
    return {
        "schema": TRUTH_SCHEMA,
        "settings": settings_record,
        "mechanism": str(settings.mechanism) if settings.mechanism else "builtin:pendulum",
        "true_time_zero": str(draw.start_time),
        "time_note": "true time t in s from true_time_zero; sample k of a segment is at "
                     "true_start_s + k / fs_true; a module delays its data by input_delay_s",
        "drive": json_ready(draw.drive),
        "angle_at_reference": references,
        "frame_mode": draw.frame,
        "streams": out_streams,
        "pulses": pulses,
        "arrays": files.path("truth.npz").name,
        **extra,
    }


def _channel_departures(draw: RigDraw, name: str) -> dict[str, float]:
    """Return a channel's undeclared lag and calibration error, where the rig has them."""
    out = {}
    if name in draw.lags:
        out["lag_s"] = draw.lags[name]
    if name in draw.calibration_error:
        out["calibration_error"] = draw.calibration_error[name]
    return out


def _references(drive: DriveMotion) -> dict[str, float]:
    """Drive angles at the main reference pulse and phi_F at the lifting-shaft pulse (rad)."""
    t_ref = drive.crossing_times("theta_F", np.array([drive.theta_f0]))
    angles = drive.angles(t_ref)
    t_lift = drive.crossing_times("theta_H", np.array([drive.theta_h0]))
    phi_f = drive.angles(t_lift)["theta_F"][0][0] - drive.theta_f0
    return {"theta_F": float(np.mod(angles["theta_F"][0][0], 2.0 * np.pi)),
            "theta_H": float(np.mod(angles["theta_H"][0][0], 2.0 * np.pi)),
            "opt3_phi_F": float(np.mod(phi_f + np.pi, 2.0 * np.pi) - np.pi)}


def _truth_grid(provider: TruthProvider, drive: DriveMotion,
                t_grid: NDArray[np.float64]) -> TruthGrid:
    """Return the model truth on ``t_grid``, solved :data:`TRUTH_POINTS` points at a time."""
    if t_grid.size <= TRUTH_POINTS:
        return provider(drive, t_grid)
    values: dict[str, NDArray[np.float64]] = {}
    for i in range(0, t_grid.size, TRUTH_POINTS):  # filled in place: no second copy
        part = provider(drive, t_grid[i:i + TRUTH_POINTS])
        for name, array in part.values.items():
            values.setdefault(name, np.empty(t_grid.size))[i:i + array.size] = array
    return TruthGrid(t_grid, values)


def _sampled_truth(settings: RigSettings, draw: RigDraw, provider: TruthProvider,
                   grid: UniformGrid, record: tuple[float, float], scratch: Path
                   ) -> tuple[SampledTruth | TruthStore, dict[str, Any]]:
    """Return the truth the channels are sampled from, and the flexible mode's truth.

    A grid of up to :data:`TRUTH_POINTS` points (a record up to about 50 s: the shipped runs)
    is computed whole in memory; a longer one goes to files in ``scratch`` a piece at a time
    (:func:`~rigval.sample_data.truth_store.store_truth`), unless the departures have a
    flexible mode, whose level is set from the whole record.
    """
    departures, seed = settings.departures, settings.seed
    area, modulus = draw.str1.area, draw.str1.youngs_modulus
    if grid.n > TRUTH_POINTS and departures.mode_body is None:
        def piece_truth(t: NDArray[np.float64]) -> TruthGrid:
            return departed_grid(provider(draw.drive, t), departures, seed, record, area,
                                 modulus)[0]

        return store_truth(piece_truth, draw, grid, TRUTH_POINTS, scratch), {}
    whole = _truth_grid(provider, draw.drive, grid.times(0, grid.n))
    whole, mode = departed_grid(whole, departures, seed, record, area, modulus)
    # what only the departures needed is let go before the streams are sampled (at 1 kHz, 8 kB
    # per quantity and second of record)
    whole = TruthGrid(whole.t, {name: values for name, values in whole.values.items()
                                if name in SAMPLED_QUANTITIES})
    return sampled_truth(draw, whole), mode


def _scaled_mechanism(path: Path, mass_scale: tuple[tuple[str, float], ...]
                      ) -> Path | dict[str, Any]:
    """Return the mechanism file, or its content with some bodies' masses scaled.

    Raises
    ------
    ConfigError
        If a scaled body is not in the mechanism.
    """
    if not mass_scale:
        return path
    data = tomllib.loads(path.read_text(encoding="utf-8"))
    bodies = {body["name"]: body for body in data.get("bodies", [])}
    for name, factor in mass_scale:
        if name not in bodies:
            raise ConfigError(f"no body {name!r} to make heavier",
                              where={"file": str(path), "key": f"mass_scale.{name}"},
                              hint=f"use one of {sorted(bodies)}")
        bodies[name]["mass"] = bodies[name]["mass"] * factor
    return data


def simulate_rig(out_dir: str | Path, settings: RigSettings | None = None, *,
                 truth: TruthProvider | None = None) -> RunFiles:
    """Run the virtual rig and write one run folder.

    Parameters
    ----------
    out_dir : str or Path
        Folder to write into (created if needed; files of the same stem are overwritten).
    settings : RigSettings, optional
        Speed, duration, seed and imperfections; default ``RigSettings()``.
    truth : callable, optional
        ``truth(drive, t) -> TruthGrid``: the model truth along the drive motion at uniform true
        times. Default: :func:`rigval.sample_data.truth.model_truth` on the settings' mechanism.

    Returns
    -------
    RunFiles
        The paths written.
    """
    settings = settings or RigSettings()
    mechanism = Path(settings.mechanism) if settings.mechanism else default_mechanism()
    draw = draw_rig(settings, mechanism_drivers(mechanism))
    starts = [c.segments[0].true_start for c in draw.clocks.values()]
    stops = [c.segments[-1].true_start + c.segments[-1].n_samples / c.fs_true
             for c in draw.clocks.values()]
    t0 = min(starts) - settings.preroll
    n = int(np.ceil((max(stops) + 0.5 - t0) * settings.truth_fs)) + 1
    grid = UniformGrid(t0, settings.truth_fs, n)
    source = _scaled_mechanism(mechanism, settings.departures.mass_scale)
    provider = truth or (lambda drive, t: model_truth(source, drive, t))

    folder = Path(out_dir)
    folder.mkdir(parents=True, exist_ok=True)
    files = RunFiles(folder, run_stem(settings.speed))
    with tempfile.TemporaryDirectory(dir=folder, prefix=".truth-") as scratch:
        sampled, mode = _sampled_truth(settings, draw, provider, grid, (min(starts), max(stops)),
                                       Path(scratch))
        streams, pulses, pieces = stream_pieces(draw, sampled, window_s=WINDOW_S)
        injector = FaultInjector(settings.faults, streams, settings.seed)
        sink = _StreamFiles(streams, draw, files, Path(scratch))
        written: set[str] = set()
        try:
            for piece in pieces:
                sink.write(injector.apply(piece), opening=piece.stream not in written)
                written.add(piece.stream)
        finally:
            sink.close()
        sink.write_truth(files.path("truth.npz"))
    references = _references(draw.drive)
    record = _truth_record(settings, draw, streams, pulses, files, references, mode)
    if settings.faults:
        record["faults"] = injector.records()
    else:  # a run without faults writes the truth it wrote before faults existed
        record["settings"].pop("faults", None)
    write_json(files.path("truth.json"), record)
    write_text_atomic(files.path("scene.toml"), scene_text(settings, draw, files, references))
    write_text_atomic(files.path("note.txt"), note_text(settings, draw, streams, files))
    logger.info("virtual rig run written to %s (%s_*)", folder, files.stem)
    return files
