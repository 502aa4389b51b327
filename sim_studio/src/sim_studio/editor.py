"""The studio's scenario editor (issue 47, item 4): opening and saving scenario files from
the page, and merging the recording into an opened scenario without losing its comments or
its formatting. The page's side is static/ext/editor.js (CodeMirror 5, Debian's
libjs-codemirror, served at ``/codemirror/``).

- ``open_scenario`` {path}: the file's text as it is, with the validator's problems;
- ``save_scenario`` {path, yaml}: writes the text exactly as typed (also when it is not
  valid: the problems come back with the reply, the text is never lost), atomically (a
  temporary file in the same folder, then a rename), keeping a CRLF file's line ends and
  writing through a symbolic link to its target;
- ``merge_recording`` {yaml, offset}: the recording's actions and expectations appended
  to the scenario text given, through ruamel.yaml's round trip. Only the lines that change
  are taken from ruamel's output (``patch``): every other line, its comments, quotes and
  line breaks inside flow collections stay byte for byte as they were.

Bad input (a path that is not a file, a folder that does not exist, text that is not
UTF-8, a file over the protocol's size) is one error to the sender naming the path and
what was wrong."""
import difflib
import io
import os
import re
import tempfile

from aiohttp import web

from . import protocol
from .recorder import check

__all__ = ['OPS', 'handle', 'routes', 'open_file', 'save_file', 'merge', 'patch',
           'problem_lines', 'CODEMIRROR', 'SUFFIXES']

CODEMIRROR = os.environ.get('MDS_CODEMIRROR_DIR', '/usr/share/javascript/codemirror')
SUFFIXES = ('.yaml', '.yml')
_LINE = re.compile(r'^.*?:(\d+): ')

OPS = {
    'open_scenario': dict(
        required={'path': 'str'}, changes_world=False, needs_control=False,
        doc="read a scenario file: its text as it is (`yaml`), the absolute `path`, the "
            "validator's `problems`"),
    'save_scenario': dict(
        required={'path': 'str', 'yaml': 'str'}, changes_world=False, needs_control=False,
        doc='write the text to a .yaml/.yml file exactly as given (also when invalid: the '
            "validator's `problems` come back), atomically; `path`, `bytes`, `problems`"),
    'merge_recording': dict(
        required={'yaml': 'str'}, optional={'offset': 0.0}, kinds={'offset': 'num>=0'},
        changes_world=False, needs_control=False,
        doc="append the recording's actions (at their times + offset s) and expectations "
            'to the scenario text given, keeping its comments and formatting (ruamel.yaml); '
            '`yaml`, `added`, `expects`, `problems`'),
}


class EditorError(ValueError):
    """A file that cannot be opened or saved, text that cannot be merged: the message
    says which and why."""


def problem_lines(problems):
    """{line (1-based): [problem text]} of the validator's ``FILE:LINE: ...`` problems."""
    out = {}
    for p in problems:
        m = _LINE.match(p)
        out.setdefault(int(m.group(1)) if m else 1, []).append(p)
    return out


def _path(path):
    return os.path.abspath(os.path.expanduser(path))


def open_file(path, limit=protocol.MAX_BYTES):
    """{path, yaml, problems} of the scenario file at ``path``; EditorError when it is not
    a readable UTF-8 text file of at most ``limit`` bytes."""
    p = _path(path)
    if not os.path.exists(p):
        raise EditorError('open_scenario: no such file: %s' % p)
    if not os.path.isfile(p):
        raise EditorError('open_scenario: not a file: %s' % p)
    size = os.path.getsize(p)
    if size > limit:
        raise EditorError('open_scenario: %s has %d bytes, more than the %d the studio '
                          'edits' % (p, size, limit))
    try:
        with open(p, 'rb') as f:
            raw = f.read()
    except OSError as e:
        raise EditorError('open_scenario: cannot read %s: %s' % (p, e.strerror or e))
    try:
        text = raw.decode('utf-8')
    except UnicodeDecodeError as e:
        raise EditorError('open_scenario: %s is not UTF-8 text (byte %d)' % (p, e.start))
    crlf = '\r\n' in text
    text = text.replace('\r\n', '\n')       # the page's editor has \n line ends
    return {'path': p, 'yaml': text, 'crlf': crlf,
            'problems': check(text, os.path.basename(p))}


