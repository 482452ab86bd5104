"""Attribution of a model error: which cause's signature the residual carries, with numbers.

The residual of every comparison (measured mean minus model, over phi_F) is regressed on what
each candidate cause would add to it (:class:`Cause`: a gain, an offset, a time lag, a mechanism
parameter, a structural mode). The regression runs in the order domain of the main shaft: the
Fourier coefficients of one revolution, orders ``1 ... K`` (order 0 too when the comparison keeps
its offset). There the noise of the revolution mean is close to independent between orders
(the coefficients of a stationary signal over its period are nearly uncorrelated), and its
variance per order is measured from the revolution-to-revolution scatter of the residual. The
stated systematic uncertainties enter as nuisance directions of known size (:class:`Nuisance`:
each sensor's calibration gain, a stream's clock alignment, the drive angles), so the noise
covariance is ``C = diag(var) + N N^T`` and every fit is generalised least squares.

Causes are chosen by forward selection: starting from "no cause", the cause that lowers
``chi^2`` most is added while its drop, over the scale ``max(1, chi^2 / dof)`` left after adding
it (an F test, so that a misfit no candidate explains does not count as evidence), exceeds both
the Bayesian information criterion's ``ln(n_rows)`` and the chi-square quantile of one degree of
freedom at ``ALPHA / m`` for ``m`` candidates still open (Bonferroni: the best of many candidates
is not chosen by chance more often than ``ALPHA``); at most :data:`MAX_CAUSES`. Where the chosen
causes leave ``chi^2`` above its degrees of freedom, every standard uncertainty is widened by the
square root of that ratio (the Birge ratio) and the evidence between candidates is taken on the
same widened scale (quasi-likelihood weights). Two causes whose whitened signatures are
nearly parallel cannot be told apart; :attr:`Attribution.confusable` names the runner-up and
their correlation. The small dense factorisations run with one BLAS thread
(:func:`rigval.acquisition.threads.single_blas_thread`: with the cores busy, threads wait for each
other). docs/diagnosis.md describes the method and its limits.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Mapping, Sequence

import numpy as np
import scipy.linalg
import scipy.special

from rigval.acquisition.errors import DataError
from rigval.acquisition.threads import single_blas_thread

__all__ = ["ALPHA", "KINDS", "MAX_CAUSES", "Attribution", "Block", "Cause", "Evidence", "Found",
           "Nuisance", "Sized", "attribute", "order_coefficients"]

logger = logging.getLogger(__name__)

#: Kinds of cause, in the order the report lists them.
KINDS: tuple[str, ...] = ("gain", "offset", "lag", "parameter", "mode")
#: Most causes forward selection adds.
MAX_CAUSES = 3
#: Family-wise probability of choosing a cause that is not there, per selection step.
ALPHA = 0.05
#: Whitened correlation above which two causes are reported as hard to tell apart.
CONFUSABLE = 0.9


@dataclasses.dataclass(frozen=True)
class Block:
    """One comparison's residual on the phi_F grid.

    Attributes
    ----------
    name : str
        The comparison.
    cycles : numpy.ndarray
        ``(n_cycles, n)`` measured minus model, each whole revolution, signal units.
    orders : int
        Highest order of the main shaft used (the comparison's low-pass over the speed).
    with_offset : bool
        Order 0 is used (the comparison keeps its constant part).
    floor : float
        White standard uncertainty per sample added to the scatter (grid, absolute
        calibration, stated model inputs), signal units.
    accepted : bool
        The verdict found no model error here: whatever of its misfit the scatter and the
        nuisances do not explain is taken as noise of that size (its variances are widened by
        its own ``chi^2`` per row when above 1), so that a cause is judged by whether it would
        have shown here, not made to explain an agreement the verdict accepts.
    """

    name: str
    cycles: np.ndarray
    orders: int
    with_offset: bool = False
    floor: float = 0.0
    accepted: bool = False

    @property
    def residual(self) -> np.ndarray:
        """Mean residual over the revolutions, ``(n,)``."""
        return self.cycles.mean(axis=0)


@dataclasses.dataclass(frozen=True)
class Cause:
    """A candidate cause and what one unit of it adds to each comparison's residual.

    Attributes
    ----------
    name : str
        ``"gain tor1"``, ``"lag tor1"``, ``"offset tor1"``, ``"A.mass"``, ``"mode 17.9 Hz"``.
    kind : str
        One of :data:`KINDS`.
    unit : str
        Unit of the coefficient (``"1"`` for a gain, ``"s"`` for a lag, ``"kg"``, ...).
    effect : mapping of str to numpy.ndarray
        Per comparison touched: the residual's change per unit coefficient over phi_F,
        ``(n,)`` signal units per unit.
    nominal : float
        Reference value: the coefficient is also reported relative to it (a parameter's
        nominal value); 0: no relative value.
    meaning : str
        What the cause stands for in words (``"calibration or torque split"``).
    """

    name: str
    kind: str
    unit: str
    effect: Mapping[str, np.ndarray]
    nominal: float = 0.0
    meaning: str = ""


@dataclasses.dataclass(frozen=True)
class Nuisance:
    """A systematic error of stated standard size that no verdict may blame: a noise direction.

    Attributes
    ----------
    name : str
        ``"calibration tor1"``, ``"alignment wls1"``, ...
    effect : mapping of str to numpy.ndarray
        Per comparison: the residual's change for one standard uncertainty, ``(n,)``.
    """

    name: str
    effect: Mapping[str, np.ndarray]


@dataclasses.dataclass(frozen=True)
class Sized:
    """A cause and its fitted size.

    Attributes
    ----------
    name, kind, unit, meaning : str
        As the :class:`Cause` (``"no cause"``, kind ``"none"``: none).
    value, std : float
        Fitted coefficient and its standard uncertainty (Birge-widened), in ``unit``.
    relative, relative_std : float
        ``value / nominal`` and its uncertainty (NaN without a nominal).
    """

    name: str
    kind: str
    unit: str
    meaning: str
    value: float
    std: float
    relative: float
    relative_std: float


@dataclasses.dataclass(frozen=True)
class Found(Sized):
    """A chosen cause, its size fitted with the other chosen causes.

    Attributes
    ----------
    delta_chi2 : float
        How much adding it lowered ``chi^2``.
    comparisons : tuple of str
        The comparisons it touches.
    """

    delta_chi2: float
    comparisons: tuple[str, ...]


@dataclasses.dataclass(frozen=True)
class Evidence(Sized):
    """One candidate of the first selection step, its size fitted alone (NaN for "no cause").

    Attributes
    ----------
    chi2 : float
        ``chi^2`` of the residual with this cause alone.
    weight : float
        Its share of the evidence among all single causes and "no cause" (quasi-likelihood
        weights ``exp(-(chi2 - chi2_min) / (2 B^2))``, ``B`` the Birge ratio, normalised).
    """

    chi2: float
    weight: float


@dataclasses.dataclass(frozen=True)
class Attribution:
    """What the residuals say about the causes.

    Attributes
    ----------
    found : tuple of Found
        The causes chosen, in the order chosen.
    candidates : tuple of Evidence
        Every single cause, best first, with "no cause" among them.
    chi2_none, chi2 : float
        ``chi^2`` without any cause and with the chosen ones.
    dof : int
        Rows minus chosen causes.
    birge : float
        ``max(1, sqrt(chi2 / dof))``: the factor every uncertainty was widened by.
    confusable : tuple of (str, str, float)
        For the first chosen cause: the runner-up and the whitened correlation of their
        signatures, when above :data:`CONFUSABLE`; empty otherwise.
    by_comparison : mapping of str to str
        Per comparison: the chosen cause that changes its residual most (absent: none).
    """

    found: tuple[Found, ...]
    candidates: tuple[Evidence, ...]
    chi2_none: float
    chi2: float
    dof: int
    birge: float
    confusable: tuple[tuple[str, str, float], ...]
    by_comparison: Mapping[str, str]

    def cause_of(self, comparison: str) -> Found | None:
        """Return the chosen cause that explains most of a comparison's residual, or None."""
        name = self.by_comparison.get(comparison)
        return next((f for f in self.found if f.name == name), None)


def order_coefficients(values: np.ndarray, orders: int, with_offset: bool) -> np.ndarray:
    """Return the real and imaginary Fourier coefficients of one revolution, orders stacked.

    Parameters
    ----------
    values : numpy.ndarray
        ``(..., n)`` samples of whole revolutions on a uniform grid without the repeated end.
    orders : int
        Highest order kept (at most ``n // 2 - 1``).
    with_offset : bool
        Keep order 0 (the mean).

    Returns
    -------
    numpy.ndarray
        ``(..., 2 orders [+ 1])``: ``[mean,] Re c_1, Im c_1, ..., Re c_K, Im c_K`` with ``c_k``
        the amplitude of order ``k`` (``x = sum Re(c_k e^(i k phi))``).
    """
    n = values.shape[-1]
    spectrum = np.fft.rfft(values, axis=-1) / n
    parts = [2.0 * spectrum[..., 1:orders + 1].real, 2.0 * spectrum[..., 1:orders + 1].imag]
    stacked = np.stack(parts, axis=-1).reshape(*values.shape[:-1], 2 * min(orders, n // 2))
    if with_offset:
        stacked = np.concatenate([spectrum[..., :1].real, stacked], axis=-1)
    return stacked


@single_blas_thread()
def attribute(blocks: Sequence[Block], causes: Sequence[Cause],
              nuisances: Sequence[Nuisance] = (), *, max_causes: int = MAX_CAUSES
              ) -> Attribution:
    """Choose the causes the residuals carry, with their sizes and uncertainties.

    Parameters
    ----------
    blocks : sequence of Block
        The comparisons' residuals (each with three revolutions or more).
    causes : sequence of Cause
        The candidates; a cause touching no block is ignored.
    nuisances : sequence of Nuisance
        Stated systematic errors, each at one standard uncertainty.
    max_causes : int
        Most causes chosen.

    Returns
    -------
    Attribution

    Raises
    ------
    DataError
        For a block with fewer than three revolutions or no orders.
    """
    rows, variance = _stack_blocks(blocks)
    names = [b.name for b in blocks]
    design = _stack_effects([c.effect for c in causes], blocks)
    noise = _stack_effects([n.effect for n in nuisances], blocks)
    variance = _widen(blocks, rows, variance, noise, design, [], accepted_only=True)
    chosen, gains, first = _select(rows, variance, noise, design, max_causes)
    if chosen:
        # each comparison's own misfit left by the chosen causes widens its variances (quasi-
        # likelihood per comparison), and the choice is made again on that scale
        variance = _widen(blocks, rows, variance, noise, design, chosen, accepted_only=False)
        chosen, gains, first = _select(rows, variance, noise, design, max_causes)
    whiten = _whitener(variance, noise)
    y, x = whiten(rows), whiten(design)
    chi2_none = float(y @ y)
    chi2 = _chi2(y, x[:, chosen]) if chosen else chi2_none
    dof = max(y.size - len(chosen), 1)
    birge = max(1.0, math.sqrt(chi2 / dof))
    found = _found(causes, chosen, y, x, birge, gains, names)
    candidates = _evidence(causes, first, chi2_none, birge, y, x)
    confusable = _confusable(causes, chosen, first, x)
    by_comparison = _by_comparison(blocks, causes, chosen, found)
    logger.info("attribution: chi2 %.4g -> %.4g over %d rows (Birge %.3g): %s", chi2_none, chi2,
                y.size, birge, ", ".join(f.name for f in found) or "no cause")
    return Attribution(tuple(found), candidates, chi2_none, chi2, dof, birge, confusable,
                       by_comparison)


def _stack_blocks(blocks: Sequence[Block]) -> tuple[np.ndarray, np.ndarray]:
    """Order coefficients of every mean residual and their variances, stacked."""
    rows, variance = [], []
    for block in blocks:
        n_cycles, n = block.cycles.shape
        if n_cycles < 3 or block.orders < 1:
            raise DataError(f"{block.name}: attribution needs 3 whole revolutions and order 1, "
                            f"got {n_cycles} and {block.orders}",
                            where={"comparison": block.name}, hint="record longer")
        per_cycle = order_coefficients(block.cycles, block.orders, block.with_offset)
        rows.append(per_cycle.mean(axis=0))
        # white floor: a sample's variance s^2 gives Re/Im c_k a variance 2 s^2 / n (s^2 / n
        # for the mean)
        white = np.full(per_cycle.shape[1], 2.0 * block.floor**2 / n)
        if block.with_offset:
            white[0] = block.floor**2 / n
        variance.append(np.var(per_cycle, axis=0, ddof=1) / n_cycles + white)
    stacked = np.concatenate(variance)
    tiny = 1e-12 * float(np.max(stacked)) if stacked.size and np.max(stacked) > 0 else 1e-300
    return np.concatenate(rows), np.maximum(stacked, tiny)


def _stack_effects(effects: Sequence[Mapping[str, np.ndarray]], blocks: Sequence[Block]
                   ) -> np.ndarray:
    """Return causes' or nuisances' effects as stacked order coefficients, one column each.

    Parameters
    ----------
    effects : sequence of mapping of str to numpy.ndarray
        Each cause's or nuisance's effect by comparison, ``(n,)`` over its block's grid.
    blocks : sequence of Block
        The comparisons, in the order of the rows.

    Returns
    -------
    numpy.ndarray
        ``(rows, len(effects))``: per block its rows (:func:`order_coefficients`), 0 where an
        effect does not touch it. The effects on one block are transformed together, each row
        as it would be alone (to the bit: the transform runs row by row).
    """
    parts = []
    for block in blocks:
        part = np.zeros((2 * block.orders + int(block.with_offset), len(effects)))
        touching = [j for j, effect in enumerate(effects) if effect.get(block.name) is not None]
        if touching:
            values = np.array([np.asarray(effects[j][block.name], dtype=float)
                               for j in touching])
            part[:, touching] = order_coefficients(values, block.orders, block.with_offset).T
        parts.append(part)
    return np.concatenate(parts)


def _select(rows: np.ndarray, variance: np.ndarray, noise: np.ndarray, design: np.ndarray,
            max_causes: int) -> tuple[list[int], list[float], dict[int, float]]:
    """Forward selection: the causes chosen, their drops of ``chi^2``, and the first step's."""
    whiten = _whitener(variance, noise)
    y, x = whiten(rows), whiten(design)
    usable = [j for j in range(design.shape[1]) if np.any(x[:, j] != 0.0)]
    chosen: list[int] = []
    gains: list[float] = []
    first: dict[int, float] = {}
    chi2 = float(y @ y)
    for _ in range(max_causes):
        trial = {j: _chi2(y, x[:, [*chosen, j]]) for j in usable if j not in chosen}
        if not trial:
            break
        if not chosen:
            first = trial
        best = min(trial, key=trial.__getitem__)
        scale = max(1.0, trial[best] / max(y.size - len(chosen) - 1, 1))
        if (chi2 - trial[best]) / scale <= _penalty(y.size, len(trial)):
            break
        gains.append(chi2 - trial[best])
        chosen.append(best)
        chi2 = trial[best]
    return chosen, gains, first


def _penalty(rows: int, candidates: int) -> float:
    """Return the drop of ``chi^2`` a cause must exceed: BIC's ``ln(rows)``, Bonferroni's quantile.

    The chi-square quantile of one degree of freedom with the upper tail ``ALPHA /
    candidates`` (``scipy.stats.chi2.isf``, whose value it is, to the bit).
    """
    return max(math.log(rows), float(scipy.special.chdtri(1, ALPHA / candidates)))


def _widen(blocks: Sequence[Block], rows: np.ndarray, variance: np.ndarray, noise: np.ndarray,
           design: np.ndarray, chosen: list[int], *, accepted_only: bool) -> np.ndarray:
    """Widen blocks' variances by their own ``chi^2`` per row (>= 1) after the chosen causes.

    With ``accepted_only`` only the blocks the verdict accepts, under "no cause".
    """
    out = variance.copy()
    start = 0
    for block in blocks:
        size = 2 * block.orders + int(block.with_offset)
        part = slice(start, start + size)
        start += size
        if accepted_only and not block.accepted:
            continue
        whiten = _whitener(variance[part], noise[part])
        y = whiten(rows[part])
        columns = [j for j in chosen if np.any(design[part, j] != 0.0)]
        rest = _chi2(y, whiten(design[part][:, columns])) if columns else float(y @ y)
        factor = max(1.0, rest / max(size - len(columns), 1))
        out[part] *= factor
        logger.debug("%s: variances widened %.3g times", block.name, factor)
    return out


def _whitener(variance: np.ndarray, noise: np.ndarray):
    """Return ``v -> L^-1 v`` for ``C = diag(variance) + noise noise^T = L L^T``."""
    if noise.shape[1] == 0:
        scale = 1.0 / np.sqrt(variance)
        return lambda v: (v.T * scale).T
    factor = scipy.linalg.cholesky(np.diag(variance) + noise @ noise.T, lower=True)
    return lambda v: scipy.linalg.solve_triangular(factor, v, lower=True)


def _chi2(y: np.ndarray, x: np.ndarray) -> float:
    """Least-squares ``chi^2`` of whitened data on whitened columns."""
    beta, *_ = np.linalg.lstsq(x, y, rcond=None)
    rest = y - x @ beta
    return float(rest @ rest)


def _found(causes: Sequence[Cause], chosen: list[int], y: np.ndarray, x: np.ndarray,
           birge: float, gains: list[float], names: list[str]) -> list[Found]:
    if not chosen:
        return []
    columns = x[:, chosen]
    beta, *_ = np.linalg.lstsq(columns, y, rcond=None)
    covariance = np.linalg.pinv(columns.T @ columns) * birge**2
    out = []
    for i, j in enumerate(chosen):
        cause = causes[j]
        std = float(math.sqrt(max(covariance[i, i], 0.0)))
        value = float(beta[i])
        nominal = cause.nominal
        relative = value / nominal if nominal else math.nan
        relative_std = std / abs(nominal) if nominal else math.nan
        out.append(Found(cause.name, cause.kind, cause.unit, cause.meaning, value, std, relative,
                         relative_std, gains[i],
                         tuple(n for n in names if n in cause.effect)))
    return out


def _evidence(causes: Sequence[Cause], first: Mapping[int, float], chi2_none: float,
              birge: float, y: np.ndarray, x: np.ndarray) -> tuple[Evidence, ...]:
    entries = [(None, chi2_none), *first.items()]
    low = min(value for _, value in entries)
    raw = [math.exp(-(value - low) / (2.0 * birge**2)) for _, value in entries]
    total = sum(raw)
    out = []
    for (j, value), weight in zip(entries, raw, strict=True):
        if j is None:
            out.append(Evidence("no cause", "none", "", "", math.nan, math.nan, math.nan,
                                math.nan, value, weight / total))
            continue
        cause, column = causes[j], x[:, j]
        power = float(column @ column)
        size, std = float(column @ y) / power, birge / math.sqrt(power)
        nominal = cause.nominal
        out.append(Evidence(cause.name, cause.kind, cause.unit, cause.meaning, size, std,
                            size / nominal if nominal else math.nan,
                            std / abs(nominal) if nominal else math.nan, value, weight / total))
    return tuple(sorted(out, key=lambda e: e.chi2))


def _confusable(causes: Sequence[Cause], chosen: list[int], first: Mapping[int, float],
                x: np.ndarray) -> tuple[tuple[str, str, float], ...]:
    if not chosen or len(first) < 2:
        return ()
    top = chosen[0]
    runner = min((j for j in first if j != top), key=first.__getitem__)
    a, b = x[:, top], x[:, runner]
    correlation = abs(float(a @ b)) / float(np.linalg.norm(a) * np.linalg.norm(b))
    if correlation < CONFUSABLE:
        return ()
    return ((causes[top].name, causes[runner].name, correlation),)


def _by_comparison(blocks: Sequence[Block], causes: Sequence[Cause], chosen: list[int],
                   found: list[Found]) -> dict[str, str]:
    """Per comparison, the chosen cause whose fitted effect on it has the largest RMS."""
    out = {}
    for block in blocks:
        sizes = {f.name: float(np.sqrt(np.mean((f.value * causes[j].effect[block.name]) ** 2)))
                 for j, f in zip(chosen, found, strict=True) if block.name in causes[j].effect}
        sizes = {name: size for name, size in sizes.items() if size > 0.0}
        if sizes:
            out[block.name] = max(sizes, key=sizes.__getitem__)
    return out
