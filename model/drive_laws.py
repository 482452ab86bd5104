"""Where drive laws come from (the laws themselves, their evaluation and inversion: ``laws.py``).

A :class:`~rigval.model.laws.DriveLaw` is written against the main drive's cycle phase, so
changing the frequency keeps the shape of every profile over a cycle (a speed sweep moves along one
path at different speeds). Laws come from

* the mechanism file (:func:`~rigval.model.laws.excitation_from_drivers`, the ``harmonic``
  law of docs/mechanism.md),
* a small TOML table, on the command line (``--drive theta_H={phase = 0.5}``) or in a file
  (:func:`parse_drive_option`, :func:`law_from_table`),
* a tabulated profile, a CSV of angle against time, smoothed and differentiated by a least-squares
  Fourier series whose order is chosen by generalised cross-validation, with a stated error
  (:func:`fit_periodic_profile`, :func:`read_profile_csv`),
* a measured run: the drive angles that processing identified from the encoders
  (:func:`excitation_from_measured`).
"""

from __future__ import annotations

import dataclasses
import logging
import math
import tomllib
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt
import pandas as pd
import scipy.linalg
import xarray as xr

from rigval.acquisition.errors import (
    ChannelNotFoundError,
    ConfigError,
    DataError,
    DataFileError,
)
from rigval.acquisition.tables import TableReader, key_path
from rigval.model.laws import DriveLaw, Excitation, FitUncertainty, Harmonic, check_frequency
from rigval.processing.periodic_fit import (
    PeriodicFit,
    fourier_basis,
    fourier_normal_equations,
    refine_period,
)

__all__ = [
    "NOISE_COVERAGE",
    "ProfileFit",
    "apply_drive_options",
    "excitation_from_measured",
    "fit_periodic_profile",
    "law_from_table",
    "parse_drive_option",
    "read_profile_csv",
]

logger = logging.getLogger(__name__)

#: Multiple of the propagated noise standard deviation included in a fitted law's stated error.
NOISE_COVERAGE = 4.0

_LAW_KEYS = ("frequency", "ratio", "phase", "theta0", "harmonics", "profile", "period")
_HARMONIC_KEYS = ("amplitude", "order", "phase")
#: Drive-law tables (``--drive NAME={...}`` and drive-law files, docs/predict.md).
_TABLES = TableReader(ConfigError, docs="docs/predict.md")
_ERROR_GRID = 720
_TRUNCATION_ORDERS = 3
_ROUNDOFF = 64 * np.finfo(float).eps


class ProfileFit(NamedTuple):
    """A law fitted to a tabulated or measured profile and the cycle frequency it implies.

    Attributes
    ----------
    law : DriveLaw
        The fitted law (``law.error`` holds the stated error).
    frequency : float
        Cycle frequency of the profile, Hz.
    """

    law: DriveLaw
    frequency: float


def _number(table: Mapping[str, Any], key: str, where: str) -> float:
    return float(_TABLES.get(table, key, where, float))


def _harmonics(value: Any, where: str) -> tuple[Harmonic, ...]:
    key = key_path(where, "harmonics")
    if not isinstance(value, list):
        raise _TABLES.fail(key, f"expected a list of tables, got {value!r}",
                           hint="write harmonics = [{amplitude = 0.05, order = 1, phase = 0.0}]")
    terms = []
    for i, item in enumerate(value):
        term = _TABLES.check_keys(item, key_path(key, i), _HARMONIC_KEYS, ("amplitude", "order"),
                                  what="in a harmonic (amplitude in rad, order; phase in rad)")
        terms.append(Harmonic(_number(term, "amplitude", key_path(key, i)),
                              _number(term, "order", key_path(key, i)),
                              _TABLES.get(term, "phase", key_path(key, i), float, 0.0)))
    return tuple(terms)


