# Hand-written: no library parses a safe boolean filter over arrays (pandas.eval and numexpr build on Python's eval).
"""User-defined edge criteria as a variant of graph network analysis (method ``"custom"``).

A criterion is a Python callable on the contact table or, for the command line, a string of
clauses ``COLUMN OP NUMBER`` / ``NUMBER OP COLUMN`` (:data:`COLUMNS`; OP one of ``< <= > >= ==
!=``; chained: ``0.2 < f_norm <= 0.8``) joined by ``and``, ``or``, ``not`` and parentheses. A
string is parsed with :mod:`ast`, checked node by node against that whitelist and evaluated
with numpy (never ``eval``); anything else is refused with a one-line
:class:`~granalytics.base.errors.ParameterError` before any data is read.
"""

from __future__ import annotations

import ast
import functools
import sys

import numpy as np

from granalytics.base.errors import ParameterError
from granalytics.core.snapshot import Snapshot
from granalytics.identification import kernels as _kernels
from granalytics.identification.cohesion import COHESION, DEFAULT_COHESION
from granalytics.identification.common import RADIUS_MODE, Identifier
from granalytics.identification.contacts import contact_table
from granalytics.identification.result import IdentificationResult
from granalytics.base.validation import POSITIVE, Callable, Instance

__all__ = ["CustomEdges", "COLUMNS", "compile_criterion"]

#: the names a criterion may use: the columns of :func:`granalytics.identification.edges.contact_table`
COLUMNS = ("i", "j", "id_i", "id_j", "f_cap", "f_coh", "f_normal", "gap", "bridge_volume",
           "f_norm", "angle_v_deg", "angle_w_deg", "rigid_residual")

MAX_LENGTH = 1000  # characters of a criterion string
MAX_DEPTH = 100  # nesting of and / or / not

_COMPARE = {ast.Lt: np.less, ast.LtE: np.less_equal, ast.Gt: np.greater, ast.GtE: np.greater_equal,
            ast.Eq: np.equal, ast.NotEq: np.not_equal}
_REFUSED = {ast.BinOp: "arithmetic", ast.Call: "function calls", ast.Attribute: "attribute access",
            ast.Subscript: "subscripts", ast.Lambda: "lambda", ast.NamedExpr: "':='", ast.JoinedStr: "f-strings",
            **dict.fromkeys((ast.ListComp, ast.SetComp, ast.DictComp, ast.GeneratorExp), "comprehensions")}
_GRAMMAR = ("a criterion string takes only clauses COLUMN OP NUMBER (OP one of < <= > >= == !=, chained "
            "as in 0.2 < f_norm < 0.8) joined by and/or/not and parentheses; for anything else pass a "
            "callable on the contact table from Python")


def _snippet(text, limit=60):
    """``text`` on one line, shortened, quoted."""
    text = " ".join(str(text).split())
    return repr(text if len(text) <= limit else text[:limit - 3] + "...")


def _refuse(node, source, what=None):
    """Raise the one-line error for a ``node`` outside the grammar."""
    if what is None:
        if isinstance(node, ast.Constant):
            what = {bool: "booleans", str: "strings", bytes: "bytes", complex: "complex numbers"}.get(
                type(node.value), f"the constant {node.value!r}")
        elif isinstance(getattr(node, "op", None), (ast.BitAnd, ast.BitOr, ast.Invert)):
            what = "'&', '|', '~' (write and, or, not)"
        elif isinstance(node, ast.UnaryOp):
            what = "arithmetic"
        else:
            what = _REFUSED.get(type(node), f"'{type(node).__name__}' expressions")
    text = ast.get_source_segment(source, node)
    raise ParameterError(f"not allowed: {what}{f' ({_snippet(text)})' if text else ''}; {_GRAMMAR}")


def _operand(node, source):
    """A column (its name, a str) or a number (an int or float, its sign included)."""
    if isinstance(node, ast.Name):
        if node.id not in COLUMNS:
            raise ParameterError(f"name {node.id!r} is not a column; columns: {', '.join(COLUMNS)}")
        return node.id
    signed = isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.UAdd, ast.USub))
    number = node.operand if signed else node
    if not (isinstance(number, ast.Constant) and type(number.value) in (int, float)):
        _refuse(node, source)
    if abs(number.value) > sys.float_info.max:  # an int beyond float64 cannot meet a float column
        _refuse(node, source, "numbers beyond ±1.8e308")
    return -number.value if signed and isinstance(node.op, ast.USub) else number.value


def _clause(node, source):
    """``table -> mask`` of a comparison: every adjacent pair of its terms is a column and a number."""
    if any(type(op) not in _COMPARE for op in node.ops):
        _refuse(node, source, "'in', 'not in', 'is', 'is not'")
    terms = [_operand(term, source) for term in (node.left, *node.comparators)]
    steps = []
    for op, left, right in zip(node.ops, terms, terms[1:]):
        if isinstance(left, str) == isinstance(right, str):
            _refuse(node, source, "comparing two columns" if isinstance(left, str) else "comparing two numbers")
        steps.append((_COMPARE[type(op)], left, right))

    def mask(table):
        value = {name: np.asarray(table[name]) for name in terms if isinstance(name, str)}
        return functools.reduce(np.logical_and, (compare(value.get(a, a), value.get(b, b)) for compare, a, b in steps))
    return mask


