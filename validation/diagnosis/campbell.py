"""Campbell diagram of a campaign: residual spectra against speed, modes told from orders.

Across runs at several speeds, content that moves with speed (a fixed order, ``f = k speed``)
is the rigid-body motion's, and a peak that keeps its frequency in Hz is a structural mode. The
resonances found in each run's non-synchronous residual
(:mod:`~rigval.validation.diagnosis.modes`) are grouped twice: by frequency (two agree within
:data:`SAME_FREQUENCY` relative or 3 combined standard uncertainties) and by order (the same
relative tolerance on ``f / speed``). A group found at three or more distinct speeds whose
frequency holds while its order moves is named a structural mode; one whose order holds while its
frequency moves is order content.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from rigval.processing.arrays import FloatArray
from rigval.validation.diagnosis.modes import Resonance

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["MIN_SPEEDS", "SAME_FREQUENCY", "Campbell", "CampbellLine", "RunSpectrum",
           "campbell", "plot_campbell"]

logger = logging.getLogger(__name__)

#: Relative agreement of two resonances' frequencies (or orders) taken as the same line.
SAME_FREQUENCY = 0.02
#: Distinct speeds a line must be found at to be named.
MIN_SPEEDS = 3
#: Two speeds differ when they differ by more than this share.
DISTINCT_SPEED = 0.05


@dataclass(frozen=True)
class RunSpectrum:
    """One run's residual spectrum and resonances for one comparison.

    Parameters
    ----------
    run : str
        Run name.
    speed_rev_s : float
        Main-shaft speed (rev/s).
    frequency, psd : numpy.ndarray
        The residual's spectrum (Hz; signal units squared per Hz).
    resonances : tuple of Resonance
        Resonances found in its non-synchronous part.
    """

    run: str
    speed_rev_s: float
    frequency: FloatArray
    psd: FloatArray
    resonances: tuple[Resonance, ...]


@dataclass(frozen=True)
class CampbellLine:
    """A group of resonances seen across speeds.

    Parameters
    ----------
    kind : {"structural mode", "order content"}
        Constant in Hz, or constant in orders.
    frequency_hz, u_frequency_hz : float
        Weighted mean frequency and its standard uncertainty (Hz; for order content the mean).
    order : float
        Mean order (``f / speed``).
    damping : float
        Mean damping ratio (1).
    speeds : tuple of float
        Speeds it was found at (rev/s).
    """

    kind: str
    frequency_hz: float
    u_frequency_hz: float
    order: float
    damping: float
    speeds: tuple[float, ...]


@dataclass(frozen=True)
class Campbell:
    """A comparison's Campbell diagram over a campaign.

    Parameters
    ----------
    name, units : str
        Comparison and signal unit.
    runs : tuple of RunSpectrum
        By speed.
    lines : tuple of CampbellLine
        Structural modes and order content found at :data:`MIN_SPEEDS` speeds or more.
    """

    name: str
    units: str
    runs: tuple[RunSpectrum, ...]
    lines: tuple[CampbellLine, ...]

    @property
    def modes(self) -> tuple[CampbellLine, ...]:
        """The structural modes."""
        return tuple(line for line in self.lines if line.kind == "structural mode")

    @property
    def sentence(self) -> str:
        """One sentence for the campaign page."""
        speeds = len({round(r.speed_rev_s, 3) for r in self.runs})
        if not self.lines:
            return (f"{self.name}: no resonance keeps its frequency or its order across "
                    f"{speeds} speeds")
        parts = [f"a structural mode at {line.frequency_hz:.1f} +- "
                 f"{max(line.u_frequency_hz, 0.05):.1f} Hz (damping about "
                 f"{100.0 * line.damping:.1g} %, at {len(line.speeds)} speeds)"
                 if line.kind == "structural mode" else
                 f"order content at order {line.order:.2f} ({len(line.speeds)} speeds)"
                 for line in self.lines]
        return f"{self.name} across {speeds} speeds: " + "; ".join(parts)


def _groups(items: list[tuple[float, float, Resonance, float]]
            ) -> list[list[tuple[float, float, Resonance, float]]]:
    """Chain items sorted by their key (first element) where neighbours agree."""
    items = sorted(items, key=lambda x: x[0])
    groups: list[list[tuple[float, float, Resonance, float]]] = []
    for item in items:
        if groups:
            last = groups[-1][-1]
            if abs(item[0] - last[0]) <= max(SAME_FREQUENCY * last[0],
                                             3.0 * float(np.hypot(item[1], last[1]))):
                groups[-1].append(item)
                continue
        groups.append([item])
    return groups


def _distinct(speeds: Sequence[float]) -> list[float]:
    out: list[float] = []
    for speed in sorted(speeds):
        if not out or speed > out[-1] * (1.0 + DISTINCT_SPEED):
            out.append(speed)
    return out


def campbell(name: str, units: str, runs: Sequence[RunSpectrum]) -> Campbell:
    """Build a comparison's Campbell diagram and name its lines.

    Parameters
    ----------
    name, units : str
        Comparison and signal unit.
    runs : sequence of RunSpectrum
        One per run.

    Returns
    -------
    Campbell
        Runs by speed; lines found at :data:`MIN_SPEEDS` distinct speeds or more.
    """
    runs = tuple(sorted(runs, key=lambda r: r.speed_rev_s))
    found = [(r, run.speed_rev_s) for run in runs for r in run.resonances]
    lines: list[CampbellLine] = []
    used: set[int] = set()
    by_hz = _groups([(r.frequency_hz, r.u_frequency_hz, r, s) for r, s in found])
    for group in by_hz:
        speeds = _distinct([s for *_, s in group])
        orders = [r.order for _, _, r, _ in group]
        if len(speeds) < MIN_SPEEDS or np.ptp(orders) <= SAME_FREQUENCY * np.mean(orders):
            continue
        weights = np.array([1.0 / max(r.u_frequency_hz, 1e-3) ** 2 for _, _, r, _ in group])
        freqs = np.array([r.frequency_hz for _, _, r, _ in group])
        lines.append(CampbellLine(
            "structural mode", float(np.sum(weights * freqs) / weights.sum()),
            float(1.0 / np.sqrt(weights.sum())), float(np.mean(orders)),
            float(np.mean([r.damping for _, _, r, _ in group])), tuple(speeds)))
        used |= {id(r) for _, _, r, _ in group}
    rest = [(r.order, r.u_frequency_hz / s, r, s) for r, s in found if id(r) not in used]
    for group in _groups(rest):
        speeds = _distinct([s for *_, s in group])
        if len(speeds) < MIN_SPEEDS:
            continue
        freqs = [r.frequency_hz for _, _, r, _ in group]
        lines.append(CampbellLine("order content", float(np.mean(freqs)), float(np.std(freqs)),
                                  float(np.mean([o for o, *_ in group])),
                                  float(np.mean([r.damping for _, _, r, _ in group])),
                                  tuple(speeds)))
    return Campbell(name, units, runs, tuple(sorted(lines, key=lambda x: x.frequency_hz)))


def plot_campbell(diagram: Campbell, *, max_order: int = 40) -> Figure:
    """Draw the Campbell diagram: residual PSD per run against speed, order lines, modes.

    Each run is a vertical strip at its speed coloured by ``log10`` of its residual PSD; the
    order lines ``f = k speed`` are grey rays (every fifth darker), each resonance found is a
    ring, and each structural mode a dashed horizontal line.
    """
    from matplotlib.figure import Figure

    fig = Figure(figsize=(7.0, 4.2), layout="constrained")
    ax = fig.add_subplot()
    speeds = np.array([r.speed_rev_s for r in diagram.runs])
    top = max(float(r.frequency[-1]) for r in diagram.runs)
    edges = np.concatenate([[speeds[0] * 0.95], 0.5 * (speeds[1:] + speeds[:-1]),
                            [speeds[-1] * 1.05]]) if speeds.size > 1 else np.array(
        [speeds[0] * 0.9, speeds[0] * 1.1])
    levels = [np.log10(np.maximum(r.psd, np.max(r.psd) * 1e-12)) for r in diagram.runs]
    low, high = np.percentile(np.concatenate(levels), [5.0, 99.9])
    mesh = None
    for k, (run, level) in enumerate(zip(diagram.runs, levels, strict=True)):
        mesh = ax.pcolormesh([edges[k], edges[k + 1]], run.frequency,
                             np.column_stack([level, level])[:-1, :1], vmin=low, vmax=high,
                             cmap="viridis", shading="flat")
    s = np.linspace(edges[0], edges[-1], 2)
    for order in range(1, max_order + 1):
        ax.plot(s, order * s, color="0.35" if order % 5 == 0 else "0.7", lw=0.6)
    for run in diagram.runs:
        for r in run.resonances:
            ax.plot(run.speed_rev_s, r.frequency_hz, "o", mfc="none", mec="red", ms=7)
    for line in diagram.modes:
        ax.axhline(line.frequency_hz, color="red", ls="--", lw=1.0)
        ax.annotate(f"mode {line.frequency_hz:.1f} Hz", (edges[-1], line.frequency_hz),
                    xytext=(-4, 3), textcoords="offset points", ha="right", color="red",
                    fontsize="small")
    ax.set_xlim(edges[0], edges[-1])
    ax.set_ylim(0.0, top)
    ax.set_xlabel("main-shaft speed [rev/s]")
    ax.set_ylabel("frequency [Hz]")
    ax.set_title(f"{diagram.name}: residual spectrum, order lines k x speed", fontsize="medium")
    if mesh is not None:
        fig.colorbar(mesh, ax=ax, label=f"log10 PSD [({diagram.units})^2/Hz]")
    return fig
