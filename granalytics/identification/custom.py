"""User-defined edge criteria as a variant of graph network analysis (method ``"custom"``).

A criterion string is never handed to ``eval`` or :meth:`pandas.DataFrame.eval`: it is parsed
with :mod:`ast` and evaluated here, node by node, on the numpy columns of the contact table.
Only the small grammar below is accepted; everything else is refused with a one-line
:class:`~granalytics.core.errors.ParameterError` before any data is touched.

* names: the columns of :func:`granalytics.identification.edges.contact_table` (:data:`COLUMNS`);
* numbers: int and float literals;
* comparisons ``< <= > >= == !=``, chained ones included (``0.2 < f_norm < 0.8``);
* ``and``, ``or``, ``not`` and their pandas spellings ``&``, ``|``, ``~``, elementwise on
  booleans (``&`` and ``|`` have the precedence of ``and`` and ``or``, as in pandas);
* unary ``+ -``, binary ``+ - * / ** %``, parentheses;
* calls of :data:`FUNCTIONS` by bare name with positional arguments.
"""

from __future__ import annotations

import ast
import io
import operator
import tokenize

import numpy as np

from granalytics.identification.cohesion import DEFAULT_COHESION, check_cohesion
from granalytics.identification import kernels as _kernels
from granalytics.identification.contacts import contact_table
from granalytics.core.errors import ParameterError
from granalytics.core.snapshot import Snapshot
from granalytics.identification.common import Identifier
from granalytics.identification.result import IdentificationResult

__all__ = ["CustomEdges", "COLUMNS", "FUNCTIONS", "compile_criterion", "evaluate_criterion"]

#: the names a criterion may use: the columns of :func:`granalytics.identification.edges.contact_table`
COLUMNS = ("i", "j", "id_i", "id_j", "f_cap", "f_coh", "f_normal", "gap", "bridge_volume",
           "f_norm", "angle_v_deg", "angle_w_deg", "rigid_residual")

#: function name -> (numpy function, number of arguments)
FUNCTIONS = {
    "abs": (np.abs, 1), "sqrt": (np.sqrt, 1), "exp": (np.exp, 1), "log": (np.log, 1),
    "log10": (np.log10, 1), "minimum": (np.minimum, 2), "maximum": (np.maximum, 2),
}

MAX_LENGTH = 1000  # characters of a criterion string
MAX_DEPTH = 100  # nesting of the expression tree

_COMPARE = {ast.Lt: np.less, ast.LtE: np.less_equal, ast.Gt: np.greater, ast.GtE: np.greater_equal,
            ast.Eq: np.equal, ast.NotEq: np.not_equal}
_ARITH = {ast.Add: np.add, ast.Sub: np.subtract, ast.Mult: np.multiply, ast.Div: np.true_divide,
          ast.Pow: np.power, ast.Mod: np.mod}
_EXACT = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Pow: operator.pow,
          ast.Mod: operator.mod}
_LOGIC = {ast.BitAnd: np.logical_and, ast.BitOr: np.logical_or}
_UNARY = {ast.UAdd: np.positive, ast.USub: np.negative}
_SYMBOL = {ast.Lt: "<", ast.LtE: "<=", ast.Gt: ">", ast.GtE: ">=", ast.Eq: "==", ast.NotEq: "!=",
           ast.Add: "+", ast.Sub: "-", ast.Mult: "*", ast.Div: "/", ast.Pow: "**", ast.Mod: "%",
           ast.BitAnd: "&", ast.BitOr: "|", ast.Invert: "~", ast.Not: "not", ast.UAdd: "+", ast.USub: "-",
           ast.And: "and", ast.Or: "or", ast.FloorDiv: "//", ast.MatMult: "@", ast.LShift: "<<",
           ast.RShift: ">>", ast.BitXor: "^", ast.In: "in", ast.NotIn: "not in", ast.Is: "is",
           ast.IsNot: "is not"}
