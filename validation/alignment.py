"""A scene's ``[alignment]`` table as the plain settings the alignment in processing takes.

The work (phi_F, clock fits, diagnostics) is
:func:`rigval.processing.stream_alignment.align_streams`; this adapter only looks the scene's
channel references up (docs/scene.md, ``[alignment]``).
"""

from __future__ import annotations

from rigval.processing.stream_alignment import AlignmentSettings, ClockSettings
from rigval.validation.scene_types import Scene

__all__ = ["alignment_settings"]


def alignment_settings(scene: Scene) -> AlignmentSettings:
    """Return the scene's alignment settings with its channel references resolved.

    The main encoder's direction is that of the drivers it feeds (+1 when none does); the
    reference stream must hold ``[angle] min_cycles`` good reference pulses.
    """
    table = scene.alignment
    directions = [d.direction for d in scene.model.drivers.values()
                  if d.encoder == table.main_encoder]
    streams = {
        name: ClockSettings(
            method="stamps" if pulse.method == "stamps" else "pulses",
            pulse=scene.channel(pulse.channel) if pulse.channel is not None else None,
            per_revolution=pulse.per_revolution, angle=pulse.angle,
            coarse_offset_s=pulse.coarse_offset_s,
            start_time_uncertainty_s=pulse.start_time_uncertainty_s,
            key=f"alignment.pulses.{name}")
        for name, pulse in table.pulses.items()}
    return AlignmentSettings(
        reference=table.reference, encoder=scene.channel(table.main_encoder),
        reference_pulse=scene.channel(table.main_reference_pulse), streams=streams,
        direction=float(directions[0] if directions else 1), min_pulses=scene.angle.min_cycles,
        key="alignment")
