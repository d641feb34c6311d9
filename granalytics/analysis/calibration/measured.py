"""A measured sieve analysis: the size distribution of a granulator's product in sieve classes
(:class:`MeasuredDistribution`), read from a CSV file (:func:`read_sieve_csv`) with the checks of
its rows, its apertures and its fractions (docs/calibration.md, "The measured distribution")."""

from __future__ import annotations

import csv
import math
import os
from dataclasses import dataclass
from numbers import Real

import numpy as np
import pandas as pd

from granalytics.base.errors import ParameterError
from granalytics.base.files import regular_input
from granalytics.base.validation import PATH, Array, Interval, validate, validate_params

__all__ = ["MeasuredDistribution", "read_sieve_csv", "SUM_TOLERANCE", "CLASS_EDGES"]

#: how far from 1 the mass fractions of a measured distribution may sum (then they are rescaled to 1)
SUM_TOLERANCE = 0.01
#: the constraint of a sum tolerance
_TOLERANCE = Interval(Real, 0, None)
#: the largest sieve file read [bytes] (a sieve analysis has a few dozen classes)
MAX_SIEVE_BYTES = 1_000_000
#: the largest sieve aperture read as metres [m]: a larger one is in another unit
MAX_APERTURE_M = 0.1
#: the smallest standard error of a measured fraction accepted (0 weighs a class infinitely)
MIN_SIGMA = 1e-6

_CLASS_FIELDS = ("lower_m", "upper_m", "mass_fraction")
_PASSING_FIELDS = ("aperture_m", "passing_fraction")


class _ClassEdges(Array):
    """Class boundaries [m]: two or more ascending sizes >= 0 (the last may be ``inf``)."""

    def __init__(self):
        super().__init__(ndim=1)

    def accepts(self, value) -> bool:
        if not super().accepts(value):
            return False
        edges = np.asarray(value, dtype=float)
        return edges.size >= 2 and edges[0] >= 0 and bool((np.diff(edges) > 0).all())

    def __str__(self):
        return "a sequence of two or more ascending sizes >= 0 [m]"


#: the constraint of class edges [m]
CLASS_EDGES = _ClassEdges()


@dataclass(frozen=True)
class MeasuredDistribution:
    """A measured size distribution in sieve classes.

    Attributes
    ----------
    edges_m : (K+1,) float array [m]
        Class boundaries, ascending: class k is [edges_m[k], edges_m[k+1]); the first may be 0
        (the pan) and the last ``inf`` (retained on the top sieve).
    fractions : (K,) float array
        Mass fraction per class, summing to 1.
    sigma : (K+1,) float array or None
        Standard error of the cumulative mass fraction passing at each edge (mass fraction), when
        the file gives one.
    source : str
        Where it came from (a file's path, or a description).

    The constructor refuses edges, fractions or errors of another shape or range
    (:class:`ParameterError`) and keeps them as float arrays.
    """

    edges_m: np.ndarray
    fractions: np.ndarray
    sigma: np.ndarray | None = None
    source: str = "measured"

    def __post_init__(self):
        k = np.size(self.edges_m) - 1
        validate("MeasuredDistribution", {"edges_m": [CLASS_EDGES],
                                          "fractions": [Array(ndim=1, length=k, within=Interval(Real, 0, 1))],
                                          "sigma": [Array(ndim=1, length=k + 1, within=Interval(Real, 0, None)), None]},
                 vars(self))
        for name in ("edges_m", "fractions", "sigma"):
            if getattr(self, name) is not None:
                object.__setattr__(self, name, np.asarray(getattr(self, name), dtype=float))

    @property
    def n_classes(self) -> int:
        """Number of classes K."""
        return int(self.fractions.size)

    @property
    def passing(self) -> np.ndarray:
        """Cumulative mass fraction passing (smaller than) each edge, (K+1,)."""
        return np.r_[0.0, np.cumsum(self.fractions)]

    def table(self) -> pd.DataFrame:
        """One row per class: ``lower_m``, ``upper_m`` [m], ``mass_fraction``, ``passing_upper``
        (cumulative fraction passing the upper edge)."""
        return pd.DataFrame({"lower_m": self.edges_m[:-1], "upper_m": self.edges_m[1:], "mass_fraction": self.fractions,
                             "passing_upper": self.passing[1:]})

    @classmethod
    @validate_params({"lower_m": [Array(ndim=1)], "upper_m": [Array(ndim=1)], "mass_fraction": [Array(ndim=1)],
                      "sigma": [Array(ndim=1), None], "tolerance": [_TOLERANCE]})
    def from_classes(cls, lower_m, upper_m, mass_fraction, sigma=None, source="measured",
                     tolerance=SUM_TOLERANCE) -> "MeasuredDistribution":
        """From class bounds [m] and mass fractions (validated as :func:`read_sieve_csv` does; rows
        are counted from 1)."""
        lengths = [len(lower_m), len(upper_m), len(mass_fraction), *([] if sigma is None else [len(sigma)])]
        if len(set(lengths)) > 1:
            raise ParameterError(f"MeasuredDistribution.from_classes: lower_m, upper_m, mass_fraction and sigma must "
                                 f"hold one value per class, got {', '.join(map(str, lengths))} values")
        rows = [{"lower_m": lo, "upper_m": hi, "mass_fraction": m} for lo, hi, m in zip(lower_m, upper_m, mass_fraction)]
        return _from_class_rows(source, [(k + 1, row) for k, row in enumerate(rows)], tolerance,
                                None if sigma is None else np.asarray(sigma, float))


