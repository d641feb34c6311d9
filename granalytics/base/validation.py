"""One way to validate arguments (the design of scikit-learn's parameter validation): a public
function declares a list of constraints per parameter, ``None`` in it allowing None, and
:func:`validate_params` refuses a value that satisfies none with one line naming the function, the
parameter, what is allowed and the value (a :class:`ParameterError`: one line on the command line,
exit status 2, never the AttributeError, TypeError or NumPy ValueError that the first use of the
value would raise somewhere inside)::

    @validate_params({"c_agg": [Interval(Real, 0, None)], "gamma": [Interval(Real, 0, None, closed="neither"), None]})
    def strength(snapshot, c_agg, gamma=None): ...

    strength(s, float("nan"))  # ParameterError: strength: c_agg must be a number >= 0, got float nan

Checks of data content (a time series without the column asked for) stay in the function.
"""

from __future__ import annotations

import functools
import inspect
import math
import os
from numbers import Integral, Real

import numpy as np

from granalytics.base.errors import ParameterError, one_line

__all__ = ["Constraint", "Interval", "Options", "Instance", "Array", "Window", "Callable", "Path", "POSITIVE", "FLAG",
           "PATH", "WINDOW", "typed_repr", "violation_message", "validate", "validate_params"]


def typed_repr(value, limit=60) -> str:
    """``type value`` for a message: the value's repr cut at ``limit`` characters."""
    text = repr(value)
    return f"{type(value).__name__} {text if len(text) <= limit else text[:limit - 3] + '...'}"


def _is_bool(value) -> bool:
    return isinstance(value, (bool, np.bool_))


class Constraint:
    """A set of allowed values: :meth:`accepts` tests one, ``str()`` describes the set in errors."""

    def accepts(self, value) -> bool:  # pragma: no cover - every constraint implements it
        raise NotImplementedError


class Interval(Constraint):
    """Numbers of ``type`` (``numbers.Real``: any int or float, NumPy's too; ``numbers.Integral``:
    whole numbers; a bool is neither) from ``lo`` to ``hi``, None for an open side (±inf stays
    outside; NaN is never inside); ``closed``: ``"both"``, ``"left"``, ``"right"`` or ``"neither"``."""

    def __init__(self, type, lo=None, hi=None, *, closed="both"):
        self.type, self.lo, self.hi, self.closed = type, lo, hi, closed

    def _edges(self):
        left = self.lo is not None and self.closed in ("both", "left")
        right = self.hi is not None and self.closed in ("both", "right")
        return -np.inf if self.lo is None else self.lo, np.inf if self.hi is None else self.hi, left, right

    def contains(self, values) -> bool:
        """Whether every one of ``values`` (a number or an array of numbers) lies inside."""
        lo, hi, left, right = self._edges()
        values = np.asarray(values)
        return bool(np.all(((values >= lo) if left else (values > lo)) & ((values <= hi) if right else (values < hi))))

    def accepts(self, value) -> bool:
        if not isinstance(value, self.type) or _is_bool(value):
            return False
        if self.type is not Integral:  # a real number is one a float holds: 10**400 is refused
            try:
                value = float(value)
            except OverflowError:
                return False
        lo, hi, left, right = self._edges()  # one number: compared without NumPy (a check of every frame)
        return bool((value >= lo if left else value > lo) and (value <= hi if right else value < hi))

    def describe(self, plural=False) -> str:
        """``"a number > 0"``; ``"numbers > 0"`` with ``plural``."""
        noun = "whole number" if self.type is Integral else "number" if (self.lo, self.hi) != (None, None) \
            else "finite number"
        left, right = self.closed in ("both", "left"), self.closed in ("both", "right")
        bounds = (f" in {'[('[not left]}{self.lo:g}, {self.hi:g}{'])'[not right]}" if None not in (self.lo, self.hi)
                  else f" {'>=' if left else '>'} {self.lo:g}" if self.lo is not None
                  else f" {'<=' if right else '<'} {self.hi:g}" if self.hi is not None else "")
        return f"{noun}s{bounds}" if plural else f"a {noun}{bounds}"

    def __str__(self):
        return self.describe()


