"""Safe arithmetic formulas over named per-sample features.

A model term is one coefficient times a formula such as ``pos(vx) * sin(alpha)`` or
``payload_kg * speed``. Formulas are parsed with :mod:`ast` against a whitelist of node
types, functions and constants; nothing is ever passed to :func:`eval`, so a formula
read from a JSON file or typed on the command line cannot run arbitrary code.

A parsed :class:`Formula` can be evaluated on numpy arrays (vectorized) or rendered to a
scalar Python expression that numba compiles (see :meth:`Formula.to_scalar_source`).

Examples
--------
>>> f = parse_formula("pos(vx) * sin(alpha)")
>>> sorted(f.variables)
['alpha', 'vx']
>>> import numpy as np
>>> f.evaluate({"vx": np.array([0.3, -0.3]), "alpha": np.array([np.pi / 2, 1.0])})
array([0.3, 0. ])
>>> parse_formula("speed * (surface == 'mud')").evaluate(
...     {"speed": np.array([1.0, 2.0]), "surface": np.array(["mud", "grass"])})
array([1., 0.])
"""

from __future__ import annotations

import ast
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np

from energy_planner.errors import FormulaError

__all__ = ["Formula", "parse_formula", "FUNCTIONS", "CONSTANTS", "MOTION_FEATURES"]

#: The per-sample motion features every formula may read (the design notes); any other
#: variable of a formula is a log channel (a payload, a ground type, a temperature).
MOTION_FEATURES = frozenset({"alpha", "gamma", "vx", "vy", "wz", "ax", "ay", "speed"})


def _pos(x):
    return np.maximum(x, 0.0) + 0.0


def _min(x, y):
    return np.minimum(x, y) + 0.0


def _max(x, y):
    return np.maximum(x, y) + 0.0


def _sign(x):
    return np.sign(x) + 0.0


def _power(x, y):
    """``x ** y`` as C ``pow`` gives it (the compiled ``**``).

    numpy's ``power`` with the scalar exponent 0.5 takes ``sqrt``, which differs from
    ``pow`` at two inputs: ``pow(-inf, 0.5)`` is inf (sqrt: NaN) and ``pow(-0.0, 0.5)``
    is +0.0 (sqrt: -0.0). Its other scalar shortcuts (``x * x``, ``1 / x``) agree with
    ``pow`` on every special value and are kept (exact, and fast).
    """
    out = np.power(x, y)
    if np.ndim(y) == 0 and y == 0.5:
        out = np.where(np.isneginf(x), np.inf, out) + 0.0
    return out


#: Functions a formula may call: name -> (numpy implementation, numba/scalar source template).
#: The two give the same number for every input, NaN, infinities and signed zeros
#: included (``tests/test_formula_parity.py``): NaN propagates through ``min``, ``max``,
#: ``pos`` and ``sign`` in both (Python's ``max(1.0, nan)`` would give 1.0), and the
#: results of these four are normalised to +0.0 (numpy and numba break ties between
#: -0.0 and 0.0 differently). The templates use ``math`` and ``np`` (numpy): a module
#: that compiles them imports both.
FUNCTIONS: dict[str, tuple[Callable[..., Any], str]] = {
    "sin": (np.sin, "math.sin({0})"),
    "cos": (np.cos, "math.cos({0})"),
    "tan": (np.tan, "math.tan({0})"),
    "abs": (np.abs, "abs({0})"),
    "sqrt": (np.sqrt, "math.sqrt({0})"),
    "exp": (np.exp, "math.exp({0})"),
    "log": (np.log, "math.log({0})"),
    "pos": (_pos, "(np.maximum({0}, 0.0) + 0.0)"),
    "min": (_min, "(np.minimum({0}, {1}) + 0.0)"),
    "max": (_max, "(np.maximum({0}, {1}) + 0.0)"),
    "sign": (_sign, "(np.sign({0}) + 0.0)"),
}
_ARITY = {"min": 2, "max": 2}

#: Named constants a formula may use.
CONSTANTS: dict[str, float] = {"pi": math.pi, "g": 9.81}

