"""The transport fence (issue 45): only sim_world/src/sim_world/transport/ knows rospy's
internals. Every other module of the stacks (their libraries and their nodes) must not

- import ``rospy.impl`` (in any spelling, importlib's included),
- touch a private attribute of rospy: a name rospy itself defines with a leading underscore
  (read from the installed rospy's source), as an attribute, in getattr/hasattr/setattr, or
  imported; or an underscored name reached from the rospy module (``rospy.names._x``),
- reach into the transport past its facade: a submodule of sim_world.transport, or a name
  of it that is not in ``sim_world.transport.__all__``.

A few underscored names rospy defines are also ordinary names of the project's own objects
(``_lock``, ``_error``, ``_thread`` ...: GENERIC) and genpy's message API (``_type``,
``_md5sum``, ``_full_text``, ``_has_header``) is public: those are allowed. Like
test_world_seam.py: one rule, one test that fails when it is broken."""
import ast
import glob
import os
import re

import pytest

pytest.importorskip('rospy')

from sim_world import transport  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
STACKS = ['sim_world', 'simvid', 'textvid', 'simsensors', 'testing_instance', 'sim_studio',
          'emulator_bridge', 'kinect4skype', 'vnc_image_client']
TRANSPORT = os.path.join(ROOT, 'sim_world', 'src', 'sim_world', 'transport')
#: underscored names rospy defines that the project's own classes also use for their own
#: attributes (a lock, a thread, a run method): not rospy's when the project says them
GENERIC = {'_', '_ROSOUT', '_add', '_error', '_lock', '_remove', '_run', '_shutdown',
           '_thread'}
#: genpy's message and service API (documented, and what rosbag and every tool read)
GENPY = {'_type', '_md5sum', '_full_text', '_has_header', '_slot_types',
         '_request_class', '_response_class'}
SUBMODULES = {'connections', 'gate', 'local', 'tcpros_guard', 'version'}


def rospy_private_names():
    """Every underscored name rospy's source defines (classes, functions, attributes and
    module globals it assigns), but for GENERIC and GENPY."""
    import rospy
    names = set()
    for path in glob.glob(os.path.join(os.path.dirname(rospy.__file__), '**', '*.py'),
                          recursive=True):
        with open(path) as f:
            tree = ast.parse(f.read())
        for n in ast.walk(tree):
            if isinstance(n, (ast.FunctionDef, ast.ClassDef)):
                names.add(n.name)
            elif isinstance(n, ast.Attribute) and isinstance(n.ctx, ast.Store):
                names.add(n.attr)
            elif isinstance(n, ast.Name) and isinstance(n.ctx, ast.Store):
                names.add(n.id)
    return {n for n in names if n.startswith('_') and not n.startswith('__')} \
        - GENERIC - GENPY


PRIVATE = rospy_private_names()


def _is_rospy(mod):
    return mod == 'rospy' or mod.startswith('rospy.')


def violations(source, private=PRIVATE, public=frozenset(transport.__all__)):
    """[(line, what)] of one module's source breaking the fence."""
    tree = ast.parse(source)
    out = []
    rospy_names = set()          # local names bound to rospy or one of its modules
    transport_names = set()      # local names bound to sim_world.transport
    for n in ast.walk(tree):
        if isinstance(n, ast.Import):
            for a in n.names:
                if a.name.startswith('rospy.impl'):
                    out.append((n.lineno, 'imports %s' % a.name))
                if _is_rospy(a.name):
                    rospy_names.add(a.asname or a.name.split('.')[0])
                if a.name.startswith('sim_world.transport.'):
                    out.append((n.lineno, 'imports %s past the facade' % a.name))
                elif a.name == 'sim_world.transport' and a.asname:
                    transport_names.add(a.asname)
        elif isinstance(n, ast.ImportFrom):
            mod = n.module or ''
            names = [a.name for a in n.names]
            if mod.startswith('rospy.impl') or (mod == 'rospy' and 'impl' in names):
                out.append((n.lineno, 'imports from %s' % (mod + ('.impl' if mod == 'rospy'
                                                                   else ''))))
            if _is_rospy(mod):
                for a in n.names:
                    if a.name.startswith('_') and not a.name.startswith('__'):
                        out.append((n.lineno, 'imports rospy\'s private %s' % a.name))
                    else:
                        rospy_names.add(a.asname or a.name)
            if mod.startswith('sim_world.transport.'):
                out.append((n.lineno, 'imports from %s past the facade' % mod))
            elif mod == 'sim_world.transport':
                for a in n.names:
                    if a.name in SUBMODULES or a.name not in public:
                        out.append((n.lineno, 'imports sim_world.transport.%s, not one of '
                                              'the facade\'s names' % a.name))
            elif mod == 'sim_world':
                for a in n.names:
                    if a.name == 'transport':
                        transport_names.add(a.asname or a.name)
    for n in ast.walk(tree):
        if isinstance(n, ast.Attribute):
            if n.attr in private:
                out.append((n.lineno, 'touches rospy\'s private .%s' % n.attr))
            root = n
            while isinstance(root, ast.Attribute):
                root = root.value
            if isinstance(root, ast.Name) and root.id in rospy_names and \
                    n.attr.startswith('_') and not n.attr.startswith('__') and \
                    n.attr not in private:
                out.append((n.lineno, 'touches rospy\'s private .%s' % n.attr))
            if isinstance(n.value, ast.Name) and n.value.id in transport_names and \
                    n.attr not in public:
                out.append((n.lineno, 'uses sim_world.transport.%s, not one of the '
                                      'facade\'s names' % n.attr))
        elif isinstance(n, ast.Call) and isinstance(n.func, (ast.Name, ast.Attribute)):
            fname = n.func.id if isinstance(n.func, ast.Name) else n.func.attr
            args = [a.value for a in n.args if isinstance(a, ast.Constant)
                    and isinstance(a.value, str)]
            if fname in ('getattr', 'hasattr', 'setattr', 'delattr'):
                out += [(n.lineno, 'touches rospy\'s private %s' % a) for a in args
                        if a in private]
            if fname in ('import_module', '__import__'):
                out += [(n.lineno, 'imports %s' % a) for a in args
                        if a.startswith('rospy.impl') or a.startswith('sim_world.transport.')]
    return out


