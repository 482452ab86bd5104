"""Counts per turn of an index-reset encoder, as the file survey estimates them.

The highest count seen plus one (the old estimate) is low whenever the counter advances several
counts per sample: the count just below the reload, ``cpr - 1``, is then skipped most turns. The
counters here are built from a known ``cpr`` and speed, so the expected value is exact; each case
also checks that the highest count plus one is wrong, so the test could not pass by it.
"""

from __future__ import annotations

import numpy as np
import pytest

from rigval.acquisition.survey import classify_channel
from rigval.sample_data.sensors import Encoder


def _counter(cpr: int, per_sample: float, turns: float, start: float,
             from_task_start: bool) -> np.ndarray:
    """Counts of a counter reloaded to 0 at each index; ``start`` turns past the index at t = 0.

    ``from_task_start``: before the first index the counter counts from 0 where the task started
    (as NI-DAQmx does); otherwise it already reads the counts past the index.
    """
    position = start * cpr + per_sample * np.arange(round(turns * cpr / per_sample))
    counts = np.floor(np.mod(position, cpr))
    if from_task_start:
        before = position < cpr
        counts[before] = np.floor(position[before]) - np.floor(start * cpr)
    return counts


#: (counts per turn, counts per sample, whether the highest count + 1 is low): where the turn
#: is a whole number of samples every turn skips the same counts below the reload.
CASES = [(4096, 1.0, False), (3000, 3.0, True), (4096, 4.0, True), (7300, 7.3, True),
         (2500, 3.0, False), (5000, 7.3, True)]


@pytest.mark.parametrize(("cpr", "per_sample", "old_low"), CASES)
@pytest.mark.parametrize("from_task_start", [False, True])
def test_counts_per_turn_at_several_counts_per_sample(cpr: int, per_sample: float, old_low: bool,
                                                      from_task_start: bool) -> None:
    counts = _counter(cpr, per_sample, 5.6, 0.3, from_task_start)
    t = np.arange(counts.size) / 1000.0
    guess, _ = classify_channel("enc", counts, "1", t)
    assert guess.role == "encoder"
    # whole counts per sample: every reading has the same fraction, the estimate is exact;
    # otherwise one count either way at most (exact where the turns' phases differ)
    assert guess.index_counts_tol <= (0 if per_sample == round(per_sample) else 1)
    assert abs(guess.index_counts - cpr) <= guess.index_counts_tol
    text = f"{guess.index_counts} +- {guess.index_counts_tol} counts per turn"
    assert f"{text} from 4 complete turn(s)" in guess.reason
    assert (counts.max() + 1 < cpr) == old_low  # the cases the old estimate got wrong


def test_one_reload_is_only_a_lower_bound() -> None:
    counts = _counter(4096, 3.0, 1.5, 0.3, from_task_start=True)  # one index, no whole turn
    guess, _ = classify_channel("enc", counts, "1", np.arange(counts.size) / 1000.0)
    assert guess.index_counts_tol == -1
    assert counts.max() + 1 <= guess.index_counts <= 4096
    assert f"at least {guess.index_counts} counts per turn" in guess.reason


def test_cumulative_counter_has_no_index_period() -> None:
    counts = np.floor(3.0 * np.arange(8000) + 100.0)
    guess, _ = classify_channel("enc", counts, "1", np.arange(counts.size) / 1000.0)
    assert (guess.index_counts, guess.index_counts_tol) == (0, 0)
    assert "reload" not in guess.reason


@pytest.mark.parametrize(("fs", "rev_per_s"), [(1000.0, 1.3), (1000.0, 2.9), (2000.0, 3.7),
                                               (5000.0, 11.0)])
def test_real_file_like_encoder(fs: float, rev_per_s: float) -> None:
    """The virtual rig's encoder model (uint32 counts, reload on the count edge at the index,
    counts from task start before it), 8192 counts per turn, on a shaft whose speed wobbles by
    15 % twice per turn, 4.5 turns: 9 to 27 counts per sample."""
    encoder = Encoder(counts_per_rev=8192, index_angle=1.3, index_reset=True)
    t = np.arange(round(4.5 / rev_per_s * fs)) / fs
    omega = 2 * np.pi * rev_per_s
    angle = 0.4 + omega * t - 0.15 / 2 * np.sin(2 * omega * t)  # speed omega (1 - 0.15 cos)
    counts = encoder.counts(angle, angle_at_start=0.4)
    guess, _ = classify_channel("enc1", counts.astype(np.float64), "1", t)
    assert counts.max() + 1 < 8192  # the old estimate
    assert guess.index_counts_tol <= 1
    assert abs(guess.index_counts - 8192) <= guess.index_counts_tol
    assert "from 3 complete turn(s)" in guess.reason