def law_from_table(table: Mapping[str, Any], base: DriveLaw, *, where: str,
                   base_dir: Path | None = None) -> tuple[DriveLaw, float | None]:
    """Return a drive law built from a TOML table, keys not given taken from ``base``.

    Keys (SI units): ``frequency`` (Hz, cycle frequency; main drive only), ``ratio`` (speed ratio
    to the main drive), ``phase`` (rad, shift against the main drive), ``theta0`` (rad),
    ``harmonics`` (list of ``{amplitude = rad, order = multiple of the cycle frequency, phase =
    rad}``, replacing the base harmonics), ``profile`` (path of a CSV of angle against time,
    relative to ``base_dir``) with optional ``period`` (s).

    Parameters
    ----------
    table : mapping
        The parsed TOML table.
    base : DriveLaw
        The law that keys not given keep (usually the mechanism file's).
    where : str
        Key path or origin used in error messages.
    base_dir : pathlib.Path, optional
        Folder that a relative ``profile`` path is resolved against; default the working folder.

    Returns
    -------
    law : DriveLaw
        The new law.
    frequency : float or None
        The cycle frequency the table sets (``frequency`` key, or a profile's period), Hz.
    """
    _TABLES.check_keys(table, where, _LAW_KEYS, what="in a drive law")
    frequency = check_frequency(table["frequency"], f"{where}.frequency") \
        if "frequency" in table else None
    if "profile" in table:
        others = sorted(set(table) - {"profile", "period", "phase", "frequency"})
        if others:
            raise _TABLES.fail(where, "a profile law takes only profile, period, phase and "
                               f"frequency, not {others}",
                               hint="the profile itself fixes ratio, theta0 and harmonics")
        path = Path(str(table["profile"]))
        if base_dir is not None and not path.is_absolute():
            path = base_dir / path
        period = _number(table, "period", where) if "period" in table else None
        t, theta = read_profile_csv(path)
        fit = fit_periodic_profile(t, theta, period=period, source=str(path))
        law = fit.law
        if "phase" in table:
            law = dataclasses.replace(law, phase=_number(table, "phase", where))
        return law, frequency if frequency is not None else fit.frequency
    changes: dict[str, Any] = {}
    for key in ("ratio", "phase", "theta0"):
        if key in table:
            changes[key] = _number(table, key, where)
    if "harmonics" in table:
        changes["harmonics"] = _harmonics(table["harmonics"], where)
    if not changes:
        return base, frequency
    return dataclasses.replace(base, source=where, error=None, **changes), frequency


def parse_drive_option(text: str, excitation: Excitation, *, base_dir: Path | None = None
                       ) -> Excitation:
    """Apply one ``NAME=LAW`` drive option to an excitation.

    ``LAW`` is ``file`` (the mechanism file's law, i.e. no change), the path of a ``.csv``
    tabulated profile, the path of a ``.toml`` file holding one law table, or an inline TOML table
    such as ``{phase = 0.5}`` or ``{frequency = 1.2, harmonics = [{amplitude = 0.05, order = 1}]}``
    (keys of :func:`law_from_table`).

    Parameters
    ----------
    text : str
        The option value.
    excitation : Excitation
        The excitation to change.
    base_dir : pathlib.Path, optional
        Folder that relative paths are resolved against.

    Returns
    -------
    Excitation
        The changed excitation; a ``frequency`` key or a profile's period on the main drive sets
        the cycle frequency.
    """
    name, sep, law_text = text.partition("=")
    name, law_text = name.strip(), law_text.strip()
    where = f"--drive {name}"
    if not sep or not name or not law_text:
        raise ConfigError(f"a drive option reads NAME=LAW, got {text!r}",
                          where={"option": text},
                          hint="e.g. --drive 'theta_H={phase = 0.5}' or theta_F=profile.csv")
    base = excitation.law(name)
    if law_text == "file":
        return excitation
    if law_text.startswith("{"):
        try:
            table = tomllib.loads(f"law = {law_text}")["law"]
        except tomllib.TOMLDecodeError as error:
            raise ConfigError(f"the inline law is not a TOML table: {error}",
                              where={"option": text},
                              hint="write TOML keys, e.g. {phase = 0.5, ratio = 2.0}") from None
    elif law_text.lower().endswith(".csv"):
        table = {"profile": law_text}
    elif law_text.lower().endswith(".toml"):
        path = Path(law_text)
        if base_dir is not None and not path.is_absolute():
            path = base_dir / path
        try:
            with path.open("rb") as handle:
                table = tomllib.load(handle)
        except OSError as error:
            raise DataFileError(f"cannot read the drive-law file: {error}",
                                where={"file": str(path)}, hint="check the path") from None
        except tomllib.TOMLDecodeError as error:
            raise ConfigError(f"the drive-law file is not valid TOML: {error}",
                              where={"file": str(path)}, hint="fix the TOML syntax") from None
        base_dir, where = path.parent, str(path)
    else:
        raise ConfigError(f"cannot tell what drive law {law_text!r} is",
                          where={"option": text},
                          hint="give 'file', a .csv profile, a .toml law file or an inline "
                               "TOML table in braces")
    law, frequency = law_from_table(table, base, where=where, base_dir=base_dir)
    if name != excitation.main and "frequency" in table:
        raise ConfigError("only the main drive sets the cycle frequency",
                          where={"key": f"{where}.frequency", "main drive": excitation.main},
                          hint=f"give frequency on {excitation.main}, and a ratio here")
    changed = excitation.with_law(name, law)
    if name == excitation.main and frequency is not None:
        changed = changed.with_frequency(frequency)
    return changed


