# Copyright 2026 formation_control developers
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

"""Sphinx configuration of the formation_control docs site (make docs)."""

from pathlib import Path
import sys
import types

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

project = 'formation_control'
author = 'formation_control developers'
copyright = '2026, formation_control developers'  # noqa: A001 (the name Sphinx reads)

extensions = [
    'myst_parser',
    'numpydoc',
    'sphinx.ext.autodoc',
    'sphinx.ext.autosummary',
]
source_suffix = {'.md': 'markdown', '.rst': 'restructuredtext'}
exclude_patterns = ['_build']
root_doc = 'index'

myst_enable_extensions = ['dollarmath']
myst_heading_anchors = 3

autosummary_generate = True
autodoc_default_options = {'members': True, 'undoc-members': True, 'member-order': 'bysource'}
autodoc_typehints = 'none'
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False
numpydoc_validation_checks = set()

html_theme = 'alabaster'
html_static_path = []


def resolve_within_package(app, env, node, contnode):
    """
    Resolve a module-relative Python reference (``scenario.initial_state``) in the package.

    The docstrings name objects of a sibling module as ``module.name``, as the code reads
    them; Sphinx looks such a name up from the current module only. It is taken here when it
    is the tail of exactly one object of formation_control; any other stays unresolved, so
    nitpicky mode still fails on it.
    """
    if node.get('refdomain') != 'py':
        return None
    target = node['reftarget'].lstrip('.~')
    domain = env.get_domain('py')
    types = set(domain.objtypes_for_role(node['reftype']) or ())
    found = {name for name, entry in domain.objects.items()
             if entry.objtype in types and name.startswith('formation_control.')
             and name.endswith('.' + target)}
    if len(found) != 1:
        return None
    node = node.deepcopy()
    node['reftarget'] = found.pop()
    return domain.resolve_xref(env, node['refdoc'], app.builder, node['reftype'],
                               node['reftarget'], node, contnode)


def skip_type_alias(app, what, name, obj, skip, options):
    """
    Leave the type aliases (``RealArray = NDArray[...]``, ``ViewRow = tuple[...]``) out.

    autosummary takes a generic alias for a class and fails to document it; the aliases are
    named in the signatures, which the source shows.
    """
    if isinstance(obj, (types.GenericAlias, types.UnionType)) or \
            type(obj).__module__ == 'typing':
        return True
    return None


def setup(app):
    """Register the package-wide reference resolver and the alias filter."""
    app.connect('missing-reference', resolve_within_package)
    app.connect('autodoc-skip-member', skip_type_alias)
