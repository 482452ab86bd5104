"""The parts the stream-set alignment is built from: stamps, the outlier rule, channel selection."""

from __future__ import annotations

import numpy as np
import pytest

from rigval.acquisition.devices import get_device
from rigval.acquisition.errors import ChannelNotFoundError
from rigval.acquisition.schema import Channel, stream_dataset
from rigval.processing import event_match, selection, stamps

FS = 100.0


def _stream(device: str, start: str, seconds: float, **channels: np.ndarray):
    n = int(seconds * FS)
    return stream_dataset(
        np.arange(n) / FS,
        {name: Channel(values[:n], "V", name, name) for name, values in channels.items()},
        device=device, start_time=start, source_file=f"{device}.csv", source_sha256="0" * 64,
        fs_nominal=FS)


def test_coarse_offset_from_stamps_given_offset_and_no_start_time() -> None:
    ones = np.ones(10_000)
    ref = _stream("cDAQ-9172", "2026-03-02T10:00:00.000Z", 20.0, a=ones)
    dev = _stream("WLS-9163", "2026-03-02T10:00:02.250Z", 10.0, b=ones)
    bounds = (get_device("cDAQ-9172").start_time_uncertainty_s
              + get_device("WLS-9163").start_time_uncertainty_s)

    by_stamps = stamps.coarse_offset(ref, dev)
    assert by_stamps.offset_s == pytest.approx(2.25, abs=1e-9)
    assert by_stamps.window_s == pytest.approx(bounds)
    assert by_stamps.source == "start stamps"

    given = stamps.coarse_offset(ref, dev, offset_s=-1.5, uncertainty_s=0.3)
    assert (given.offset_s, given.window_s, given.source) == (-1.5, 0.3, "given offset")

    # NI's 1904 epoch means "no start time": the whole overlap is searched, i.e. the window
    # reaches from the device record's start at the reference's start to its end at the end.
    unknown = _stream("WLS-9163", "1904-01-01T00:00:00Z", 10.0, b=ones)
    blind = stamps.coarse_offset(ref, unknown)
    ref_span, dev_span = 19.99, 9.99
    assert blind.source == "no start time"
    assert blind.offset_s - blind.window_s == pytest.approx(-dev_span)
    assert blind.offset_s + blind.window_s == pytest.approx(ref_span)


def test_robust_inliers_cut_at_five_robust_sigmas_with_a_floor() -> None:
    rng = np.random.default_rng(3)
    residual = rng.normal(0.0, 1e-6, 2000)
    sigma = 1.4826 * np.median(np.abs(residual - np.median(residual)))
    residual[:3] = np.median(residual) + np.array([4.5, 5.5, -8.0]) * sigma
    keep = event_match.robust_inliers(residual)
    assert keep[0] and not keep[1] and not keep[2]
    # about 0.6 per million Gaussian residuals lie beyond 5 sigma: none of these 1997
    assert keep[3:].all()
    assert event_match.robust_inliers(residual, floor_s=1e-3).all()
    # the scale comes from the chosen residuals only; NaN is never kept
    among = np.zeros(residual.size, dtype=bool)
    among[100:] = True
    residual[50] = np.nan
    keep = event_match.robust_inliers(residual, among=among)
    assert not keep[50] and not keep[1]


def test_selected_channels_prefix_shared_names_and_name_what_is_missing() -> None:
    ones = np.ones(100)
    aligned = {"cdaq": _stream("cDAQ-9172", "2026-03-02T10:00:00Z", 1.0, acc=ones, enc=ones),
               "wls": _stream("WLS-9163", "2026-03-02T10:00:00Z", 1.0, acc=ones, tor=ones)}
    assert selection.selected_channels(aligned) == [
        ("cdaq", "acc", "cdaq_acc"), ("cdaq", "enc", "enc"),
        ("wls", "acc", "wls_acc"), ("wls", "tor", "tor")]
    assert selection.selected_channels(aligned, {"wls": ["acc"]}) == [("wls", "acc", "acc")]
    with pytest.raises(ChannelNotFoundError) as info:
        selection.selected_channels(aligned, {"wls": ["enc"]})
    assert info.value.where["channel"] == "enc"
    with pytest.raises(ChannelNotFoundError, match="no aligned stream 'lvm'"):
        selection.selected_channels(aligned, {"lvm": ["acc"]})
