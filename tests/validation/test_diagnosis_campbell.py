"""Campbell diagram: a mode keeps its frequency across speeds, order content keeps its order."""

from __future__ import annotations

import numpy as np
import pytest

from rigval.sample_data import Imperfections, RigSettings, simulate_rig
from rigval.sample_data.departures import Departures
from rigval.validation.campaign.engine import RunOutcome
from rigval.validation.campaign.report import campbell_diagrams, write_campaign_report
from rigval.validation.diagnosis.campbell import RunSpectrum, campbell, plot_campbell
from rigval.validation.diagnosis.modes import Resonance
from rigval.validation.run.validate import validate_scene


def _res(hz, speed, u=0.05, zeta=0.02):
    return Resonance(hz, u, zeta, 0.004, 1.0, 0.1, 0.5, 100.0, hz / speed)


def _run(speed, *resonances):
    f = np.linspace(0.0, 40.0, 321)
    return RunSpectrum(f"r{speed}", speed, f, np.ones_like(f), tuple(resonances))


def test_constant_frequency_is_a_mode_and_constant_order_is_order_content():
    runs = [_run(s, _res(21.0 + d, s), _res(14.0 * s + e, s, u=0.02))
            for s, d, e in ((0.8, 0.03, 0.01), (1.0, -0.04, -0.02), (1.2, 0.02, 0.0))]
    diagram = campbell("str1", "Pa", runs)
    kinds = {line.kind: line for line in diagram.lines}
    assert set(kinds) == {"structural mode", "order content"}
    mode = kinds["structural mode"]
    assert mode.frequency_hz == pytest.approx(21.0, abs=0.05)
    assert len(mode.speeds) == 3
    assert kinds["order content"].order == pytest.approx(14.0, abs=0.05)
    assert "structural mode at 21.0" in diagram.sentence
    plot_campbell(diagram)  # draws without error


def test_two_speeds_or_a_wandering_peak_name_nothing():
    two = campbell("x", "1", [_run(0.8, _res(21.0, 0.8)), _run(1.0, _res(21.0, 1.0))])
    assert two.lines == ()
    # a peak neither constant in Hz nor in order: 16, 21, 27 Hz at 0.8, 1.0, 1.2 rev/s
    wander = campbell("x", "1", [_run(0.8, _res(16.0, 0.8)), _run(1.0, _res(21.0, 1.0)),
                                 _run(1.2, _res(27.0, 1.2))])
    assert wander.lines == ()


@pytest.mark.slow
def test_campaign_page_separates_the_rig_mode_from_the_orders(tmp_path):
    outcomes = []
    for k, speed in enumerate((0.8, 1.0, 1.2)):
        # no Wi-Fi dropout: a 10 s record keeps its revolutions whole
        settings = RigSettings(speed=speed, duration=10.0, seed=31 + k,
                               imperfections=Imperfections(dropouts=0), departures=Departures(
            mode_body="B", mode_hz=21.4, mode_damping=0.025, mode_level=0.06))
        files = simulate_rig(tmp_path / "data", settings)
        run_dir = tmp_path / "campaign" / files.stem
        result = validate_scene(files.path("scene.toml"), run_dir)
        outcomes.append(RunOutcome(files.stem, files.path("scene.toml"), run_dir,
                                   "passed" if result.passed else "failed",
                                   speed_rev_s=result.speed_rev_s,
                                   outputs=tuple(p.name for p in result.outputs)))
    diagrams = {d.name: d for d in campbell_diagrams(outcomes)}
    modes = diagrams["str1"].modes
    assert len(modes) == 1 and modes[0].frequency_hz == pytest.approx(21.4, rel=0.02)
    # the torques see no mode of rod B
    assert diagrams["tor1"].modes == ()
    files = write_campaign_report(outcomes, tmp_path / "campaign")
    html = files.html.read_text()
    assert "Campbell diagram" in html and "structural mode at 21." in html
