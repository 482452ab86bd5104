"""Convert a run's raw channels to physical units and put every device on one timeline.

Usage: python convert_and_align.py [SCENE]
(default: the first sample run shipped with rigval)

Prints each device's clock model (offset, drift, fit residual, matched reference pulses) and the
torque of shaft tor1 at the first reference pulse after alignment.
"""

import sys
from pathlib import Path

import numpy as np

from rigval.processing.clock_fit import channel_time
from rigval.processing.stream_alignment import align_streams
from rigval.sample_data import shipped_runs
from rigval.validation.read_plan import read_streams
from rigval.validation.scene import load_scene
from rigval.validation.stage_settings import alignment_settings, convert_stream


def main(scene_path: Path) -> None:
    scene = load_scene(scene_path)
    raw = read_streams(scene)
    physical = {name: convert_stream(raw[name], spec) for name, spec in scene.streams.items()}
    aligned, clocks, main_angle = align_streams(alignment_settings(scene), physical)
    for name, clock in clocks.items():
        print(f"{name:5s} offset {clock.offset_s:+.6f} s  drift {clock.drift_ppm:+7.2f} ppm  "
              f"residual {clock.residual_rms_s * 1e6:6.1f} us  {clock.events_matched} pulses "
              f"matched, {len(clock.gaps)} gaps")
    first_pulse = np.interp(2 * np.pi * np.ceil(main_angle.phi[0] / (2 * np.pi)),
                            main_angle.phi, main_angle.time)
    for ref in (c.measured for c in scene.comparisons):
        stream = aligned[ref.stream]
        value = np.interp(first_pulse, channel_time(stream, ref.channel),
                          stream[ref.channel].to_numpy())
        print(f"{ref}: {value:.4g} {stream[ref.channel].attrs['units']} at the reference "
              f"position (t = {first_pulse:.4f} s)")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else shipped_runs()[0])