class Options(Constraint):
    """One of ``values``, matched by type and value (``"1"`` is not 1, True is not 1)."""

    def __init__(self, values):
        self.values = tuple(values)

    def accepts(self, value) -> bool:
        return any(isinstance(value, type(v)) and _is_bool(value) == _is_bool(v) and value == v for v in self.values)

    def __str__(self):
        return f"one of {', '.join(map(repr, self.values))}"


class Instance(Constraint):
    """An instance of ``cls`` (a class or a tuple of classes), described as ``description`` if given."""

    def __init__(self, cls, description=None):
        self.cls, self.description = cls, description

    def accepts(self, value) -> bool:
        return isinstance(value, self.cls)

    def __str__(self):
        classes = self.cls if isinstance(self.cls, tuple) else (self.cls,)
        return self.description or " or ".join(f"a {c.__name__}" for c in classes)


class Array(Constraint):
    """Anything ``np.asarray`` turns into an array of ``dtype`` (``numbers.Real``, ``numbers.Integral``
    or ``str``; an empty one of any) with no bool in it, of ``ndim`` dimensions and ``length`` along
    the first axis (any without), ``finite`` (no NaN, ±inf) or every element ``within`` an
    :class:`Interval`."""

    _KINDS = {Real: "iuf", Integral: "iu", str: "U"}

    def __init__(self, ndim=None, *, length=None, dtype=Real, finite=False, within=None):
        self.ndim, self.length, self.dtype, self.finite, self.within = ndim, length, dtype, finite, within

    def accepts(self, value) -> bool:
        if value is None or isinstance(value, (str, bytes, dict, set)):
            return False
        try:
            array = np.asarray(value)
        except (TypeError, ValueError):  # a ragged list
            return False
        if self.dtype is str and array.dtype == object and all(isinstance(v, str) for v in array.flat):
            array = array.astype(str)  # a pandas Index or column of str
        if (self.ndim is not None and array.ndim != self.ndim) or (
                self.length is not None and (array.ndim == 0 or len(array) != self.length)):
            return False
        if not array.size:  # no element of another type
            return True
        if array.dtype.kind not in self._KINDS[self.dtype]:
            return False
        if isinstance(value, (list, tuple)) and any(
                _is_bool(v) or (self.dtype is str) != isinstance(v, str) for v in np.asarray(value, dtype=object).flat):
            return False  # NumPy reads [0.5, True] as numbers, ["a", 1] as str
        if self.within is not None:
            return self.within.contains(array)
        return not self.finite or bool(np.isfinite(array).all())

    def __str__(self):
        items = ("str" if self.dtype is str else self.within.describe(plural=True) if self.within is not None
                 else ("finite " if self.finite else "") + ("whole numbers" if self.dtype is Integral else "numbers"))
        if self.length == 2:
            return f"a pair of {items}"
        shape = {None: "an array", 1: "a sequence"}.get(self.ndim, f"a {self.ndim}-D array")
        return f"{shape} of {'' if self.length is None else f'{self.length} '}{items}"


class Window(Array):
    """A closed window ``(lo, hi)`` of revolutions or seconds: two finite numbers, lo <= hi."""

    def __init__(self):
        super().__init__(ndim=1, length=2, finite=True)

    def accepts(self, value) -> bool:
        if not super().accepts(value):
            return False
        lo, hi = (float(v) for v in np.asarray(value, dtype=float))  # a Series by position, not by its index
        return lo <= hi and math.isfinite(hi - lo)  # Python floats: a span beyond 1.8e308 is inf, not a warning

    def __str__(self):
        return "a pair of finite numbers (lo, hi) with lo <= hi"


class Callable(Constraint):
    """Anything callable (a function, a class, an object with ``__call__``)."""

    def accepts(self, value) -> bool:
        return callable(value)

    def __str__(self):
        return "a callable"