def save_file(path, text):
    """Write ``text`` to ``path`` as given (valid or not), atomically: {path, bytes,
    problems}. A file that had CRLF line ends keeps them; a symbolic link keeps pointing
    to the file written; the file's permissions stay."""
    p = _path(path)
    if not p.endswith(SUFFIXES):
        raise EditorError('save_scenario: %s: a scenario file ends in .yaml or .yml' % p)
    target = os.path.realpath(p)            # a link: write its target, keep the link
    folder = os.path.dirname(target)
    if os.path.isdir(target):
        raise EditorError('save_scenario: %s is a folder' % p)
    if not os.path.isdir(folder):
        raise EditorError('save_scenario: no such folder: %s' % folder)
    mode = None
    data = text
    if os.path.isfile(target):
        mode = os.stat(target).st_mode & 0o7777
        with open(target, 'rb') as f:
            if b'\r\n' in f.read(protocol.MAX_BYTES * 4) and '\r\n' not in text:
                data = text.replace('\n', '\r\n')
    raw = data.encode('utf-8')
    try:
        fd, tmp = tempfile.mkstemp(prefix='.%s.' % os.path.basename(target), suffix='.tmp',
                                   dir=folder)
    except OSError as e:
        raise EditorError('save_scenario: cannot write in %s: %s' % (folder,
                                                                   e.strerror or e))
    try:
        with os.fdopen(fd, 'wb') as f:
            f.write(raw)
            f.flush()
            os.fsync(f.fileno())
        if mode is None:
            umask = os.umask(0)
            os.umask(umask)
            mode = 0o666 & ~umask
        os.chmod(tmp, mode)
        os.replace(tmp, target)
    except OSError as e:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise EditorError('save_scenario: cannot write %s: %s' % (p, e.strerror or e))
    return {'path': p, 'bytes': len(raw), 'problems': check(text, os.path.basename(p))}


# -- ruamel.yaml's round trip, applied as a patch ------------------------------------------
def _yaml(text):
    from ruamel.yaml import YAML
    from ruamel.yaml.util import load_yaml_guess_indent
    try:
        _data, indent, offset = load_yaml_guess_indent(text)
    except Exception:  # noqa: BLE001 - the load below says what is wrong
        indent, offset = 2, 0
    y = YAML()                          # round trip: comments, quotes, flow styles kept
    y.preserve_quotes = True
    y.width = 1 << 16                   # never wrap (patch keeps the file's own breaks)
    if not re.search(r'^ *- ', text, re.M):
        indent, offset = 4, 2           # no block list yet: the examples' "  - " style
    indent = indent or 2
    y.indent(mapping=2, sequence=indent, offset=min(offset or 0, indent - 2))
    return y


def _dump(y, data):
    s = io.StringIO()
    y.dump(data, s)
    return s.getvalue()


def patch(orig, r0, r1):
    """``orig`` changed as ruamel's dump ``r0`` (of orig unchanged) became ``r1`` (after the
    change): the lines that ruamel re-flowed but the change did not touch stay as in
    ``orig``; only the changed lines come from ``r1``."""
    o, a, b = orig.splitlines(True), r0.splitlines(True), r1.splitlines(True)
    if o and not o[-1].endswith('\n'):
        o[-1] += '\n'
    changed = [False] * len(a)          # r0 lines the change replaced or deleted
    repl = {}                           # r0 line -> r1 lines put in its place
    before = {}                         # r0 position -> r1 lines inserted there
    same = {}                           # r0 line -> r1 line (equal)
    for tag, j1, j2, k1, k2 in difflib.SequenceMatcher(None, a, b, autojunk=False) \
            .get_opcodes():
        if tag == 'equal':
            for d in range(j2 - j1):
                same[j1 + d] = k1 + d
        elif tag == 'insert':
            before.setdefault(_above_comments(a, j1, b[k1]), []).extend(b[k1:k2])
        else:
            for j in range(j1, j2):
                changed[j] = True
            repl[j1] = b[k1:k2]
    out = []

    def from_r1(j):
        out.extend(before.get(j, []))
        if changed[j]:
            out.extend(repl.get(j, []))
        else:
            out.append(b[same[j]])

    for tag, i1, i2, j1, j2 in difflib.SequenceMatcher(None, o, a, autojunk=False) \
            .get_opcodes():
        if tag == 'equal':
            for d in range(j2 - j1):
                j = j1 + d
                if changed[j] or j in before:
                    from_r1(j)
                else:
                    out.append(o[i1 + d])
            continue
        # lines ruamel wrote differently (a flow collection re-flowed): kept as they were
        # unless the change touched them
        touched = any(changed[j] for j in range(j1, j2)) or \
            any(j in before for j in range(j1 + 1, j2))
        if not touched:
            if j1 < j2:
                out.extend(before.get(j1, []))
            out.extend(o[i1:i2])
        else:
            for j in range(j1, j2):
                from_r1(j)
    out.extend(before.get(len(a), []))
    return ''.join(out)


def _indent(line):
    return len(line) - len(line.lstrip(' '))


def _above_comments(lines, j, first):
    """Where lines starting with ``first`` go in before ``lines[j]``: above the blank lines
    and the comments no more indented than they are, which ruamel keeps after the last
    item of a list but which stand before what follows it."""
    n = _indent(first)
    while j > 0:
        prev = lines[j - 1]
        s = prev.strip()
        if s and not (s.startswith('#') and _indent(prev) <= n):
            break
        j -= 1
    return j


def _new_id(base, used):
    i = 1
    while '%s%d' % (base, i) in used:
        i += 1
    used.add('%s%d' % (base, i))
    return '%s%d' % (base, i)