_BINOPS: dict[type, tuple[Callable[[Any, Any], Any], str]] = {
    ast.Add: (np.add, "+"),
    ast.Sub: (np.subtract, "-"),
    ast.Mult: (np.multiply, "*"),
    ast.Div: (np.divide, "/"),  # compiled as np.divide: x / 0 is inf or NaN, not an error
    ast.Pow: (_power, "**"),
}
_CMPOPS: dict[type, tuple[Callable[[Any, Any], Any], str]] = {
    ast.Eq: (np.equal, "=="),
    ast.NotEq: (np.not_equal, "!="),
    ast.Lt: (np.less, "<"),
    ast.LtE: (np.less_equal, "<="),
    ast.Gt: (np.greater, ">"),
    ast.GtE: (np.greater_equal, ">="),
}


@dataclass(frozen=True)
class Formula:
    """A parsed, validated formula.

    Attributes
    ----------
    text : str
        The canonical text (``ast.unparse`` of the parsed tree): equal formulas written
        with different spacing have the same text.
    variables : frozenset of str
        The feature names the formula reads.
    """

    text: str
    variables: frozenset[str]
    _tree: ast.expr = field(repr=False, compare=False)

    def evaluate(self, features: Mapping[str, Any]) -> np.ndarray:
        """Evaluate on arrays of per-sample features (broadcast to a float array).

        Raises
        ------
        FormulaError
            If a variable is missing from ``features``.
        """
        missing = sorted(v for v in self.variables if v not in features)
        if missing:
            raise FormulaError(
                f"formula {self.text!r} needs {', '.join(map(repr, missing))}, which the data "
                f"does not have; available: {', '.join(sorted(map(str, features))) or 'none'}"
            )
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            out = _eval(self._tree, features)
        return np.asarray(out, dtype=float)

    @cached_property
    def channel_uses(self) -> tuple[dict[str, frozenset[str]], frozenset[str]]:
        """How the formula reads each variable: as a category or as a number.

        Walked once per formula (every cost and every priced path types its model's
        channels, :func:`energy_planner.energy.channels.channel_kinds`).

        Returns
        -------
        categories : dict
            Variable -> the strings it is compared with (``ground == 'mud'``): a
            categorical variable and the categories the formula names.
        numeric : frozenset of str
            Variables read as numbers: in arithmetic, in a function, or compared with a
            number. A variable compared only with another variable is in neither.

        Examples
        --------
        >>> cats, numeric = parse_formula("(ground == 'mud') * speed + load_kg").channel_uses
        >>> cats, sorted(numeric)
        ({'ground': frozenset({'mud'})}, ['load_kg', 'speed'])
        """
        cats: dict[str, set[str]] = {}
        numeric: set[str] = set()
        _uses(self._tree, cats, numeric)
        return {k: frozenset(v) for k, v in sorted(cats.items())}, frozenset(numeric)

    def to_scalar_source(self, variables: Mapping[str, str], constants: Mapping[str, Any]) -> str:
        """Render as a scalar Python expression (for numba code generation).

        The expression uses the names ``math`` and ``np`` (numpy): the module that
        compiles it imports both. Compiled, it gives the same number as :meth:`evaluate`
        for every input, NaN and infinities included (division by zero gives inf or NaN,
        as in numpy, not an error).

        Parameters
        ----------
        variables : mapping
            Feature name -> local variable name in the generated function.
        constants : mapping
            Feature name -> constant value (numbers or strings) substituted at render
            time; string comparisons against constants are folded.
        """
        return _src(self._tree, variables, constants, self.text)


def parse_formula(text: str) -> Formula:
    """Parse and validate a term formula.

    Parameters
    ----------
    text : str
        Arithmetic over feature names, numbers, strings (for categorical channels),
        ``+ - * / **``, comparisons (which give 0 or 1), the functions in
        :data:`FUNCTIONS` and the constants in :data:`CONSTANTS`.

    Raises
    ------
    FormulaError
        With the offending name or construct and the valid choices.

    Examples
    --------
    >>> parse_formula("speed*speed").text
    'speed * speed'
    >>> parse_formula("__import__('os')")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    energy_planner.errors.FormulaError: unknown function '__import__' ... valid functions: abs, ...
    """
    if not isinstance(text, str) or not text.strip():
        raise FormulaError(f"a term formula must be a non-empty string, got {text!r}")
    formula = _PARSED.get(text)
    if formula is None:
        try:
            tree = ast.parse(text.strip(), mode="eval").body
        except SyntaxError as exc:
            raise FormulaError(f"cannot parse formula {text!r}: {exc.msg}") from exc
        variables: set[str] = set()
        _check(tree, text, variables)
        formula = Formula(text=ast.unparse(tree), variables=frozenset(variables), _tree=tree)
        if len(_PARSED) > 4096:
            _PARSED.clear()
        _PARSED[text] = formula
        _PARSED.setdefault(formula.text, formula)  # the canonical text parses to itself
    return formula