_CONSTRUCTS = {
    ast.Attribute: "attribute access", ast.Subscript: "subscripts", ast.Lambda: "lambda",
    ast.ListComp: "comprehensions", ast.SetComp: "comprehensions", ast.DictComp: "comprehensions",
    ast.GeneratorExp: "comprehensions", ast.JoinedStr: "f-strings", ast.NamedExpr: "':=' (assignment)",
    ast.Starred: "starred arguments", ast.IfExp: "'if ... else'", ast.List: "lists", ast.Tuple: "tuples",
    ast.Set: "sets", ast.Dict: "dicts", ast.Await: "await", ast.Yield: "yield", ast.YieldFrom: "yield",
    ast.Slice: "slices", ast.FormattedValue: "f-strings",
}
_GRAMMAR = ("allowed: column names, numbers, comparisons, and/or/not (&/|/~), + - * / ** %, "
            "parentheses, " + "/".join(FUNCTIONS) + "(...)")


def _snippet(text, limit=60):
    """``text`` on one line, shortened, quoted."""
    text = " ".join(str(text).split())
    return repr(text if len(text) <= limit else text[:limit - 3] + "...")


def _refuse(what):
    raise ParameterError(what)


def _scan_tokens(source):
    """Refuse ``@`` (not Python syntax before a name, so refused here with a clear message) and
    stray characters; rewrite the operators ``&``/``|`` as ``and``/``or``, which gives them the
    precedence pandas gives them (``a > 1 & b < 2`` means ``(a > 1) & (b < 2)``)."""
    try:
        tokens = list(tokenize.generate_tokens(io.StringIO(source).readline))
    except (tokenize.TokenError, SyntaxError):
        return source  # unbalanced brackets and the like: ast.parse reports them
    starts, pos = [0], 0
    for line in source.splitlines(keepends=True):
        pos += len(line)
        starts.append(pos)
    pieces, last = [], 0
    for tok in tokens:
        (row, col) = tok.start
        if tok.type == tokenize.OP and tok.string in ("@", "@="):
            _refuse(f"'@' is not allowed (line {row}, column {col + 1}): criteria see only the edge table's "
                    f"columns, not Python variables; {_GRAMMAR}")
        if tok.type == tokenize.ERRORTOKEN and not tok.string.isspace():
            _refuse(f"unexpected character {tok.string!r} (line {row}, column {col + 1}); {_GRAMMAR}")
        if tok.type == tokenize.OP and tok.string in ("&", "|"):
            offset = starts[row - 1] + col
            pieces.append(source[last:offset])
            pieces.append(" and " if tok.string == "&" else " or ")
            last = offset + 1
    pieces.append(source[last:])
    return "".join(pieces)


def _describe(node, source):
    """What ``node`` is, for an error message: its construct and its text."""
    text = ast.get_source_segment(source, node)
    return f" ({_snippet(text)})" if text else ""


def _check(node, source, depth=0):
    """Refuse any node outside the grammar (recursively)."""
    if depth > MAX_DEPTH:
        _refuse(f"expression nested deeper than {MAX_DEPTH} levels")
    here = _describe(node, source)
    if isinstance(node, ast.Expression):
        return _check(node.body, source, depth + 1)
    if isinstance(node, ast.Constant):
        value = node.value
        if type(value) is not int and type(value) is not float:
            kind = {bool: "booleans", str: "strings", bytes: "bytes", complex: "complex numbers"}.get(
                type(value), f"the constant {value!r}")
            _refuse(f"not allowed: {kind}{here}; {_GRAMMAR}")
        _literal(value, here)
        return
    if isinstance(node, ast.Name):
        if node.id in COLUMNS:
            return
        if node.id in FUNCTIONS:
            _refuse(f"function {node.id!r} must be called, e.g. {node.id}(f_norm)")
        _refuse(f"name {node.id!r} is not a column or allowed function; columns: {', '.join(COLUMNS)}; "
                f"functions: {', '.join(FUNCTIONS)}")
    if isinstance(node, ast.Compare):
        for op in node.ops:
            if type(op) not in _COMPARE:
                _refuse(f"the operator '{_SYMBOL.get(type(op), type(op).__name__)}' is not allowed{here}; {_GRAMMAR}")
        for child in (node.left, *node.comparators):
            _check(child, source, depth + 1)
        return
    if isinstance(node, ast.BoolOp):
        for child in node.values:
            _check(child, source, depth + 1)
        return
    if isinstance(node, ast.BinOp):
        if type(node.op) not in _ARITH and type(node.op) not in _LOGIC:
            _refuse(f"the operator '{_SYMBOL.get(type(node.op), type(node.op).__name__)}' is not allowed{here}; "
                    f"{_GRAMMAR}")
        _check(node.left, source, depth + 1)
        _check(node.right, source, depth + 1)
        return
    if isinstance(node, ast.UnaryOp):
        _check(node.operand, source, depth + 1)
        return
    if isinstance(node, ast.Call):
        func = node.func
        if not isinstance(func, ast.Name) or func.id not in FUNCTIONS:
            name = func.id if isinstance(func, ast.Name) else ast.get_source_segment(source, func) or "this"
            _refuse(f"calling {_snippet(name)} is not allowed; only {', '.join(FUNCTIONS)} can be called, by bare name")
        if node.keywords:
            _refuse(f"keyword arguments are not allowed{here}")
        if any(isinstance(arg, ast.Starred) for arg in node.args):
            _refuse(f"starred arguments are not allowed{here}")
        if len(node.args) != FUNCTIONS[func.id][1]:
            _refuse(f"{func.id}() takes {FUNCTIONS[func.id][1]} argument(s), got {len(node.args)}{here}")
        for arg in node.args:
            _check(arg, source, depth + 1)
        return
    construct = _CONSTRUCTS.get(type(node), f"'{type(node).__name__}' expressions")
    _refuse(f"not allowed: {construct}{here}; {_GRAMMAR}")