def _bad(path, row, field, value, why) -> ParameterError:
    where = f"{path}: row {row}" + (f", field {field}" if field else "")
    return ParameterError(f"{where}: {why}" + ("" if value is None else f" (got {value!r})"))


def _number(path, row, field, text, *, allow_inf=False) -> float:
    try:
        value = float(text)
    except (TypeError, ValueError):
        raise _bad(path, row, field, text, "not a number") from None
    if math.isnan(value) or (math.isinf(value) and not (allow_inf and value > 0)):
        raise _bad(path, row, field, text, "must be a finite number" + (" (or inf)" if allow_inf else ""))
    if value < 0:
        raise _bad(path, row, field, text, "must not be negative")
    return value


@validate_params({"path": [PATH], "tolerance": [_TOLERANCE]})
def read_sieve_csv(path, tolerance=SUM_TOLERANCE) -> MeasuredDistribution:
    """Read a measured sieve analysis from a CSV file.

    Two forms, told apart by the header (lines starting with ``#`` are comments):

    - classes: ``lower_m,upper_m,mass_fraction`` — one row per sieve class, apertures in metres
      (``upper_m`` of the last class may be ``inf``), mass fractions summing to 1;
    - cumulative: ``aperture_m,passing_fraction`` — the cumulative mass fraction passing each
      aperture, apertures ascending; the classes are [0, a₁), [a₁, a₂), …, and, when the last
      value is below 1, [a_K, ∞) holding the rest.

    An optional last column ``sigma`` gives the standard error of the cumulative fraction passing
    each class's upper edge (or each aperture).

    Parameters
    ----------
    path : str or path-like
    tolerance : float, default 0.01
        The fractions (classes form) or the last passing value (cumulative form, when it is the
        whole) may differ from 1 by this much; they are then rescaled to sum to 1.

    Raises
    ------
    ParameterError
        One line naming the file, the row (counted from 1, the header being row 0 of the data) and
        the field and value: a value that is not a number, negative or NaN; fractions that do not
        sum to 1 within ``tolerance``; classes that are not sorted, overlap or leave a gap; a
        decreasing cumulative fraction; fewer than two classes.
    """
    path = os.fspath(path)
    regular_input(path)  # a FIFO would block for ever
    if os.path.getsize(path) > MAX_SIEVE_BYTES:
        raise ParameterError(f"{path}: {os.path.getsize(path) / 1e6:.3g} MB is not a sieve analysis (a few dozen "
                             f"classes; at most {MAX_SIEVE_BYTES / 1e6:g} MB are read)")
    try:
        with open(path, newline="") as handle:
            lines = [line for line in handle if line.strip() and not line.lstrip().startswith("#")]
    except OSError as exc:
        raise ParameterError(f"{path}: cannot read the measured distribution ({exc.strerror or exc})") from None
    except UnicodeDecodeError:
        raise ParameterError(f"{path}: not a text (CSV) file") from None
    if not lines:
        raise ParameterError(f"{path}: empty (expected a header lower_m,upper_m,mass_fraction or "
                             "aperture_m,passing_fraction)")
    reader = csv.reader(lines)
    header = [h.strip() for h in next(reader)]
    if len(set(header)) != len(header):
        raise ParameterError(f"{path}: header {','.join(header)!r} names a column twice")
    base = [h for h in header if h != "sigma"]
    if tuple(base) not in (_CLASS_FIELDS, _PASSING_FIELDS) or header[: len(base)] != base:
        raise ParameterError(f"{path}: header {','.join(header)!r}: expected lower_m,upper_m,mass_fraction[,sigma] "
                             "or aperture_m,passing_fraction[,sigma]")
    rows = []
    for k, values in enumerate(reader, start=1):
        if len(values) != len(header):
            raise _bad(path, k, None, ",".join(values), f"expected {len(header)} fields ({','.join(header)})")
        rows.append((k, dict(zip(header, (v.strip() for v in values)))))
    sigma = None
    if "sigma" in header:
        sigma = np.array([_number(path, k, "sigma", row["sigma"]) for k, row in rows])
        small = np.flatnonzero(~(sigma >= MIN_SIGMA))
        if small.size:
            k = rows[small[0]][0]
            raise _bad(path, k, "sigma", rows[small[0]][1]["sigma"],
                       f"a standard error of a fraction must be >= {MIN_SIGMA:g} (typically 0.005-0.05); 0 would "
                       "weigh that class infinitely")
    measured = (_from_class_rows if tuple(base) == _CLASS_FIELDS else _from_passing_rows)(path, rows, tolerance, sigma)
    edges = measured.edges_m[np.isfinite(measured.edges_m)]
    if edges.size and edges.max() > MAX_APERTURE_M:
        column = "upper_m" if tuple(base) == _CLASS_FIELDS else "aperture_m"
        largest = float(edges.max())
        unit = "micrometres" if largest > 100 else "millimetres"
        raise ParameterError(f"{path}: column {column}: an aperture of {largest:g} m is larger than any granulator's "
                             f"granule (at most {MAX_APERTURE_M:g} m is read as metres): the file is likely in {unit}; "
                             "give apertures in metres")
    return measured