class Path(Constraint):
    """A path: a str or a path-like object of str (not bytes, None or a number), described as
    ``what`` in errors."""

    def __init__(self, what="a file name"):
        self.what = what

    def accepts(self, value) -> bool:
        return isinstance(value, (str, os.PathLike)) and isinstance(os.fspath(value), str)

    def __str__(self):
        return f"{self.what} (str or path-like)"


#: a finite number > 0 (a tolerance, a surface tension, a speed)
POSITIVE = Interval(Real, 0, None, closed="neither")
#: True or False (NumPy's bools included); never text such as "no" read by its truth value
FLAG = Instance((bool, np.bool_), "True or False")
#: a file name
PATH = Path()
#: a window (lo, hi) [revolutions or s]
WINDOW = Window()


def violation_message(allowed, value) -> str | None:
    """``"must be <allowed>, got <type> <value>"`` when ``value`` satisfies none of ``allowed`` (a list
    of constraints, None allowing None), else None."""
    if any(value is None if c is None else c.accepts(value) for c in allowed):
        return None
    text = [str(c) for c in allowed]
    text = text[0] if len(text) == 1 else f"{', '.join(text[:-1])} or {text[-1]}"
    return f"must be {text}, got {one_line(typed_repr(value))}"


def validate(where, constraints, values) -> None:
    """Raise :class:`ParameterError` (``"where: name must be …, got …"``, no prefix without ``where``)
    for the first parameter of ``constraints`` (name -> list of constraints) whose value in
    ``values`` satisfies none of them."""
    for name, allowed in constraints.items():
        why = violation_message(allowed, values[name])
        if why:
            raise ParameterError(f"{f'{where}: ' if where else ''}{name} {why}")


def validate_params(constraints):
    """Decorator: check the arguments of the decorated function against ``constraints`` (parameter
    name -> list of constraints: :class:`Constraint` objects, or None to allow None) before it runs;
    errors name the function by its qualified name (``Class.method`` for a method, ``Class`` for
    its ``__init__``)."""

    def decorate(func):
        signature = inspect.signature(func)
        unknown = sorted(set(constraints) - set(signature.parameters))
        if unknown:
            raise TypeError(f"validate_params: {func.__qualname__} has no parameter {', '.join(unknown)}")
        where = func.__qualname__.removesuffix(".__init__")
        arguments = _argument_reader(signature, constraints)

        @functools.wraps(func)
        def validated(*args, **kwargs):
            values = arguments(args, kwargs)
            if values is not None:  # None: a wrong call, left to Python's own error from the call itself
                validate(where, constraints, values)
            return func(*args, **kwargs)

        return validated

    return decorate


def _argument_reader(signature, names):
    """A function ``(args, kwargs) -> {name: value}`` of the parameters ``names`` in a call, defaults
    filled in, or None for a call that does not fit ``signature``. Without ``*args`` or
    ``**kwargs`` in the signature the values are read by position (the decorated functions run for
    every frame, and :meth:`inspect.Signature.bind` takes microseconds); otherwise through ``bind``."""
    params = signature.parameters
    kinds = {p.kind for p in params.values()}

    def bound(args, kwargs):
        try:
            call = signature.bind(*args, **kwargs)
        except TypeError:
            return None
        call.apply_defaults()
        return call.arguments

    if kinds - {inspect.Parameter.POSITIONAL_OR_KEYWORD, inspect.Parameter.KEYWORD_ONLY}:
        return bound
    positional = [n for n, p in params.items() if p.kind is inspect.Parameter.POSITIONAL_OR_KEYWORD]
    required = [n for n, p in params.items() if p.default is inspect.Parameter.empty]
    slots = [(name, positional.index(name) if name in positional else len(params), params[name].default)
             for name in names]

    def read(args, kwargs):
        given = positional[:len(args)]
        if len(args) > len(positional) or any(k not in params or k in given for k in kwargs) or any(
                n not in kwargs and n not in given for n in required):
            return None
        return {name: args[index] if index < len(args) else kwargs.get(name, default) for name, index, default in slots}

    return read