#: :func:`parse_formula`'s formulas by text, once per process: the term catalog parses its
#: terms when it is built and a model parses the canonical texts again when it reads them
#: (17 texts twice in a warm ``energy``); a :class:`Formula` is immutable, so one object
#: serves every caller.
_PARSED: dict[str, Formula] = {}


def _check(node: ast.AST, text: str, variables: set[str]) -> None:
    if isinstance(node, ast.Constant):
        if isinstance(node.value, bool) or not isinstance(node.value, int | float | str):
            raise FormulaError(f"constant {node.value!r} in {text!r} is not a number or string")
    elif isinstance(node, ast.Name):
        if node.id in FUNCTIONS:
            raise FormulaError(f"{node.id!r} in {text!r} is a function: call it, e.g. {node.id}(x)")
        if node.id not in CONSTANTS:
            variables.add(node.id)
    elif isinstance(node, ast.BinOp):
        if type(node.op) not in _BINOPS:
            raise FormulaError(
                f"operator {type(node.op).__name__} in {text!r} is not allowed; "
                "valid: + - * / ** and comparisons"
            )
        _check(node.left, text, variables)
        _check(node.right, text, variables)
    elif isinstance(node, ast.UnaryOp):
        if not isinstance(node.op, ast.USub | ast.UAdd):
            raise FormulaError(f"unary {type(node.op).__name__} in {text!r} is not allowed")
        _check(node.operand, text, variables)
    elif isinstance(node, ast.Compare):
        if len(node.ops) != 1 or type(node.ops[0]) not in _CMPOPS:
            raise FormulaError(f"use one comparison at a time (==, !=, <, <=, >, >=) in {text!r}")
        _check(node.left, text, variables)
        _check(node.comparators[0], text, variables)
    elif isinstance(node, ast.Call):
        name = node.func.id if isinstance(node.func, ast.Name) else ast.unparse(node.func)
        if name not in FUNCTIONS:
            raise FormulaError(
                f"unknown function {name!r} in {text!r}; valid functions: "
                + ", ".join(sorted(FUNCTIONS))
            )
        arity = _ARITY.get(name, 1)
        if node.keywords or len(node.args) != arity:
            raise FormulaError(f"{name}() takes {arity} argument(s) in {text!r}")
        for arg in node.args:
            _check(arg, text, variables)
    else:
        raise FormulaError(
            f"{type(node).__name__} ({ast.unparse(node)!r}) is not allowed in formula {text!r}; "
            "use numbers, feature names, + - * / **, comparisons and "
            + ", ".join(sorted(FUNCTIONS))
        )


def _eval(node: ast.AST, f: Mapping[str, Any]) -> Any:
    if isinstance(node, ast.Constant):
        return node.value
    if isinstance(node, ast.Name):
        if node.id in CONSTANTS:
            return CONSTANTS[node.id]
        value = f[node.id]
        arr = np.asarray(value)
        return arr.astype(float) if arr.dtype.kind in "biuf" else arr
    if isinstance(node, ast.BinOp):
        return _BINOPS[type(node.op)][0](_eval(node.left, f), _eval(node.right, f))
    if isinstance(node, ast.UnaryOp):
        v = _eval(node.operand, f)
        return -v if isinstance(node.op, ast.USub) else v
    if isinstance(node, ast.Compare):
        left, right = _eval(node.left, f), _eval(node.comparators[0], f)
        return _CMPOPS[type(node.ops[0])][0](left, right).astype(float)
    assert isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
    return FUNCTIONS[node.func.id][0](*(_eval(a, f) for a in node.args))