def _python_files():
    for stack in STACKS:
        for d, dirs, files in os.walk(os.path.join(ROOT, stack)):
            if os.path.abspath(d).startswith(TRANSPORT):
                continue
            dirs[:] = [x for x in dirs if x not in ('__pycache__', 'node_modules')]
            for f in files:
                path = os.path.join(d, f)
                if f.endswith('.py'):
                    yield path
                elif os.path.basename(d) == 'nodes':
                    with open(path, 'rb') as fh:
                        first = fh.readline()
                    if first.startswith(b'#!') and b'python' in first:
                        yield path


FILES = sorted(os.path.relpath(p, ROOT) for p in _python_files())


def test_the_fence_scans_every_stack_and_the_nodes():
    assert len(FILES) > 100
    for stack in STACKS:
        assert any(p.startswith(stack + '/') for p in FILES), stack
    assert 'sim_world/nodes/sim_world' in FILES
    assert 'testing_instance/nodes/run_scenario' in FILES
    assert not any(p.startswith('sim_world/src/sim_world/transport/') for p in FILES)


@pytest.mark.parametrize('path', FILES)
def test_only_the_transport_knows_rospys_internals(path):
    with open(os.path.join(ROOT, path)) as f:
        source = f.read()
    assert violations(source) == [], '%s reaches rospy\'s internals outside ' \
        'sim_world/src/sim_world/transport/ (use the facade, sim_world.transport)' % path


def test_the_list_of_rospys_private_names_is_read_from_rospy():
    for name in ('_connection_header', '_SubscriberImpl', '_PublisherImpl', '_queue',
                 '_cond_data_available', '_set_caller_id', '_invoke_callback',
                 '_handle_request', '_tcp_server_callback', '_tcpros_server'):
        assert name in PRIVATE, name
    assert not (PRIVATE & (GENERIC | GENPY))


def test_the_fence_can_fail():
    bad = '\n'.join([
        'import rospy.impl.tcpros_pubsub',                                   # 1
        'from rospy.impl.registration import get_topic_manager',            # 2
        'from rospy import impl',                                            # 3
        'from rospy.topics import _SubscriberImpl',                          # 4
        'import rospy.names',                                                # 5
        'rospy.names._set_caller_id("/ns/x")',                               # 6
        'h = getattr(msg, "_connection_header", None)',                     # 7
        'c._cond_data_available.notify()',                                   # 8
        'importlib.import_module("rospy.impl.tcpros_base")',                 # 9
        'from sim_world.transport import connections',                       # 10
        'from sim_world.transport.gate import close',                        # 11
        'from sim_world import transport',                                   # 12
        'transport._connections.add(c)',                                     # 13
        'rospy._private_thing',                                              # 14
    ])
    lines = sorted({line for line, _what in violations(bad)})
    assert lines == [1, 2, 3, 4, 6, 7, 8, 9, 10, 11, 13, 14]
    good = '\n'.join([
        'import rospy',
        'from sim_world import transport',
        'pub = transport.publisher("/x", T, queue_size=1)',
        'transport.close_gate(); transport.reopen_gate(); transport.settle()',
        'h = transport.connection_header(msg)',
        'self._lock = threading.Lock(); self._error = None',             # generic names
        'print(msg._type, msg._md5sum, cls._full_text)',                 # genpy's API
        'rospy.get_param("~x"); rospy.core.is_initialized()',
    ])
    assert violations(good) == []


def test_every_facade_name_is_there_and_documented():
    doc = transport.__doc__
    for name in transport.__all__:
        assert hasattr(transport, name), name
        assert re.search(r'``%s\b' % re.escape(name), doc), \
            '%s is not in the facade\'s docstring' % name
