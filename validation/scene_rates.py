"""Scene frequencies checked against the sampling rates, once the streams have been read.

A scene states corner frequencies before any file is read; whether they fit is known only from
each stream's nominal rate ``fs_nominal``. :func:`check_sample_rates` names the scene key of the
first corner that does not fit:

``streams.S.channels.C.highpass_hz``
    The charge amplifier's high-pass corner must lie below the Nyquist frequency fs/2 of its
    stream (the digital inverse of the high-pass is defined only there).
``comparisons[i].lowpass_hz``
    The zero-phase low-pass of the measured signal must lie below 0.45 fs of the measured stream:
    the validation applies it only there (above, the Butterworth design degenerates next to
    Nyquist and the anti-alias filter of the angle resampling already limits the band).
"""

from __future__ import annotations

import contextlib
import logging
from collections.abc import Iterator, Mapping

import xarray as xr

from rigval.acquisition.errors import ConfigError
from rigval.validation.errors import SceneError
from rigval.validation.scene_types import Scene

__all__ = ["LOWPASS_FRACTION", "check_sample_rates", "encoder_scale_errors"]

logger = logging.getLogger(__name__)

#: Largest comparison low-pass corner as a fraction of the measured stream's rate.
LOWPASS_FRACTION = 0.45


def _rate(streams: Mapping[str, xr.Dataset], name: str) -> float | None:
    value = streams[name].attrs.get("fs_nominal") if name in streams else None
    return float(value) if value is not None and float(value) > 0 else None


def check_sample_rates(scene: Scene, streams: Mapping[str, xr.Dataset]) -> None:
    """Raise a SceneError naming the key of a corner frequency its stream's rate cannot carry.

    Parameters
    ----------
    scene : Scene
        The scene.
    streams : mapping of str to xarray.Dataset
        The streams as read (attribute ``fs_nominal`` in Hz); streams without a nominal rate
        (irregular time stamps) are not checked.

    Raises
    ------
    SceneError
        ``where["key"]`` is the scene key; the message gives the limit in Hz.
    """
    for name, spec in scene.streams.items():
        fs = _rate(streams, name)
        if fs is None:
            continue
        for channel in spec.channels.values():
            corner = channel.params.get("highpass_hz")
            if corner is not None and corner >= fs / 2:
                key = f"{channel.key}.highpass_hz"
                raise SceneError(
                    f"{key}: {corner:g} Hz is not below fs/2 = {fs / 2:g} Hz of stream {name!r} "
                    f"({spec.file.name} at {fs:g} Hz)", where={"key": key, "file": spec.file},
                    hint="give the amplifier's high-pass corner in Hz (typically 0.1 to 10 Hz)")
    for comparison in scene.comparisons:
        fs = _rate(streams, comparison.measured.stream)
        corner = comparison.lowpass_hz
        if fs is None or corner is None:
            continue
        limit = LOWPASS_FRACTION * fs
        if corner >= limit:
            key = f"{comparison.key}.lowpass_hz"
            raise SceneError(
                f"{key}: {corner:g} Hz is not below {LOWPASS_FRACTION:g} fs = {limit:g} Hz of "
                f"stream {comparison.measured.stream!r} (fs = {fs:g} Hz, Nyquist {fs / 2:g} Hz)",
                where={"key": key}, hint=f"give a corner below {limit:g} Hz, or remove the key "
                                         "to compare the unfiltered signal")


@contextlib.contextmanager
def encoder_scale_errors(scene: Scene) -> Iterator[None]:
    """Name the encoders' ``counts_per_rev`` keys when a drive filter corner cannot be designed.

    The drive-angle filter corner is 8 times the measured revolution rate; a corner above fs/2
    means the encoder counts far more per revolution than ``counts_per_rev`` says (or the rate
    is wrong). The processing error names its internal ``cutoff_hz``; this re-raises it as a
    SceneError with the scene keys to check.
    """
    try:
        yield
    except ConfigError as error:
        if error.where.get("key") != "cutoff_hz":
            raise
        refs = [scene.alignment.main_encoder] + [d.encoder for d in scene.model.drivers.values()]
        keys = list(dict.fromkeys(f"{scene.channel(ref).key}.counts_per_rev" for ref in refs))
        values = ", ".join(f"{key} = {scene.channel(ref).params['counts_per_rev']}"
                           for key, ref in zip(keys, refs, strict=False))
        raise SceneError(
            f"the drive speed from the encoders is implausibly high ({error.message}); the "
            f"encoder scale is probably wrong: {values}", where={"key": keys[0], "keys": keys},
            hint="give counts per revolution after x4 decoding (lines per revolution times 4)"
        ) from error