def _src(node: ast.AST, variables: Mapping[str, str], constants: Mapping[str, Any], text: str):
    def rec(n: ast.AST) -> str:
        return _src(n, variables, constants, text)

    if isinstance(node, ast.Constant):
        return repr(node.value) if isinstance(node.value, str) else _number_source(node.value)
    if isinstance(node, ast.Name):
        if node.id in CONSTANTS:
            return _number_source(CONSTANTS[node.id])
        if node.id in variables:
            return variables[node.id]
        if node.id in constants:
            value = constants[node.id]
            return repr(value) if isinstance(value, str) else _number_source(value)
        raise FormulaError(
            f"formula {text!r} needs {node.id!r}; give it with --set {node.id}=VALUE (a "
            f"constant) or --channel {node.id}=RASTER[:TABLE] (a map), or choose a model "
            "without this term"
        )
    if isinstance(node, ast.BinOp):
        if isinstance(node.op, ast.Div):  # numba's "/" raises ZeroDivisionError
            return f"np.divide({rec(node.left)}, {rec(node.right)})"
        return f"({rec(node.left)} {_BINOPS[type(node.op)][1]} {rec(node.right)})"
    if isinstance(node, ast.UnaryOp):
        return f"(-{rec(node.operand)})" if isinstance(node.op, ast.USub) else rec(node.operand)
    if isinstance(node, ast.Compare):
        op = type(node.ops[0])
        known = [_constant(n, variables, constants) for n in (node.left, node.comparators[0])]
        if all(k is not _UNKNOWN for k in known):
            # both sides known at render time (e.g. a categorical channel given as a
            # constant compared with a string): fold the comparison.
            return "1.0" if bool(_CMPOPS[op][0](known[0], known[1])) else "0.0"
        if any(isinstance(k, str) for k in known):
            var = node.left if known[0] is _UNKNOWN else node.comparators[0]
            name = var.id if isinstance(var, ast.Name) else ast.unparse(var)
            cat = known[1] if known[0] is _UNKNOWN else known[0]
            raise FormulaError(
                f"formula {text!r} compares {name} with the category {cat!r}, but {name} is "
                f"given as numbers per cell or sample: a raster of category codes needs its "
                f"value table, --channel {name}=RASTER:TABLE (a CSV of code,category rows, "
                f"e.g. 1,{cat}); or give one category for the whole map, --set {name}={cat}",
                value=name,
                column=name,
                hint=f"--channel {name}=RASTER:TABLE",
            )
        left, right = rec(node.left), rec(node.comparators[0])
        return f"(1.0 if {left} {_CMPOPS[op][1]} {right} else 0.0)"
    assert isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
    return FUNCTIONS[node.func.id][1].format(*(rec(a) for a in node.args))


def _uses(node: ast.AST, cats: dict[str, set[str]], numeric: set[str]) -> None:
    """Collect the variables compared with strings (``cats``) and read as numbers."""
    if isinstance(node, ast.Name):
        if node.id not in CONSTANTS:
            numeric.add(node.id)
        return
    if isinstance(node, ast.Compare):
        sides = (node.left, node.comparators[0])
        for side, other in (sides, sides[::-1]):
            if not (isinstance(side, ast.Name) and side.id not in CONSTANTS):
                _uses(side, cats, numeric)
            elif isinstance(other, ast.Constant) and isinstance(other.value, str):
                cats.setdefault(side.id, set()).add(other.value)
            elif not (isinstance(other, ast.Name) and other.id not in CONSTANTS):
                numeric.add(side.id)  # compared with a number or an expression
        return
    children = node.args if isinstance(node, ast.Call) else ast.iter_child_nodes(node)
    for child in children:
        _uses(child, cats, numeric)


_UNKNOWN = object()


def _number_source(value: Any) -> str:
    """Source of a float constant; NaN and infinities as ``math.nan`` / ``math.inf``.

    ``repr(float("nan"))`` is ``nan``, a name the generated module does not define.

    Examples
    --------
    >>> _number_source(2), _number_source(float("nan")), _number_source(float("-inf"))
    ('2.0', 'math.nan', '(-math.inf)')
    """
    v = float(value)
    if math.isnan(v):
        return "math.nan"
    if math.isinf(v):
        return "math.inf" if v > 0 else "(-math.inf)"
    return repr(v)


def _constant(node: ast.AST, variables: Mapping[str, str], constants: Mapping[str, Any]) -> Any:
    """The value of ``node`` if it is known before run time, else ``_UNKNOWN``."""
    if isinstance(node, ast.Constant):
        return node.value
    if isinstance(node, ast.Name) and node.id not in variables:
        if node.id in CONSTANTS:
            return CONSTANTS[node.id]
        if node.id in constants:
            return constants[node.id]
    return _UNKNOWN