def _check_count(path, rows):
    if len(rows) < 2:
        raise ParameterError(f"{path}: {len(rows)} class(es); a size distribution needs at least two")


def _from_class_rows(path, rows, tolerance, sigma):
    _check_count(path, rows)
    lower, upper, frac = [], [], []
    for k, row in rows:
        lo = _number(path, k, "lower_m", row["lower_m"])
        hi = _number(path, k, "upper_m", row["upper_m"], allow_inf=k == rows[-1][0])
        m = _number(path, k, "mass_fraction", row["mass_fraction"])
        if hi <= lo:
            raise _bad(path, k, "upper_m", row["upper_m"], f"must be above lower_m {lo:g}")
        if lower:
            if lo < lower[-1]:
                raise _bad(path, k, "lower_m", row["lower_m"], f"classes not sorted: below the previous class's "
                                                               f"lower_m {lower[-1]:g}")
            if lo < upper[-1]:
                raise _bad(path, k, "lower_m", row["lower_m"], f"overlaps the previous class [{lower[-1]:g}, "
                                                               f"{upper[-1]:g})")
            if lo > upper[-1]:
                raise _bad(path, k, "lower_m", row["lower_m"], f"a gap after the previous class's upper_m "
                                                               f"{upper[-1]:g} (sieve classes are contiguous)")
        lower.append(lo)
        upper.append(hi)
        frac.append(m)
    frac = np.array(frac)
    total = frac.sum()
    if abs(total - 1) > tolerance:
        raise ParameterError(f"{path}: field mass_fraction: the fractions sum to {total:.6g}, not 1 within "
                             f"{tolerance:g}")
    if sigma is not None:
        sigma = np.r_[0.0, sigma]  # nothing passes the first class's lower edge... by definition
    return MeasuredDistribution(np.array([lower[0], *upper]), frac / total, sigma, str(path))


def _from_passing_rows(path, rows, tolerance, sigma):
    _check_count(path, rows)
    apertures, passing = [], []
    for k, row in rows:
        a = _number(path, k, "aperture_m", row["aperture_m"])
        p = _number(path, k, "passing_fraction", row["passing_fraction"])
        if a == 0:
            raise _bad(path, k, "aperture_m", row["aperture_m"], "must be above 0")
        if apertures and a <= apertures[-1]:
            raise _bad(path, k, "aperture_m", row["aperture_m"], f"apertures not sorted ascending (previous "
                                                                 f"{apertures[-1]:g})")
        if apertures and p < passing[-1]:
            raise _bad(path, k, "passing_fraction", row["passing_fraction"], f"decreases (previous {passing[-1]:g}); "
                                                                             "the mass passing is cumulative")
        if p > 1 + tolerance:
            raise _bad(path, k, "passing_fraction", row["passing_fraction"], f"above 1 (by more than {tolerance:g})")
        apertures.append(a)
        passing.append(p)
    passing = np.array(passing)
    edges = [0.0, *apertures]
    if passing[-1] >= 1 - tolerance:  # the last aperture passes everything
        passing = passing / passing[-1]
    else:
        edges.append(math.inf)
        passing = np.r_[passing, 1.0]
        if sigma is not None:
            sigma = np.r_[sigma, 0.0]
    if sigma is not None:
        sigma = np.r_[0.0, sigma]
    return MeasuredDistribution(np.array(edges), np.diff(np.r_[0.0, passing]), sigma, str(path))