def _literal(value, here=""):
    """A numeric literal: an int as a Python int (integer arithmetic stays exact, see
    :func:`_arithmetic`), a float as a float64 scalar."""
    if type(value) is int:
        return value
    try:
        return np.float64(float(value))
    except OverflowError:
        _refuse(f"the number{here} is too large")


#: the most bits an integer in a criterion may have (about 1e1233): beyond it ``**`` is refused
MAX_INTEGER_BITS = 4096


def _is_integer(value) -> bool:
    """Whether ``value`` holds integers only: a Python int, a numpy integer (array), or an object
    array of Python ints (the result of exact integer arithmetic)."""
    if isinstance(value, (bool, np.bool_)):
        return False
    if isinstance(value, (int, np.integer)):
        return True
    arr = np.asarray(value)
    if arr.dtype.kind in "iu":
        return True
    return arr.dtype == object and all(type(v) is int for v in arr.flat)


def _exact(value):
    """An integer operand as Python ints (an object array for an array): they neither round
    (float64 holds integers exactly only up to 2**53) nor wrap around (int64 stops at 2**63)."""
    if isinstance(value, (int, np.integer)):
        return int(value)
    return np.asarray(value).astype(object)


def _bits(value) -> int:
    return max((abs(int(v)).bit_length() for v in np.asarray(value, dtype=object).flat), default=0)


def _arithmetic(op, left, right):
    """``left op right``. Integers with ``+ - * ** %`` are computed exactly (as Python ints:
    ``id_i ** 3`` of an id above 2**21 is exact, where float64 would round it); ``/`` and any
    float operand give float64, as in numpy."""
    if op is ast.Div or not (_is_integer(left) and _is_integer(right)):
        return _ARITH[op](left, right)
    left, right = _exact(left), _exact(right)
    if op is ast.Pow:
        exponent = max((int(v) for v in np.asarray(right, dtype=object).flat), default=0)
        if exponent > 0 and _bits(left) * exponent > MAX_INTEGER_BITS:
            _refuse(f"integer power too large: a {_bits(left)}-bit number to the power {exponent} has more than "
                    f"{MAX_INTEGER_BITS} bits")
    if op is ast.Mod and any(int(v) == 0 for v in np.asarray(right, dtype=object).flat):
        _refuse("integer modulo by zero")
    result = _EXACT[op](left, right)  # Python's operators: a numpy ufunc would turn Python ints into int64
    if _bits(result) > MAX_INTEGER_BITS:
        _refuse(f"integer arithmetic gives a number of more than {MAX_INTEGER_BITS} bits")
    return result


def compile_criterion(source) -> ast.Expression:
    """Parse and check a criterion string; the checked tree, or a one-line :class:`ParameterError`."""
    if not isinstance(source, str):
        raise ParameterError(f"criterion must be an expression string or a callable, got {type(source).__name__}")
    try:
        return _compile(source.strip())
    except ParameterError as exc:
        raise ParameterError(f"edge criterion {_snippet(source)} failed: {exc}") from None


def _syntax_error(exc, positions=True):
    where = ""
    if positions and exc.offset:
        where = f" at line {exc.lineno}, column {exc.offset}" if (exc.lineno or 1) > 1 else f" at column {exc.offset}"
    text = f" near {_snippet(exc.text)}" if exc.text and exc.text.strip() else ""
    _refuse(f"not a valid expression ({exc.msg}{where}{text}); {_GRAMMAR}")


