"""The scene's types: one validation case as frozen dataclasses (format ``rigval-scene/1``).

:mod:`rigval.validation.scene` reads a scene file into these. Each spec's fields are its TOML
table's keys, and a field's default is the key's default: the parser takes both from here, so
each setting is written once. A field whose metadata has ``toml=False`` is filled by the parser
(the key path, the channels summed) and is not a key of the file. Every key is described in
``docs/scene.md``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any, Literal

from rigval.acquisition.channel_map import ChannelSpec, StreamSpec
from rigval.model.output_values import ModelOutput
from rigval.model.results import COMPARABLE, QUANTITIES
from rigval.processing.sensors import channel_units
from rigval.validation.metrics.compare import DEFAULT_METRICS

__all__ = [
    "MODEL_QUANTITIES",
    "NOT_A_KEY",
    "SCHEMA",
    "AlignmentSpec",
    "AngleSpec",
    "ChannelRef",
    "ComparisonSpec",
    "DriverSpec",
    "ModelSpec",
    "OutputSpec",
    "PredictionSpec",
    "PulseSpec",
    "Scene",
    "SymmetrySpec",
]

#: Field metadata of a field the parser fills that is not a key of the scene file.
NOT_A_KEY: Mapping[str, bool] = MappingProxyType({"toml": False})


def _no_entries() -> Mapping[str, Any]:
    """Return the default of a table of entries: an empty read-only mapping."""
    return MappingProxyType({})

SCHEMA = "rigval-scene/1"


#: Model quantities a comparison may name (docs/model.md, *Result contract*; the table is
#: :data:`rigval.model.results.QUANTITIES`): item kind, axes, unit per axis.
MODEL_QUANTITIES: Mapping[str, tuple[str, tuple[str, ...] | None, Mapping[str, str]]] = (
    MappingProxyType({name: (str(QUANTITIES[name].item), QUANTITIES[name].axes,
                             QUANTITIES[name].units) for name in COMPARABLE}))


@dataclass(frozen=True)
class ChannelRef:
    """A ``"stream.channel"`` reference.

    Parameters
    ----------
    stream : str
        Stream name (a ``[streams.X]`` table).
    channel : str
        Channel name within it.
    """

    stream: str
    channel: str

    def __str__(self) -> str:
        return f"{self.stream}.{self.channel}"


@dataclass(frozen=True)
class PulseSpec:
    """A non-reference stream's reference pulse channel.

    Parameters
    ----------
    channel : ChannelRef or None
        The pulse channel (None with ``method = "stamps"``).
    per_revolution : int, default 1
        Pulses per main-shaft revolution (2 for a lifting shaft turning twice as fast).
    angle : float
        phi_F in rad at which the sensor fires (its mounting position; 0 at the reference).
    method : str, default "pulses"
        ``"pulses"``: the clock is fitted on the pulse channel; ``"stamps"``: the stream's clock
        is synchronised with the reference's (same chassis, NTP/PTP) and its start stamp is
        used as it is, with ``start_time_uncertainty_s`` carried into the results.
    coarse_offset_s : float or None
        ``t_ref - t_stream`` in s to search around instead of the start stamps' difference (for
        a stream whose stamp is known to be wrong).
    start_time_uncertainty_s : float or None
        Bound in s of the error of the stream's start stamp relative to the reference's (or of
        ``coarse_offset_s``); None: the sum of both device profiles' bounds.
    """

    channel: ChannelRef | None = None
    per_revolution: int = 1
    angle: float = 0.0
    method: Literal["pulses", "stamps"] = "pulses"
    coarse_offset_s: float | None = None
    start_time_uncertainty_s: float | None = None


@dataclass(frozen=True)
class AlignmentSpec:
    """How the streams' clocks are brought onto the reference stream's timeline.

    Parameters
    ----------
    reference : str
        Stream whose clock is the timeline.
    main_encoder : ChannelRef
        Main-shaft encoder: phi_F(t).
    main_reference_pulse : ChannelRef
        Once-per-revolution pulse on the reference stream: phi_F = 0 at its rising edge.
    pulses : mapping of str to PulseSpec
        Per other stream, its pulse channel.
    """

    reference: str
    main_encoder: ChannelRef
    main_reference_pulse: ChannelRef
    pulses: Mapping[str, PulseSpec] = field(default_factory=_no_entries)


@dataclass(frozen=True)
class AngleSpec:
    """The uniform phi_F grid on which measurement and model are compared.

    Parameters
    ----------
    points_per_revolution : int
        Grid points per revolution (360 is 1 degree).
    interpolation : {"linear", "cubic"}
        Interpolation of amplitudes when resampling onto the grid.
    min_cycles : int
        Fewest whole revolutions a run must contain.
    """

    points_per_revolution: int = 360
    interpolation: Literal["linear", "cubic"] = "cubic"
    min_cycles: int = 3


@dataclass(frozen=True)
class DriverSpec:
    """How a model driver follows a measured encoder (``drives = "measured"``).

    Parameters
    ----------
    name : str
        Driver name in the mechanism file.
    encoder : ChannelRef
        Encoder channel measuring the driven shaft.
    angle_at_reference : float
        Driver angle in rad when the main reference pulse fires (phi_F = 0).
    direction : {1, -1}
        +1 when the driver angle grows with the encoder count.
    """

    name: str = field(metadata=NOT_A_KEY)
    encoder: ChannelRef
    angle_at_reference: float
    direction: Literal[1, -1] = 1


@dataclass(frozen=True)
class ModelSpec:
    """The model side: which mechanism and how its drives are excited.

    Parameters
    ----------
    drives : {"measured", "analytic"}
        ``"measured"``: drive angles identified from the encoders; ``"analytic"``: the mechanism
        file's drive laws.
    drivers : mapping of str to DriverSpec
        Per driver (``drives = "measured"`` only).
    """

    drives: Literal["measured", "analytic"] = "analytic"
    drivers: Mapping[str, DriverSpec] = field(default_factory=_no_entries)


@dataclass(frozen=True)
class ComparisonSpec:
    """One measured channel against one model quantity.

    Parameters
    ----------
    name : str
        Unique name; titles the report section.
    measured : ChannelRef
        The measured channel, in its converted unit.
    model : rigval.model.output_values.ModelOutput
        The model quantity.
    key : str
        Key path, e.g. ``comparisons[0]``.
    scale : float
        The model value times ``scale`` is compared (sign, share of a torque, 1/area).
    scale_units : str
        Unit of ``scale`` (``"1"`` unless it changes the unit, e.g. ``"m-2"``).
    lowpass_hz : float or None
        Zero-phase low-pass cut-off for the measured signal in Hz (None: unfiltered).
    remove_offset : bool
        Add the difference of the measured mean's and the model's averages over a revolution to
        the model (sensors with an unknown zero, such as AC-coupled accelerometers); reported.
    metrics : tuple of str
        Metrics to compute (names of :data:`rigval.validation.metrics.compare.METRICS`); ASME V&V 20
        on the peak and RMS features always runs in addition.
    uncertainty : mapping of str to float
        Systematic uncertainties for V&V 20 (``u_input``, ``u_measurement`` in the signal's
        unit, ``u_measurement_rel`` as a fraction, coverage factor ``k``); the random part comes
        from the cycles and ``u_num`` from the angle-grid error.
    nrmse_normaliser : {"range", "rms", "peak"}
        Normaliser of the NRMSE.
    thresholds : mapping of str to str
        Pass/fail criteria: score name to threshold text (``">= 0.8"``, ``"abs <= 0.1"``).
    summed : tuple of ChannelRef
        Further channels of the same stream and unit added to ``measured`` before comparing
        (``measured = ["wls1.tor1", "wls1.tor2"]``: both shafts' torques against the whole drive
        torque); empty for one channel.
    signs : tuple of float
        The sign of each of ``summed`` (``-1.0`` for a subtracted channel); empty when every
        channel is added.
    """

    name: str
    measured: ChannelRef
    model: ModelOutput
    key: str = field(metadata=NOT_A_KEY)
    scale: float = 1.0
    scale_units: str = "1"
    lowpass_hz: float | None = None
    remove_offset: bool = False
    metrics: tuple[str, ...] = DEFAULT_METRICS
    uncertainty: Mapping[str, float] = field(default_factory=_no_entries)
    nrmse_normaliser: Literal["range", "rms", "peak"] = "range"
    thresholds: Mapping[str, str] = field(default_factory=_no_entries)
    summed: tuple[ChannelRef, ...] = field(default=(), metadata=NOT_A_KEY)
    signs: tuple[float, ...] = field(default=(), metadata=NOT_A_KEY)

    @property
    def terms(self) -> tuple[tuple[float, ChannelRef], ...]:
        """The measured signal as (sign, channel) terms: ``measured`` first, then ``summed``."""
        signs = self.signs or (1.0,) * len(self.summed)
        return ((1.0, self.measured), *zip(signs, self.summed, strict=True))

    @property
    def measured_text(self) -> str:
        """The measured signal as written: ``wls1.tor1 + wls1.tor2``."""
        text = str(self.measured)
        for sign, ref in self.terms[1:]:
            text += f" {'-' if sign < 0 else '+'} {ref}"
        return text


@dataclass(frozen=True)
class SymmetrySpec:
    """Two comparisons a symmetric planar model treats as equal (``[[symmetry]]``).

    Parameters
    ----------
    name : str
        Name of the pair in the report.
    comparisons : tuple of str
        The two comparisons, same unit, e.g. the two shafts of a drive.
    u_measurement_rel : float
        Each channel's relative calibration standard uncertainty (1 %: 0.01), required.
    key : str
        Key path in the scene file (``symmetry[0]``).
    kind : "shares" or "faces"
        ``shares``: each carries half of their sum (two shafts, a left and a right gauge): their
        shares, lag and asymmetry are reported (:func:`rigval.validation.diagnosis.symmetry.
        pair_shares`). ``faces``: gauges on opposite faces of a rod: the axial part is their
        mean, the bending part half their difference
        (:func:`rigval.validation.diagnosis.symmetry.axial_bending`).
    u_measurement_rel_common : float, default 0
        The part of it common to both (one gauge lot, one drawing); it cancels in the
        comparison of the two.
    """

    name: str
    comparisons: tuple[str, str]
    u_measurement_rel: float
    key: str = field(metadata=NOT_A_KEY)
    kind: Literal["shares", "faces"] = "shares"
    u_measurement_rel_common: float = 0.0


@dataclass(frozen=True)
class PredictionSpec:
    """Model outputs reported without a measured counterpart (the paper's figs. 15-17).

    Parameters
    ----------
    points : tuple of str
        Points whose position, speed and acceleration are shown.
    supports : tuple of str or None
        Ground joints whose support force (force on the frame) is shown; None: every ground pin.
    """

    points: tuple[str, ...] = ()
    supports: tuple[str, ...] | None = None


@dataclass(frozen=True)
class OutputSpec:
    """What the run's netCDF file keeps besides the angle domain, the model and the verdicts.

    Parameters
    ----------
    raw : bool, default False
        Keep every stream as read (``/raw/<stream>``, float32): about 4 bytes per sample.
    aligned : bool, default False
        Keep every stream converted and on the reference timeline (``/aligned/<stream>``).
    """

    raw: bool = False
    aligned: bool = False


@dataclass(frozen=True)
class Scene:
    """A parsed, checked scene.

    Parameters
    ----------
    path : pathlib.Path
        The scene file.
    text : str
        Its text as read (copied into the netCDF file and the report).
    sha256 : str
        SHA-256 of the text (UTF-8).
    title : str
        Human-readable title.
    mechanism : pathlib.Path
        The mechanism file (``builtin:NAME`` resolved).
    note : pathlib.Path or None
        The operator's note for the run.
    streams : mapping of str to StreamSpec
        Streams by name.
    alignment : AlignmentSpec
        Clock alignment.
    angle : AngleSpec
        The comparison grid.
    model : ModelSpec
        Drive excitation.
    comparisons : tuple of ComparisonSpec
        What is compared.
    predictions : PredictionSpec
        What is predicted beyond the comparisons.
    output : OutputSpec
        What the netCDF file keeps besides the angle domain (``[output]``).
    symmetry : tuple of SymmetrySpec
        Pairs of comparisons a symmetric planar model treats as equal (``[[symmetry]]``).
    """

    path: Path = field(metadata=NOT_A_KEY)
    text: str = field(repr=False, metadata=NOT_A_KEY)
    sha256: str = field(metadata=NOT_A_KEY)
    title: str
    mechanism: Path
    note: Path | None
    streams: Mapping[str, StreamSpec]
    alignment: AlignmentSpec
    angle: AngleSpec
    model: ModelSpec
    comparisons: tuple[ComparisonSpec, ...]
    predictions: PredictionSpec
    output: OutputSpec = OutputSpec()
    symmetry: tuple[SymmetrySpec, ...] = ()

    @property
    def input_files(self) -> tuple[Path, ...]:
        """Every file the validation reads: data files, mechanism, note."""
        files = [spec.file for spec in self.streams.values()] + [self.mechanism]
        return tuple(files + ([self.note] if self.note else []))

    def channel(self, ref: ChannelRef) -> ChannelSpec:
        """Return the channel a reference names."""
        return self.streams[ref.stream].channels[ref.channel]

    def units(self, ref: ChannelRef) -> str:
        """Return the unit of a channel after conversion."""
        return channel_units(self.channel(ref))


