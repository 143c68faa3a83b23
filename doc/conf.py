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
Sphinx configuration of the observer_ros documentation (``doc/``, the layout rosdoc2 builds).

Markdown pages (MyST), the furo theme, the library reference generated from the docstrings
(autodoc, numpydoc sections through napoleon) and the parameter reference generated from the
parameter schema at every build (``_ext/observer_ros_docs.py``). Build it with
``./scripts/docs.sh`` (HTML in ``doc/_build/html``); the test suite builds it with warnings
as errors.
"""

from pathlib import Path
import sys

DOC = Path(__file__).resolve().parent
# The checkout's package first (a build from a source tree documents that tree), then the
# documentation's own extension.
sys.path[:0] = [str(DOC.parent), str(DOC / '_ext')]

project = 'observer_ros'
author = 'observer_ros contributors'
copyright = '2026, observer_ros contributors'  # noqa: A001 (Sphinx's name)
release = version = '0.1.0'

extensions = [
    'myst_parser',
    'sphinx.ext.autodoc',
    'sphinx.ext.autosummary',
    'sphinx.ext.napoleon',
    'observer_ros_docs',
]

source_suffix = {'.rst': 'restructuredtext', '.md': 'markdown'}
root_doc = 'index'
exclude_patterns = ['_build', '_generated']
templates_path = ['_templates']
# Text as written: "..." stays three dots and quotes stay straight (parameter values).
smartquotes = False

# MyST: heading anchors for links to sections of other pages (page.md#section).
myst_heading_anchors = 3
myst_enable_extensions = ['colon_fence', 'deflist']

# Every cross-reference of a hand-written page must resolve (nitpicky); the docstrings'
# numpydoc type words ("array_like, shape (n, p)") are exempt (observer_ros_docs).
nitpicky = True
# Short attribute names in docstrings (n_states, estimate) name several attributes of the
# library; Sphinx links the first, which is all a reader needs.
suppress_warnings = ['ref.python']

# The docstrings are numpydoc (Parameters / Returns / Raises sections).
napoleon_google_docstring = False
napoleon_numpy_docstring = True
napoleon_custom_sections = ['Contents']
# Attributes sections as fields, so that documented attributes are not described twice.
napoleon_use_ivar = True
autodoc_member_order = 'bysource'
autodoc_typehints = 'description'
autosummary_generate = True

try:
    import furo  # noqa: F401 (the theme of requirements.txt; rosdoc2 brings its own)
    html_theme = 'furo'
except ImportError:
    html_theme = 'alabaster'
html_title = 'observer_ros'
html_static_path = []
