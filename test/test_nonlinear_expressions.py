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
Expressions of a nonlinear model: a whitelist, errors that say where and what, never code.

The model's equations come from a parameter file; a user's text must never run. These tests
hold the parser to its whitelist (every operator and function it allows evaluates as
``math`` would), its errors to naming the expression, the column and what is allowed, and
fuzz it: random text raises nothing but :class:`ExpressionError`, and nothing is evaluated.
"""

import builtins
import math

from hypothesis import given, settings, strategies as st
import pytest

from observer_ros.core.errors import ConfigError
from observer_ros.core.nonlinear import expressions
from observer_ros.core.nonlinear.expressions import (
    ExpressionError, FUNCTIONS, parse_expression, reserved_name_problem)

NAMES = ('x', 'yaw', 'v', 'r')
VALUES = {'x': 0.3, 'yaw': -1.2, 'v': 2.5, 'r': 0.05}
MATH = {name: getattr(math, name) for name in FUNCTIONS if hasattr(math, name)}
MATH.update({'abs': abs, 'min': min, 'max': max})


def evaluate(text):
    return parse_expression(text, NAMES).build(VALUES, MATH)


@pytest.mark.parametrize('text, expected', [
    ('v * cos(yaw)', 2.5 * math.cos(-1.2)),
    ('(v + x * 0.3 / 2) / r', (2.5 + 0.3 * 0.3 / 2) / 0.05),
    ('-x ** 2', -(0.3 ** 2)),
    ('+x - -v', 0.3 + 2.5),
    ('atan2(x, v) + exp(x) - log(v) + sqrt(v)',
     math.atan2(0.3, 2.5) + math.exp(0.3) - math.log(2.5) + math.sqrt(2.5)),
    ('min(x, v, r) + max(x, v) + abs(yaw)', 0.05 + 2.5 + 1.2),
    ('sinh(x) * cosh(x) / tanh(x) + asin(x) + acos(x) + atan(x) + tan(x) + sin(pi * e)',
     math.sinh(0.3) * math.cosh(0.3) / math.tanh(0.3) + math.asin(0.3) + math.acos(0.3)
     + math.atan(0.3) + math.tan(0.3) + math.sin(math.pi * math.e)),
    ('  2 ** 3  ', 8),
])
def test_every_allowed_operator_and_function_evaluates_as_math(text, expected):
    assert evaluate(text) == pytest.approx(expected, rel=1e-15)


def test_the_names_an_expression_uses_are_listed():
    assert parse_expression('v * cos(yaw) + pi', NAMES).names == {'v', 'yaw'}


@pytest.mark.parametrize('text, column, what', [
    ('v.real', 1, 'Attribute is not allowed'),
    ('v * foo(x)', 5, "'foo' is not a function"),
    ('x + q', 5, "unknown name 'q'"),
    ('x[0]', 1, 'Subscript is not allowed'),
    ('x if v else r', 1, 'IfExp is not allowed'),
    ('x < v', 1, 'Compare is not allowed'),
    ('x // v', 1, 'the operator FloorDiv is not allowed'),
    ('x % v', 1, 'the operator Mod is not allowed'),
    ('~x', 1, 'the operator Invert is not allowed'),
    ('not x', 1, 'the operator Not is not allowed'),
    ('x and v', 1, 'BoolOp is not allowed'),
    ('"text"', 1, "'text' is not a real number"),
    ('True', 1, 'True is not a real number'),
    ('1j', 1, '1j is not a real number'),
    ('1e999', 1, 'inf is not a finite number'),
    ('sin(x, v)', 1, 'sin takes 1 argument, got 2'),
    ('atan2(x)', 1, 'atan2 takes 2 arguments, got 1'),
    ('max(x)', 1, 'max takes two or more arguments, got 1'),
    ('sin(x=1)', 1, 'sin takes plain arguments only'),
    ('sin(*x)', 1, 'sin takes plain arguments only'),
    ('x + cos', 5, 'the function cos is not called'),
    ('lambda: 1', 1, 'Lambda is not allowed'),
    ('[x, v]', 1, 'List is not allowed'),
    ('x.__class__.__bases__', 1, 'Attribute is not allowed'),
    ('__import__("os").system("true")', 1, "'this' is not a function"),
    ('(x := 1)', 2, 'NamedExpr is not allowed'),
])
def test_an_error_names_the_expression_the_column_and_what_is_allowed(text, column, what):
    with pytest.raises(ExpressionError) as caught:
        parse_expression(text, NAMES, 'dynamics.px')
    error = caught.value
    assert error.parameter == 'dynamics.px'
    assert f'{text!r} at column {column}: {what}' in error.reason
    assert 'expected numbers, the names r, v, x, yaw, pi, e' in error.reason
    assert 'atan2(x, y)' in error.reason and 'min(x, y, ...)' in error.reason
    assert isinstance(error, ConfigError) and isinstance(error, ValueError)


@pytest.mark.parametrize('text, what', [
    ('', 'the expression is empty'),
    ('   ', 'the expression is empty'),
    ('1 +', 'not an expression'),
    ('x = 1', 'not an expression'),
    ('x\0', 'not an expression'),
    ('x\nimport os', 'not an expression'),
    ('x' * (expressions.MAX_LENGTH + 1), 'longer than'),
    ('-' * 500 + 'x', 'nested deeper than'),
    ('(' * 150 + 'x' + ')' * 150, None),
    (3.0, 'expected a string, got float'),
    (None, 'expected a string, got NoneType'),
])
def test_text_that_is_not_one_expression_is_refused(text, what):
    if what is None:  # parentheses alone do not nest operations
        assert parse_expression(text, NAMES).names == {'x'}
        return
    with pytest.raises(ExpressionError, match=what):
        parse_expression(text, NAMES, 'outputs.cam_x')


@pytest.mark.parametrize('name, problem', [
    ('cos', 'is a function'), ('pi', 'is a constant'), ('e', 'is a constant'),
    ('lambda', 'is a Python keyword'), ('1x', 'is not a name'), ('_x', 'is not a name'),
    ('a b', 'is not a name'), (3, 'is not a name'),
])
def test_reserved_names_are_refused_with_the_reason(name, problem):
    assert problem in reserved_name_problem(name)


class NoEvaluation:
    """Make eval and exec raise, and compile refuse anything but a parse to a tree."""

    def __enter__(self):
        import ast
        self.saved = builtins.eval, builtins.exec, builtins.compile
        real_compile = builtins.compile

        def refuse(*args, **kwargs):
            raise AssertionError('user text was evaluated')

        def parse_only(source, filename, mode, flags=0, *args, **kwargs):
            if not flags & ast.PyCF_ONLY_AST:
                raise AssertionError('user text was compiled')
            return real_compile(source, filename, mode, flags, *args, **kwargs)

        builtins.eval = builtins.exec = refuse
        builtins.compile = parse_only
        return self

    def __exit__(self, *exc):
        builtins.eval, builtins.exec, builtins.compile = self.saved


ALPHABET = st.sampled_from(list('xyawvr0123456789.+-*/()[]{},:;=<>!%&|^~@\'" \n\t_\\') + [
    'sin', 'atan2', 'min', 'pi', 'e', 'lambda', 'import', '__import__', 'os', '**', '//',
    'if', 'else', 'for', 'in', 'not', 'and', 'yield', 'await', '1e999', 'j', '\0', '\u00e9'])


@settings(max_examples=400, deadline=None, derandomize=True)
@given(st.one_of(st.text(max_size=60), st.lists(ALPHABET, max_size=30).map(''.join)))
def test_random_text_raises_only_the_package_error_and_is_never_evaluated(text):
    import ast
    try:
        with NoEvaluation():
            expression = parse_expression(text, NAMES, 'dynamics.x')
    except ExpressionError as error:
        assert error.parameter == 'dynamics.x'
        return
    # what passed contains only whitelisted nodes
    allowed = (ast.Constant, ast.Name, ast.UnaryOp, ast.BinOp, ast.Call, ast.Load, ast.USub,
               ast.UAdd, ast.Add, ast.Sub, ast.Mult, ast.Div, ast.Pow)
    for node in ast.walk(expression.tree):
        assert isinstance(node, allowed), ast.dump(node)


def test_code_in_an_expression_never_runs(tmp_path):
    marker = tmp_path / 'ran'
    with NoEvaluation():
        for text in [f'__import__("pathlib").Path({str(marker)!r}).touch()',
                     f'open({str(marker)!r}, "w")', 'exec("1")', 'eval("1")',
                     '(lambda: 1)()', 'x.__class__']:
            with pytest.raises(ExpressionError):
                parse_expression(text, NAMES)
        assert parse_expression('v * cos(yaw)', NAMES).names == {'v', 'yaw'}
    assert not marker.exists()
