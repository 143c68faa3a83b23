# Copyright 2026 observer_ros contributors
#
# Licensed under the Apache License, Version 2.0 (the "License");
# you may not use this file except in compliance with the License.
# You may obtain a copy of the License at
#
#     http://www.apache.org/licenses/LICENSE-2.0
#
# Unless required by applicable law or agreed to in writing, software
# distributed under the License is distributed on an "AS IS" BASIS,
# WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied.
# See the License for the specific language governing permissions and
# limitations under the License.


"""
User expressions parsed by a whitelist: the equations of a nonlinear model, never code.

An expression such as ``v * cos(yaw)`` or ``(v + w * b / 2) / r`` is parsed with Python's
:mod:`ast` and then checked node by node: numbers, the model's names, the operators
``+ - * / **`` and unary ``-``/``+``, parentheses, and calls of the functions of
:data:`FUNCTIONS` with their number of arguments, with ``pi`` and ``e``. Anything else (an
attribute, a subscript, a comparison, a keyword argument, a string, a lambda...) is refused
with a :class:`ExpressionError` that names the expression, the column and what is allowed.
Nothing of the user's text is ever evaluated, executed or compiled: the checked tree is
walked by :meth:`Expression.build` with the caller's symbols and functions (SymPy's in
:mod:`observer_ros.core.nonlinear.model`; ``math``'s in the tests).
"""

import ast
from dataclasses import dataclass
import math
from typing import Callable, Iterable, Mapping, Optional
import warnings

from observer_ros.core.errors import ConfigError

__all__ = ['CONSTANTS', 'Expression', 'ExpressionError', 'FUNCTIONS', 'MAX_LENGTH',
           'parse_expression', 'reserved_name_problem']

#: The functions an expression may call and how many arguments each takes (None: two or
#: more).
FUNCTIONS = {
    'sin': 1, 'cos': 1, 'tan': 1, 'asin': 1, 'acos': 1, 'atan': 1, 'atan2': 2,
    'sinh': 1, 'cosh': 1, 'tanh': 1, 'exp': 1, 'log': 1, 'sqrt': 1, 'abs': 1,
    'min': None, 'max': None,
}

#: The named numbers an expression may use.
CONSTANTS = {'pi': math.pi, 'e': math.e}

#: The longest expression taken, in characters (a longer one is refused before parsing).
MAX_LENGTH = 10_000

#: The deepest nesting of operations taken (deeper is refused; Python's own parser and the
#: symbolic library recurse on it).
MAX_DEPTH = 100

_BINARY = {ast.Add: '+', ast.Sub: '-', ast.Mult: '*', ast.Div: '/', ast.Pow: '**'}
_UNARY = {ast.USub: '-', ast.UAdd: '+'}

ALLOWED = ('numbers, the names {names}, pi, e, the operators + - * / ** and unary -, '
           'parentheses and the functions ' + ', '.join(
               f'{name}({"x, y" if count == 2 else "x, y, ..." if count is None else "x"})'
               for name, count in FUNCTIONS.items()))


class ExpressionError(ConfigError):
    """
    An expression that is not one of the allowed equations.

    ``parameter`` names the expression (``dynamics.x``, ``outputs.wheel_left``); the reason
    quotes it, gives the column (1-based) and says what is allowed.
    """


def reserved_name_problem(name: str) -> Optional[str]:
    """
    Say why ``name`` cannot name a state, input, output or constant (None: it can).

    Examples
    --------
    >>> reserved_name_problem('yaw') is None
    True
    >>> reserved_name_problem('cos')
    "'cos' is a function of the expressions"

    """
    if not isinstance(name, str) or not name.isidentifier() or name.startswith('_'):
        return (f'{name!r} is not a name (letters, digits and _, not starting with a digit '
                f'or _)')
    if name in FUNCTIONS:
        return f'{name!r} is a function of the expressions'
    if name in CONSTANTS:
        return f'{name!r} is a constant of the expressions'
    import keyword
    if keyword.iskeyword(name):
        return f'{name!r} is a Python keyword'
    return None


@dataclass(frozen=True)
class Expression:
    """
    A checked expression: its text, its tree and the names it uses.

    Attributes
    ----------
    label : str
        What the expression is (``dynamics.yaw``), for messages.
    text : str
    tree : ast.expr
        Checked: only the nodes :func:`parse_expression` allows.
    names : frozenset of str
        The model names it uses.
    """

    label: str
    text: str
    tree: ast.expr
    names: frozenset

    def build(self, symbols: Mapping[str, object], functions: Mapping[str, Callable],
              constants: Optional[Mapping[str, object]] = None,
              number: Optional[Callable] = None):
        """
        Return the expression made of ``symbols`` and ``functions`` (a walk of the tree).

        Parameters
        ----------
        symbols : mapping
            A value or symbol for each name of :attr:`names`.
        functions : mapping
            A callable for each name of :data:`FUNCTIONS` the expression calls.
        constants : mapping, optional
            ``pi`` and ``e`` (default: the floats of :data:`CONSTANTS`).
        number : callable, optional
            Makes each number written in the expression (default: the number itself; a
            model passes each as a parameter, so generated code keeps its exact value).

        Examples
        --------
        >>> import math
        >>> expression = parse_expression('v * cos(yaw)', ['v', 'yaw'])
        >>> expression.build({'v': 2.0, 'yaw': 0.0}, {'cos': math.cos})
        2.0

        """
        constants = CONSTANTS if constants is None else constants
        return _build(self.tree, symbols, functions, constants, number)


