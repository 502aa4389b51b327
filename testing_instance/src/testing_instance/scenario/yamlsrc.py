"""A scenario file's YAML with line numbers, and the problem type every check raises.

The bottom of the scenario stack: ``parse``/``read`` give mappings (LDict) and lists (LList)
that remember the line of each key and item, so every later check (parameters and sweeps in
``params``, the schema in ``scenario``) reports ``FILE:LINE: where: what``
(ScenarioError, never a traceback).
"""
import difflib

import yaml

__all__ = ['ScenarioError', 'LDict', 'LList', 'Loader', 'parse', 'read', 'line_of',
           'close_match', 'show']


class ScenarioError(Exception):
    """One or more problems in a scenario file; str() gives one line per problem."""

    def __init__(self, problems):
        self.problems = list(problems)
        Exception.__init__(self, '\n'.join(self.problems))


class LDict(dict):
    line = 0
    key_lines = None


class LList(list):
    line = 0
    item_lines = None


class Loader(yaml.SafeLoader):
    pass


def _construct_mapping(loader, node):
    loader.flatten_mapping(node)
    d = LDict()
    d.line = node.start_mark.line + 1
    d.key_lines = {}
    for knode, vnode in node.value:
        k = loader.construct_object(knode, deep=True)
        if not isinstance(k, (str, int, float, bool)) or k is None:
            raise yaml.constructor.ConstructorError(
                None, None, 'a mapping key must be a plain word', knode.start_mark)
        if k in d:
            raise yaml.constructor.ConstructorError(
                None, None, 'key %r appears twice' % (k,), knode.start_mark)
        d[k] = loader.construct_object(vnode, deep=True)
        d.key_lines[k] = vnode.start_mark.line + 1
    return d


def _construct_sequence(loader, node):
    lst = LList(loader.construct_object(c, deep=True) for c in node.value)
    lst.line = node.start_mark.line + 1
    lst.item_lines = [c.start_mark.line + 1 for c in node.value]
    return lst


Loader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _construct_mapping)
Loader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_SEQUENCE_TAG, _construct_sequence)



def parse(text, path='<scenario>'):
    """The YAML text with line numbers; ScenarioError ``FILE:LINE: not valid YAML``."""
    try:
        return yaml.load(text, Loader=Loader)
    except yaml.YAMLError as e:
        mark = getattr(e, 'problem_mark', None)
        line = mark.line + 1 if mark is not None else 0
        what = getattr(e, 'problem', None) or str(e)
        raise ScenarioError(['%s:%d: not valid YAML: %s' % (path, line, what)])


def read(path):
    """parse() of a file; ScenarioError when it cannot be read."""
    try:
        with open(path) as f:
            text = f.read()
    except OSError as e:
        raise ScenarioError(['%s: cannot read the scenario file: %s' % (path, e.strerror)])
    return parse(text, path)


def line_of(obj, key=None, default=0):
    if key is not None and isinstance(obj, LDict) and obj.key_lines and key in obj.key_lines:
        return obj.key_lines[key]
    if isinstance(obj, LList) and isinstance(key, int) and obj.item_lines \
            and key < len(obj.item_lines):
        return obj.item_lines[key]
    return getattr(obj, 'line', default) or default


def close_match(word, choices):
    m = difflib.get_close_matches(str(word), list(choices), n=1)
    return ' (did you mean %r?)' % m[0] if m else ''


def show(v):
    s = repr(v)
    return s if len(s) <= 60 else s[:57] + '...'