def _parse(text):
    try:
        return ast.parse(text, mode="eval")
    except (RecursionError, MemoryError, ValueError) as exc:
        _refuse(f"not a valid expression ({type(exc).__name__}); {_GRAMMAR}")


def _compile(source):
    if len(source) > MAX_LENGTH:
        _refuse(f"expression is {len(source)} characters long, at most {MAX_LENGTH} are allowed")
    if "\x00" in source:
        _refuse("null character in the expression")
    if not source:
        _refuse(f"empty expression; {_GRAMMAR}")
    rewritten = _scan_tokens(source)
    try:
        tree = _parse(rewritten)
    except SyntaxError as exc:
        if rewritten != source:  # positions in the text as written
            try:
                _parse(source)
            except SyntaxError as original:
                _syntax_error(original)
        _syntax_error(exc, positions=rewritten == source)
    _check(tree, rewritten)
    return tree


def _is_bool(value):
    return np.asarray(value).dtype == np.bool_


def _evaluate(node, columns):
    """Value of a checked tree on ``columns`` (name -> numpy array)."""
    if isinstance(node, ast.Expression):
        return _evaluate(node.body, columns)
    if isinstance(node, ast.Constant):
        return _literal(node.value)
    if isinstance(node, ast.Name):
        return columns[node.id]
    if isinstance(node, ast.Compare):
        left, result = _evaluate(node.left, columns), None
        for op, comparator in zip(node.ops, node.comparators):
            right = _evaluate(comparator, columns)
            step = _COMPARE[type(op)](left, right)
            result = step if result is None else np.logical_and(result, step)
            left = right
        return result
    if isinstance(node, ast.BoolOp):
        values = [_evaluate(child, columns) for child in node.values]
        _need_bool(values, "and" if isinstance(node.op, ast.And) else "or")
        combine = np.logical_and if isinstance(node.op, ast.And) else np.logical_or
        result = values[0]
        for value in values[1:]:
            result = combine(result, value)
        return result
    if isinstance(node, ast.BinOp):
        left, right = _evaluate(node.left, columns), _evaluate(node.right, columns)
        if type(node.op) in _LOGIC:
            _need_bool([left, right], _SYMBOL[type(node.op)])
            return _LOGIC[type(node.op)](left, right)
        return _arithmetic(type(node.op), left, right)
    if isinstance(node, ast.UnaryOp):
        operand = _evaluate(node.operand, columns)
        if isinstance(node.op, (ast.Not, ast.Invert)):
            _need_bool([operand], _SYMBOL[type(node.op)])
            return np.logical_not(operand)
        if _is_integer(operand):  # exact, as in _arithmetic: -(2**70) stays an integer
            return -_exact(operand) if isinstance(node.op, ast.USub) else _exact(operand)
        return _UNARY[type(node.op)](operand)
    if isinstance(node, ast.Call):  # the functions are float functions: exact integers enter as float64
        func = FUNCTIONS[node.func.id][0]
        return func(*(_as_float(_evaluate(arg, columns)) for arg in node.args))
    raise AssertionError(f"unchecked node {type(node).__name__}")  # _check refuses every other node


def _as_float(value):
    """Python-int results of exact integer arithmetic as float64 (numpy's functions have no
    object loops); everything else as it is."""
    if isinstance(value, int) and not isinstance(value, bool):
        return np.float64(value)
    arr = np.asarray(value)
    return arr.astype(np.float64) if arr.dtype == object else value


def _need_bool(values, op):
    for value in values:
        if not _is_bool(value):
            _refuse(f"'{op}' needs true/false operands such as comparisons, got {np.asarray(value).dtype} values; "
                    f"write e.g. (f_norm >= 0.5) {op} (angle_v_deg < 30)" if op not in ("not", "~")
                    else f"'{op}' needs a true/false operand such as a comparison, got {np.asarray(value).dtype} "
                         f"values; write e.g. {op}(f_norm >= 0.5)")