def _build(node, symbols, functions, constants, number):
    if isinstance(node, ast.Constant):
        return node.value if number is None else number(node.value)
    if isinstance(node, ast.Name):
        return symbols[node.id] if node.id in symbols else constants[node.id]
    if isinstance(node, ast.UnaryOp):
        operand = _build(node.operand, symbols, functions, constants, number)
        return -operand if isinstance(node.op, ast.USub) else +operand
    if isinstance(node, ast.BinOp):
        left = _build(node.left, symbols, functions, constants, number)
        right = _build(node.right, symbols, functions, constants, number)
        op = type(node.op)
        if op is ast.Add:
            return left + right
        if op is ast.Sub:
            return left - right
        if op is ast.Mult:
            return left * right
        if op is ast.Div:
            return left / right
        return left ** right
    arguments = [_build(argument, symbols, functions, constants, number)
                 for argument in node.args]
    return functions[node.func.id](*arguments)


def _fail(label: str, text: str, node, what: str, names: Iterable[str]) -> ExpressionError:
    column = getattr(node, 'col_offset', None)
    where = '' if column is None else f' at column {column + 1}'
    allowed = ALLOWED.format(names=', '.join(sorted(names)) or '(none)')
    return ExpressionError(label, f'{text!r}{where}: {what}; expected {allowed}')


def _check(node, label, text, names, used, depth):
    if depth > MAX_DEPTH:
        raise _fail(label, text, node, f'nested deeper than {MAX_DEPTH}', names)
    if isinstance(node, ast.Constant):
        value = node.value
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise _fail(label, text, node, f'{value!r} is not a real number', names)
        if not math.isfinite(value):
            raise _fail(label, text, node, f'{value!r} is not a finite number', names)
        return
    if isinstance(node, ast.Name):
        if node.id in names:
            used.add(node.id)
            return
        if node.id in CONSTANTS:
            return
        if node.id in FUNCTIONS:
            raise _fail(label, text, node, f'the function {node.id} is not called', names)
        raise _fail(label, text, node, f'unknown name {node.id!r}', names)
    if isinstance(node, ast.UnaryOp):
        if type(node.op) not in _UNARY:
            raise _fail(label, text, node, f'the operator {type(node.op).__name__} is not '
                        f'allowed', names)
        _check(node.operand, label, text, names, used, depth + 1)
        return
    if isinstance(node, ast.BinOp):
        if type(node.op) not in _BINARY:
            raise _fail(label, text, node, f'the operator {type(node.op).__name__} is not '
                        f'allowed', names)
        _check(node.left, label, text, names, used, depth + 1)
        _check(node.right, label, text, names, used, depth + 1)
        return
    if isinstance(node, ast.Call):
        function = node.func
        if not isinstance(function, ast.Name) or function.id not in FUNCTIONS:
            called = function.id if isinstance(function, ast.Name) else 'this'
            raise _fail(label, text, node, f'{called!r} is not a function of the '
                        f'expressions', names)
        if node.keywords or any(isinstance(a, ast.Starred) for a in node.args):
            raise _fail(label, text, node, f'{function.id} takes plain arguments only',
                        names)
        count = FUNCTIONS[function.id]
        given = len(node.args)
        if (count is None and given < 2) or (count is not None and given != count):
            expected = 'two or more' if count is None else str(count)
            raise _fail(label, text, node, f'{function.id} takes {expected} argument'
                        f'{"" if count == 1 else "s"}, got {given}', names)
        for argument in node.args:
            _check(argument, label, text, names, used, depth + 1)
        return
    raise _fail(label, text, node, f'{type(node).__name__} is not allowed', names)


def parse_expression(text, names: Iterable[str], label: str = 'expression') -> Expression:
    """
    Parse and check ``text`` against the whitelist; nothing of it is evaluated.

    Parameters
    ----------
    text : str
        One expression, such as ``'v * cos(yaw)'``.
    names : iterable of str
        The names it may use: the model's states, inputs and constants.
    label : str
        What the expression is, for the error (``dynamics.x``).

    Returns
    -------
    Expression

    Raises
    ------
    ExpressionError
        Not a string, empty, too long, not a Python expression, or a part that is not
        allowed: the message quotes the expression, the column (1-based) and what is
        allowed.

    Examples
    --------
    >>> parse_expression('v * cos(yaw)', ['v', 'yaw', 'w']).names == {'v', 'yaw'}
    True
    >>> parse_expression('v.real', ['v'], 'dynamics.x')  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    observer_ros.core.nonlinear.expressions.ExpressionError: dynamics.x: 'v.real' at column 1: \
Attribute is not allowed; expected numbers, the names v, pi, e, ...

    """
    names = frozenset(names)
    if isinstance(text, str):
        text = text.strip()
    else:
        raise _fail(label, repr(text)[:40], None, f'expected a string, got '
                    f'{type(text).__name__}', names)
    if not text:
        raise _fail(label, text, None, 'the expression is empty', names)
    if len(text) > MAX_LENGTH:
        raise _fail(label, text[:40] + '...', None, f'longer than {MAX_LENGTH} characters',
                    names)
    try:
        with warnings.catch_warnings():  # "invalid decimal literal" and the like: refused
            warnings.simplefilter('ignore', SyntaxWarning)
            tree = ast.parse(text, mode='eval')
    except SyntaxError as e:
        column = (e.offset or 1) - 1
        raise _fail(label, text, _At(column), f'not an expression ({e.msg})', names) from None
    except (ValueError, RecursionError, MemoryError) as e:
        raise _fail(label, text, None, f'cannot be parsed ({type(e).__name__})',
                    names) from None
    used: set = set()
    try:
        _check(tree.body, label, text, names, used, 0)
    except RecursionError:
        raise _fail(label, text, None, f'nested deeper than {MAX_DEPTH}', names) from None
    return Expression(label, text, tree.body, frozenset(used))


class _At:
    """A position without a node (a syntax error's column)."""

    def __init__(self, column: int) -> None:
        self.col_offset = max(0, column)
