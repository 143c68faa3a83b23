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
SciPy's ``place_poles`` and ``linear_sum_assignment``, without their packages' imports.

``from scipy.signal import place_poles`` runs ``scipy/signal/__init__.py``, which imports
``scipy.stats``, the window functions and the peak finding and parses about 800 docstrings:
0.6 s of a 1.0 s ``design_observer`` run on a quiet machine, paid by every node and tool
that places poles. ``place_poles`` itself needs numpy, ``scipy.linalg`` and ``warnings``.
``from scipy.optimize import linear_sum_assignment`` (the check of the poles achieved) runs
``scipy/optimize/__init__.py``: another 0.2 s, for one compiled function.

:func:`place_poles` is SciPy's own function, from the installed SciPy's source file
(``scipy/signal/_ltisys.py``): the definitions it uses (``place_poles``, ``_YT_loop``, ...) are
taken from that file's syntax tree and compiled with those three modules as their globals,
so the operations, and the bits, are SciPy's (``test_scipy_parts.py`` checks the gains
against ``scipy.signal.place_poles`` bit for bit). Where that file cannot be read or a name
it needs is not one of those (another SciPy), it is ``scipy.signal.place_poles``, imported.

:func:`linear_sum_assignment` is the function of SciPy's compiled module
``scipy.optimize._lsap``, loaded from its file; ``scipy.optimize`` exports that same object
(the module initialises once), so ``scipy.optimize.linear_sum_assignment`` is it.
"""

import ast
import builtins
from pathlib import Path
import sys
from typing import Callable, Optional
import warnings

import numpy as np

#: The definitions of ``scipy/signal/_ltisys.py`` that ``place_poles`` uses.
DEFINITIONS = ('Bunch', '_valid_inputs', '_order_complex_poles', '_KNV0', '_YT_real',
               '_YT_complex', '_YT_loop', '_KNV0_loop', 'place_poles')

_LOADED: dict = {}


def _globals() -> dict:
    """Return the module globals the definitions may name (``_ltisys``'s own imports)."""
    import scipy.linalg
    return {'np': np, 's_qr': scipy.linalg.qr, 'linalg': scipy.linalg, 'warnings': warnings,
            '__name__': 'scipy.signal._ltisys'}


def _free_names(definitions: list) -> set:
    """Return the names the definitions read but neither bind nor find in builtins."""
    read, bound = set(), set()
    for definition in definitions:
        for node in ast.walk(definition):
            if isinstance(node, ast.Name):
                (read if isinstance(node.ctx, ast.Load) else bound).add(node.id)
            elif isinstance(node, ast.arg):
                bound.add(node.arg)
            elif isinstance(node, (ast.FunctionDef, ast.ClassDef)):
                bound.add(node.name)
            elif isinstance(node, ast.ExceptHandler) and node.name:
                bound.add(node.name)
    return read - bound - set(dir(builtins))


def from_source() -> Optional[Callable]:
    """Return ``place_poles`` compiled from the installed SciPy's source, or None."""
    import scipy
    path = Path(scipy.__file__).resolve().parent / 'signal' / '_ltisys.py'
    try:
        tree = ast.parse(path.read_text(encoding='utf-8'), filename=str(path))
    except (OSError, SyntaxError, UnicodeDecodeError):
        return None
    definitions = [node for node in tree.body
                   if isinstance(node, (ast.FunctionDef, ast.ClassDef))
                   and node.name in DEFINITIONS]
    namespace = _globals()
    if (sorted(node.name for node in definitions) != sorted(DEFINITIONS)
            or any(node.decorator_list for node in definitions)
            or not _free_names(definitions) <= set(namespace)):
        return None
    exec(compile(ast.Module(body=definitions, type_ignores=[]), str(path), 'exec'), namespace)
    return namespace['place_poles']


def place_poles() -> Callable:
    """
    Return SciPy's ``place_poles`` (loaded once, from source where it can be).

    Examples
    --------
    >>> import numpy as np
    >>> result = place_poles()(np.array([[0.0, 1.0], [0.0, 0.0]]), np.array([[0.0], [1.0]]),
    ...                        np.array([-1.0, -2.0]))
    >>> np.round(result.gain_matrix, 12).tolist()
    [[2.0, 3.0]]

    """
    if 'place_poles' not in _LOADED:
        loaded = from_source()
        if loaded is None:
            from scipy.signal import place_poles as loaded
        _LOADED['place_poles'] = loaded
    return _LOADED['place_poles']


def _lsap_from_file() -> Optional[Callable]:
    """Return ``linear_sum_assignment`` of ``scipy.optimize._lsap``, loaded from its file."""
    import importlib.machinery
    import importlib.util
    import scipy
    module = sys.modules.get('scipy.optimize._lsap')
    if module is None:
        folder = Path(scipy.__file__).resolve().parent / 'optimize'
        for suffix in importlib.machinery.EXTENSION_SUFFIXES:
            path = folder / f'_lsap{suffix}'
            if path.is_file():
                break
        else:
            return None
        try:
            spec = importlib.util.spec_from_file_location('scipy.optimize._lsap', path)
            module = importlib.util.module_from_spec(spec)
            spec.loader.exec_module(module)
        except (ImportError, OSError):
            return None
    function = getattr(module, 'linear_sum_assignment', None)
    return function if callable(function) else None


def linear_sum_assignment() -> Callable:
    """
    Return SciPy's ``linear_sum_assignment`` (loaded once, without ``scipy.optimize``).

    Examples
    --------
    >>> rows, columns = linear_sum_assignment()([[4.0, 1.0], [2.0, 8.0]])
    >>> rows.tolist(), columns.tolist()
    ([0, 1], [1, 0])

    """
    if 'linear_sum_assignment' not in _LOADED:
        loaded = _lsap_from_file()
        if loaded is None:
            from scipy.optimize import linear_sum_assignment as loaded
        _LOADED['linear_sum_assignment'] = loaded
    return _LOADED['linear_sum_assignment']