def evaluate_criterion(tree, table, n_contacts, source=None) -> np.ndarray:
    """The boolean mask (one entry per contact) of a tree from :func:`compile_criterion` on the
    contact table (``source``: the criterion as written, for error messages)."""
    columns = {name: table[name].to_numpy() for name in COLUMNS}
    try:
        with np.errstate(all="ignore"):
            value = np.asarray(_evaluate(tree, columns))
        if value.dtype != np.bool_:
            kind = "integer" if value.dtype == object else value.dtype
            _refuse(f"the expression gives {kind} values, not true/false; use a comparison, e.g. f_norm >= 0.5")
    except (TypeError, ValueError, ArithmeticError) as exc:  # ParameterError included
        detail = str(exc) if isinstance(exc, ParameterError) else f"evaluation error: {_snippet(exc, 120)}"
        label = source if source is not None else ast.unparse(tree)
        raise ParameterError(f"edge criterion {_snippet(label)} failed: {detail}") from None
    if value.ndim == 0:
        return np.full(n_contacts, bool(value))
    return value


class CustomEdges(Identifier):
    """GNA with user-defined edge criteria (method ``"custom"``): granules are the connected
    components (≥ 2 particles) of the contacts a criterion keeps.

    Parameters
    ----------
    criterion : str or callable
        An expression on the columns of :func:`~granalytics.identification.edges.contact_table` (``i``,
        ``j``, ``id_i``, ``id_j``, ``f_cap``, ``f_coh``, ``f_normal``, ``gap``, ``bridge_volume``,
        ``f_norm``, ``angle_v_deg``, ``angle_w_deg``, ``rigid_residual`` [m/s]), e.g.
        ``"f_norm >= 0.5 and (angle_v_deg < 30 or angle_w_deg < 30)"``. It is parsed and
        evaluated by granalytics itself, never by ``eval``: only column names, int and float
        literals, comparisons (chained too), ``and``/``or``/``not`` (also ``&``/``|``/``~``),
        unary ``+ -``, ``+ - * / ** %``, parentheses and the functions ``abs``, ``sqrt``,
        ``exp``, ``log``, ``log10``, ``minimum``, ``maximum`` are accepted; anything else
        raises :class:`~granalytics.core.errors.ParameterError`. Or, from Python, a callable
        taking that table (a DataFrame) and returning a boolean array.
    radius : {"pair", "mean"}
        R in ``f_norm``.
    surface_tension : float, optional
        γ [N/m] in ``f_norm``; defaults to the run metadata's.
    cohesion : {"acting", "bridge"}, default "acting"
        Which force is ``f_coh`` (and so ``f_norm``); :mod:`granalytics.identification.cohesion`.
    """

    method = "custom"

    def __init__(self, criterion, *, radius="pair", surface_tension=None, cohesion=DEFAULT_COHESION):
        if isinstance(criterion, str):
            self._tree = compile_criterion(criterion)
        elif callable(criterion):
            self._tree = None
        else:
            raise ParameterError(f"criterion must be an expression string or a callable, got {type(criterion).__name__}")
        self.criterion = criterion
        self.radius = radius
        self.surface_tension = surface_tension
        self.cohesion = check_cohesion(cohesion)

    def _param_value(self, name):
        value = getattr(self, name)
        if name == "criterion" and not isinstance(value, str):  # a callable, by its name
            return getattr(value, "__name__", repr(value))
        return value

    def identify(self, snapshot: Snapshot) -> IdentificationResult:
        """Keep the contacts the criterion selects; label their components."""
        table = contact_table(snapshot, self.radius, self.surface_tension, self.cohesion)
        if self._tree is not None:
            keep = evaluate_criterion(self._tree, table, snapshot.n_contacts, self.criterion)
        else:
            try:
                keep = self.criterion(table)
            except Exception as exc:  # a user function: report it, whatever it raised
                raise ParameterError(f"edge criterion {self._param_value('criterion')!r} failed: {exc}") from None
        keep = np.asarray(keep)
        if keep.shape != (snapshot.n_contacts,) or keep.dtype != np.bool_:
            raise ParameterError(f"edge criterion must give one boolean per contact ({snapshot.n_contacts}), "
                                 f"got dtype {keep.dtype} shape {keep.shape}")
        membership = _kernels.union_find_membership(snapshot.n_particles, snapshot.contact_i[keep], snapshot.contact_j[keep])
        labels, sizes = _kernels.canonical_labels(membership)
        return IdentificationResult(labels=labels, sizes=sizes, method=self.method, params=self.params(),
                                    snapshot=snapshot, kept=keep)