def _load(text):
    """(ruamel instance, the round-trip data of ``text``, ruamel's dump of it unchanged)."""
    y = _yaml(text)
    try:
        data = y.load(text)
        r0 = _dump(y, data)
    except Exception as e:  # noqa: BLE001 - ruamel's errors: YAMLError and others
        raise EditorError('merge_recording: the scenario is not valid YAML, fix it first: %s'
                          % ' '.join(str(e).split()))
    if not isinstance(data, dict) or not hasattr(data, 'ca'):
        raise EditorError('merge_recording: the scenario is not a mapping of duration, '
                          'timeline, expect...')
    return y, data, r0


def _change(text, fn):
    """``text`` changed by ``fn(data)`` on its round-trip data, as a patch (one change at a
    time, so that each one's lines are found on their own)."""
    y, data, r0 = _load(text)
    fn(data)
    return patch(text, r0, _dump(y, data))


def merge(text, recorder, offset=0.0):
    """Scenario ``text`` with ``recorder``'s actions (at their times + ``offset`` s) and
    expectations appended; the duration grows to cover them. Returns (new text, number of
    actions, number of expectations). EditorError when the text is no scenario mapping."""
    if not recorder.actions and not recorder.expects:
        raise EditorError('merge_recording: nothing recorded to merge (record, or add an '
                          'expectation in assert mode, first)')
    y, data, _r0 = _load(text)
    for key in ('timeline', 'expect'):
        if data.get(key) is not None and not isinstance(data[key], list):
            raise EditorError('merge_recording: %s of the scenario is not a list' % key)
    rec = y.load(recorder.yaml())
    actions, expects = list(rec['timeline'] or []), list(rec['expect'] or [])
    ends = [float(e['at']) + offset for e in actions] + \
        [float(e['window'][1]) - recorder_margin() for e in expects if 'window' in e]
    need = round(max(ends or [0.0]) + recorder_margin(), 3)

    def add_actions(data):
        seq = _seq(data, 'timeline')
        used = {str(e.get('id')) for e in seq if isinstance(e, dict)}
        for e in actions:
            if e['id'] in used:
                e['id'] = _new_id('a', used)
            used.add(e['id'])
            if offset:
                e['at'] = round(float(e['at']) + offset, 3)
            seq.append(e)

    def add_expects(data):
        seq = _seq(data, 'expect')
        used = {str(e.get('name')) for e in seq if isinstance(e, dict)}
        for e in expects:
            name, i = e['name'], 1
            while e['name'] in used:
                i += 1
                e['name'] = '%s_%d' % (name, i)
            used.add(e['name'])
            seq.append(e)

    def set_duration(data):
        dur = data.get('duration')
        if not isinstance(dur, (int, float)) or isinstance(dur, bool) or dur < need:
            data['duration'] = need

    if actions:
        text = _change(text, add_actions)
    if expects:
        text = _change(text, add_expects)
    text = _change(text, set_duration)
    return text, len(actions), len(expects)


def recorder_margin():
    from .recorder import MARGIN
    return MARGIN


def _seq(data, key):
    """The list under ``key`` (made when missing or null; an empty flow list ``[]``
    becomes a block list)."""
    from ruamel.yaml.comments import CommentedSeq
    seq = data.get(key)
    if seq is None:
        seq = CommentedSeq()
        if key in data:
            data[key] = seq
        elif key == 'timeline' and 'expect' in data:    # before the expectations
            data.insert(list(data).index('expect'), key, seq)
        else:
            data[key] = seq
    if not len(seq):
        seq.fa.set_block_style()
    return seq


# -- the studio's side -------------------------------------------------------------------------
async def handle(studio, cmd, client):
    import asyncio
    loop = asyncio.get_event_loop()
    f = cmd.fields
    if cmd.op == 'open_scenario':
        out = await loop.run_in_executor(None, open_file, f['path'])
        studio.log('studio: opened %s' % out['path'])
        return out
    if cmd.op == 'save_scenario':
        out = await loop.run_in_executor(None, save_file, f['path'], f['yaml'])
        n = len(out['problems'])
        studio.log('studio: saved %s (%d bytes%s)' % (
            out['path'], out['bytes'], ', %d problem%s' % (n, 's' * (n > 1)) if n else ''))
        return out
    if cmd.op == 'merge_recording':
        text, added, expects = merge(f['yaml'], studio.recorder, f['offset'])
        return {'yaml': text, 'added': added, 'expects': expects, 'problems': check(text)}
    raise ValueError('editor: no op %s' % cmd.op)


def routes(app, studio):
    """CodeMirror's files at /codemirror/ (Debian's libjs-codemirror), as three.js's at
    /three/."""
    if os.path.isdir(CODEMIRROR):
        app.router.add_static('/codemirror/', CODEMIRROR)
    else:
        async def missing(_request):
            raise web.HTTPNotFound(text='the studio has no CodeMirror: install Debian\'s '
                                   'libjs-codemirror (tools/setup)')
        app.router.add_get('/codemirror/{tail:.*}', missing)