def _condition(node, source, depth=0):
    """``table -> mask`` of a checked condition (a clause, or and / or / not of conditions)."""
    if depth > MAX_DEPTH:
        raise ParameterError(f"expression nested deeper than {MAX_DEPTH} levels")
    if isinstance(node, ast.Compare):
        return _clause(node, source)
    if isinstance(node, ast.BoolOp):
        parts = [_condition(value, source, depth + 1) for value in node.values]
        combine = np.logical_and if isinstance(node.op, ast.And) else np.logical_or
        return lambda table: functools.reduce(combine, (part(table) for part in parts))
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.Not):
        part = _condition(node.operand, source, depth + 1)
        return lambda table: np.logical_not(part(table))
    if isinstance(node, ast.Name) or (isinstance(node, ast.Constant) and type(node.value) in (int, float)):
        _operand(node, source)  # an unknown name is refused as such
        _refuse(node, source, "a bare column or number where a comparison belongs")
    _refuse(node, source)


def compile_criterion(source: str):
    """The criterion string ``source`` as a function of the contact table (a DataFrame or a dict of
    columns) that gives one bool per contact; a one-line :class:`ParameterError` naming what in
    ``source`` is outside the grammar (the module docstring), e.g. arithmetic or a call.
    """
    if not isinstance(source, str):
        raise ParameterError(f"criterion must be an expression string or a callable, got {type(source).__name__}")
    text = source.strip()
    try:
        if len(text) > MAX_LENGTH:
            raise ParameterError(f"expression is {len(text)} characters long, at most {MAX_LENGTH} are allowed")
        try:
            tree = ast.parse(text, mode="eval")
        except (SyntaxError, ValueError, RecursionError, MemoryError) as exc:
            detail = exc.msg if isinstance(exc, SyntaxError) else type(exc).__name__
            raise ParameterError(f"not a valid expression ({detail}); {_GRAMMAR}") from None
        return _condition(tree.body, text)
    except ParameterError as exc:
        raise ParameterError(f"edge criterion {_snippet(source)} failed: {exc}") from None


class CustomEdges(Identifier):
    """GNA with user-defined edge criteria (method ``"custom"``): granules are the connected
    components (≥ 2 particles) of the contacts a criterion keeps.

    Parameters
    ----------
    criterion : callable or str
        A callable taking the contact table (:func:`~granalytics.identification.edges.contact_table`,
        a DataFrame with the columns :data:`COLUMNS`) and returning one bool per contact; or a
        string of comparisons of a column with a number joined by ``and``, ``or``, ``not``, e.g.
        ``"f_norm >= 0.5 and (angle_v_deg < 30 or angle_w_deg < 30)"`` (:func:`compile_criterion`).
    radius : {"pair", "mean"}
        R in ``f_norm``.
    surface_tension : float, optional
        γ [N/m] in ``f_norm``; defaults to the run metadata's.
    cohesion : {"acting", "bridge"}, default "acting"
        Which force is ``f_coh`` (and so ``f_norm``); :mod:`granalytics.identification.cohesion`.
    """

    method = "custom"
    _parameter_constraints = {"criterion": [Callable(), Instance(str, "a criterion string")], "radius": [RADIUS_MODE],
                              "surface_tension": [POSITIVE, None], "cohesion": [COHESION]}

    def __init__(self, criterion, *, radius="pair", surface_tension=None, cohesion=DEFAULT_COHESION):
        self._select = criterion if callable(criterion) else compile_criterion(criterion)
        self.criterion = criterion
        self.radius = radius
        self.surface_tension = surface_tension
        self.cohesion = cohesion

    def _param_value(self, name):
        value = getattr(self, name)
        if name == "criterion" and not isinstance(value, str):  # a callable, by its name
            return getattr(value, "__name__", repr(value))
        return value

    def identify(self, snapshot: Snapshot) -> IdentificationResult:
        """Keep the contacts the criterion selects; label their components."""
        table = contact_table(snapshot, self.radius, self.surface_tension, self.cohesion)
        name = _snippet(self._param_value("criterion"))
        try:
            keep = np.asarray(self._select(table))
        except Exception as exc:  # a user function: report it, whatever it raised
            raise ParameterError(f"edge criterion {name} failed: {type(exc).__name__}: {_snippet(exc, 120)}") from exc
        if keep.shape != (snapshot.n_contacts,) or keep.dtype != np.bool_:
            raise ParameterError(f"edge criterion {name} must give one boolean per contact ({snapshot.n_contacts}), "
                                 f"got dtype {keep.dtype} shape {keep.shape}")
        membership = _kernels.union_find_membership(snapshot.n_particles, snapshot.contact_i[keep], snapshot.contact_j[keep])
        labels, sizes = _kernels.canonical_labels(membership)
        return IdentificationResult(labels=labels, sizes=sizes, method=self.method, params=self.params(),
                                    snapshot=snapshot, kept=keep)