def apply_drive_options(excitation: Excitation, options: Sequence[str], *,
                        base_dir: Path | None = None) -> Excitation:
    """Apply ``NAME=LAW`` options in order (see :func:`parse_drive_option`)."""
    for text in options:
        excitation = parse_drive_option(text, excitation, base_dir=base_dir)
    return excitation


def read_profile_csv(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """Read a tabulated drive profile: a CSV with a header and columns of time and angle.

    The columns are found by name: one containing ``time`` (s) and one containing ``angle`` or
    ``theta`` (rad); a file with exactly two columns may name them freely (time first).

    Parameters
    ----------
    path : str or pathlib.Path
        The CSV file.

    Returns
    -------
    t : ndarray
        Times, s, strictly increasing.
    theta : ndarray
        Angles, rad (unwrapped as given; a turning drive's angle keeps growing).
    """
    path = Path(path)
    try:
        frame = pd.read_csv(path, comment="#")
    except (OSError, pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as error:
        raise DataFileError(f"cannot read the profile CSV: {error}", where={"file": str(path)},
                            hint="give a CSV with a header row, columns time_s and angle_rad") \
            from None
    columns = [str(c) for c in frame.columns]
    time_cols = [c for c in columns if "time" in c.lower()]
    angle_cols = [c for c in columns if "angle" in c.lower() or "theta" in c.lower()]
    if len(time_cols) == 1 and len(angle_cols) == 1:
        time_col, angle_col = time_cols[0], angle_cols[0]
    elif len(columns) == 2:
        time_col, angle_col = columns
    else:
        raise DataFileError(f"cannot tell the time and angle columns apart among {columns}",
                            where={"file": str(path)},
                            hint="name the columns time_s and angle_rad")
    values = {}
    for col in (time_col, angle_col):
        numeric = pd.to_numeric(frame[col], errors="coerce").to_numpy(dtype=float)
        bad = np.flatnonzero(~np.isfinite(numeric))
        if bad.size:
            raise DataError(f"{bad.size} rows of column {col!r} are not finite numbers "
                            f"(first at data row {bad[0] + 1})",
                            where={"file": str(path), "column": col},
                            hint="remove or fix those rows")
        values[col] = numeric
    t, theta = values[time_col], values[angle_col]
    if t.size and np.any(np.diff(t) <= 0):
        row = int(np.flatnonzero(np.diff(t) <= 0)[0]) + 2
        raise DataError("profile times must increase strictly", where={
            "file": str(path), "column": time_col, "data row": row},
            hint="sort the rows by time and drop duplicates")
    return t, theta


def fit_periodic_profile(t: npt.ArrayLike, theta: npt.ArrayLike, *, period: float | None = None,
                         max_order: int | None = None, source: str = "profile") -> ProfileFit:
    """Smooth and differentiate a periodic drive profile by a least-squares Fourier series.

    The angle minus its whole turns per cycle, ``theta - ratio * tau``, is fitted by a Fourier
    series in the cycle phase ``tau = 2 pi (t - t0) / period``; the number of harmonics minimises
    generalised cross-validation, ``N RSS / (N - p)**2``. Derivatives are the series' analytic
    derivatives. The stated error (:class:`~rigval.model.laws.FitUncertainty`) adds the noise
    propagated through the fit (:data:`NOISE_COVERAGE` standard deviations, from the least-squares
    covariance, worst point of the cycle), a truncation estimate (what harmonics ``K+1 .. K+3``
    add when fitted) and floating-point round-off.

    Parameters
    ----------
    t : array_like
        Times, s, strictly increasing (any spacing).
    theta : array_like
        Angles, rad.
    period : float, optional
        Cycle period, s. Default ``t[-1] - t[0]``: the last row closes the cycle (its angle is the
        first angle plus whole turns).
    max_order : int, optional
        Largest number of harmonics tried; default ``min(100, (N - 1) // 3)``.
    source : str
        Where the samples came from (kept in the law).

    Returns
    -------
    ProfileFit
        The law (t = 0 at ``t[0]``) with its stated error, and the cycle frequency ``1 / period``.

    Raises
    ------
    DataError
        Too few samples, times not increasing, or a period the samples do not fit.
    """
    t = np.asarray(t, dtype=float)
    theta = np.asarray(theta, dtype=float)
    where = {"source": source}
    if t.shape != theta.shape or t.ndim != 1 or t.size < 8:
        raise DataError(f"a profile needs at least 8 (time, angle) pairs, got shapes {t.shape} "
                        f"and {theta.shape}", where=where, hint="tabulate the whole cycle")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(theta)) and np.all(np.diff(t) > 0)):
        raise DataError("profile times must be finite and strictly increasing, angles finite",
                        where=where, hint="sort the rows and remove gaps")
    span = t[-1] - t[0]
    period = span if period is None else float(period)
    if not period > 0 or period > span * (1 + 1e-9):
        raise DataError(f"the period {period:g} s must be positive and at most the profile's "
                        f"span {span:g} s", where=where,
                        hint="tabulate at least one whole cycle, the last row closing it")
    turns = (theta[-1] - theta[0]) / span * period / (2.0 * math.pi)
    ratio = float(round(turns))
    tau = 2.0 * math.pi * (t - t[0]) / period
    y = theta - ratio * tau
    n = t.size
    available = min(100, (n - 1) // 3)
    largest = available if max_order is None else max(0, min(int(max_order), available))
    gram, rhs = fourier_normal_equations(tau, y, min(largest + _TRUNCATION_ORDERS, available))
    # Nested least squares from one Cholesky factor: the leading block of R factors the leading
    # block of A^T A, and with z = R^-T A^T y the residual of the first p columns is
    # y^T y - sum(z[:p]**2).
    while True:
        try:
            full_factor = scipy.linalg.cholesky(gram, lower=False)
            break
        except np.linalg.LinAlgError:  # high orders nearly dependent (samples bunched in phase)
            if available == 0:
                raise DataError("the profile's samples do not determine even a constant",
                                where=where, hint="check the time column") from None
            available //= 2
            largest = min(largest, available)
            size = 2 * min(largest + _TRUNCATION_ORDERS, available) + 1
            gram, rhs = gram[:size, :size], rhs[:size]
    projected = scipy.linalg.solve_triangular(full_factor, rhs, trans="T")
    explained = np.cumsum(projected**2)
    orders = np.arange(largest + 1)
    sizes = 2 * orders + 1
    rss = np.maximum(float(y @ y) - explained[sizes - 1], 0.0)
    order = int(np.argmin(n * rss / (n - sizes) ** 2.0))
    p = 2 * order + 1
    factor = full_factor[:p, :p]
    coef = scipy.linalg.solve_triangular(factor, projected[:p])
    residual = theta - PeriodicFit(t0=float(t[0]), period=period, ratio=ratio, coef=coef)(t)[0]
    sigma = math.sqrt(float(residual @ residual) / (n - p)) if n > p else 0.0
    grid = np.linspace(0.0, 2.0 * math.pi, _ERROR_GRID, endpoint=False)
    noise, truncation = [], []
    extra = min(order + _TRUNCATION_ORDERS, available)
    extra_coef = None
    if extra > order:
        pe = 2 * extra + 1
        extra_coef = scipy.linalg.solve_triangular(full_factor[:pe, :pe], projected[:pe])
    for derivative in range(3):
        rows = fourier_basis(grid, order, derivative)
        spread = scipy.linalg.solve_triangular(factor, rows.T, trans="T")
        noise.append(NOISE_COVERAGE * sigma * float(np.sqrt(np.max(np.sum(spread**2, axis=0)))))
        if extra_coef is None:
            truncation.append(0.0)
        else:
            tail = fourier_basis(grid, extra, derivative)[:, p:] @ extra_coef[p:]
            truncation.append(float(np.max(np.abs(tail))))
    scale = abs(coef[0]) + abs(ratio) * 2.0 * math.pi + np.abs(coef[1:]).sum()
    roundoff = [_ROUNDOFF * scale * max(1, order) ** m for m in range(3)]
    total = [a + b + c for a, b, c in zip(noise, truncation, roundoff, strict=True)]
    error = FitUncertainty(angle=total[0], speed=total[1], acceleration=total[2],
                           residual_rms=sigma, order=order, samples=n)
    harmonics = tuple(
        Harmonic(amplitude=math.hypot(coef[2 * k - 1], coef[2 * k]), order=float(k),
                 phase=math.atan2(coef[2 * k - 1], coef[2 * k]))
        for k in range(1, order + 1))
    law = DriveLaw(theta0=float(coef[0]), ratio=ratio, harmonics=harmonics, source=source,
                   error=error)
    logger.info("fitted %s: %d harmonics, residual rms %.3g rad, speed error %.3g rad/rad",
                source, order, sigma, error.speed)
    return ProfileFit(law=law, frequency=1.0 / period)


def _whole_turns_period(t: np.ndarray, theta: np.ndarray, name: str) -> float:
    """Return the mean period of the whole turns in a measured angle record, s.

    For every sample, the time at which the angle has turned a further ``m`` whole revolutions is
    interpolated (``m`` as large as the record allows); a periodic law repeats exactly after
    ``m`` periods, so harmonics do not bias the estimate as an end-to-end slope would, and the
    mean over all samples averages the angle noise.
    """
    turned = (theta - theta[0]) * math.copysign(1.0, theta[-1] - theta[0])
    turns = math.floor(turned[-1] / (2.0 * math.pi))
    if turns < 1:
        raise DataError(f"the main drive {name!r} turns less than once in the measured run "
                        f"({turned[-1]:.3g} rad)", where={"drive": name},
                        hint="give a run of at least one whole revolution, or the period")
    monotone = np.maximum.accumulate(turned)
    levels = turned + 2.0 * math.pi * turns
    usable = levels <= monotone[-1]
    later = np.interp(levels[usable], monotone, t)
    return float(np.mean(later - t[usable]) / turns)


def excitation_from_measured(data: xr.Dataset, names: Sequence[str], *, main: str | None = None,
                             period: float | None = None,
                             offsets: Mapping[str, float] | None = None) -> Excitation:
    """Return the periodic excitation identified from a measured run's drive angles.

    Each drive angle ``data[name]`` (rad, along ``time`` in s) is fitted by
    :func:`fit_periodic_profile` over all its cycles, with the cycle period from the main drive's
    whole turns unless given. Where ``data`` also holds ``<name>_dot`` and ``<name>_ddot`` (what
    :func:`rigval.processing.excitation.drive_excitation` derives from the encoders), their rms
    deviation from the fitted law is logged: it measures how far the run departs from one
    repeating cycle. Samples whose time or angle is not finite (gaps) are left out and counted in
    the log.

    Parameters
    ----------
    data : xarray.Dataset
        Drive angles, and optionally their derivatives, along dim ``time``.
    names : sequence of str
        Drive names, in the mechanism's driver order.
    main : str, optional
        Main drive; default ``names[0]``.
    period : float, optional
        Cycle period, s; default from the main drive's whole turns.
    offsets : mapping of str to float, optional
        Angle (rad) added to a measured angle to give the driven body's absolute angle in the
        mechanism's frame (an encoder counts from wherever it started); default 0.

    Returns
    -------
    Excitation
        The laws with their stated errors; t = 0 at the first sample.
    """
    main = names[0] if main is None else main
    offsets = dict(offsets or {})
    missing = [name for name in names if name not in data.data_vars]
    if missing:
        raise ChannelNotFoundError(f"the measured excitation lacks drive angles {missing}",
                                   where={"variables": missing},
                                   hint="identify the excitation from the encoders first",
                                   available=list(map(str, data.data_vars)))
    t_all = np.asarray(data["time"].values, dtype=float)
    laws = []
    for name in [main, *(n for n in names if n != main)]:
        angle = np.asarray(data[name].values, dtype=float) + float(offsets.get(name, 0.0))
        keep = np.isfinite(t_all) & np.isfinite(angle)
        if not np.all(keep):
            logger.info("measured %s: %d of %d samples are not finite and left out", name,
                        int(np.count_nonzero(~keep)), keep.size)
        t = t_all[keep]
        if period is None:
            start = _whole_turns_period(t, angle[keep], main)
            first = fit_periodic_profile(t, angle[keep], period=start).law.error
            period = refine_period(t, angle[keep], start, first.order if first else 0)
        fit = fit_periodic_profile(t - t_all[0], angle[keep], period=period,
                                   source=f"measured {name}")
        law = fit.law
        if t[0] != t_all[0]:  # the fit's t = 0 is its first kept sample; move it to the record's
            law = _shift_time(law, (t[0] - t_all[0]) * 2.0 * math.pi / period)
        laws.append((name, law))
        _log_departure(name, law, data, keep, t - t_all[0], 2.0 * math.pi / period)
    assert period is not None
    ordered = tuple(next(item for item in laws if item[0] == name) for name in names)
    return Excitation(frequency=1.0 / period, laws=ordered, main=main)


def _shift_time(law: DriveLaw, phase: float) -> DriveLaw:
    """Return the law delayed by ``phase`` (rad of the cycle): ``new(tau) = law(tau - phase)``."""
    harmonics = tuple(dataclasses.replace(h, phase=h.phase - h.order * phase)
                      for h in law.harmonics)
    return dataclasses.replace(law, theta0=law.theta0 - law.ratio * phase, harmonics=harmonics)


def _log_departure(name: str, law: DriveLaw, data: xr.Dataset, keep: np.ndarray, t: np.ndarray,
                   omega: float) -> None:
    """Log the rms departure of measured derivatives from the fitted periodic law."""
    if f"{name}_dot" not in data.data_vars:
        return
    _, speed, accel = law.evaluate(t, omega)
    text = f"{_rms(speed - data[f'{name}_dot'].values[keep]):.3g} rad/s"
    if f"{name}_ddot" in data.data_vars:
        text += f", {_rms(accel - data[f'{name}_ddot'].values[keep]):.3g} rad/s^2"
    logger.info("measured %s departs from its periodic law by rms %s", name, text)


def _rms(values: np.ndarray) -> float:
    finite = values[np.isfinite(values)]
    return float(np.sqrt(np.mean(finite**2))) if finite.size else math.nan
