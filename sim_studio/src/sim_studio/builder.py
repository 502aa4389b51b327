"""Build the device (issue 47 part 7): a form of every plugin's declared parameters with the
phone's current values, and saving it as a URDF that ``office.launch phone_model:=PATH``
and ``spawn_model -urdf -file PATH`` load as the phone.

The form comes from the phone's description (``robot_description`` on the parameter
server, the text the world spawned it from) read with sim_world's URDF loader
(``parse_urdf``), and from each plugin's own parameter rows (``Plugin.param_rows()``, the
registry ``sim_world.plugins.lookup`` the world creates plugins with): one group per plugin,
one field per row, its value the text the description gives (``find_texts``, the order the
plugin reads them in) or the row's default.

Saving puts each changed value where the plugin reads it (the element that gives it now,
else a new child of the plugin element, which the plugin reads first), then checks the
result with the world's own code: ``parse_urdf`` (the loader), ``parse_params`` of each row
(the plugins' parameter check at load: one error per bad field, in the world's wording), and
a dry-run spawn of the model into a world without ROS (``sim_world.spawn.spawn_xml``: what
/gazebo/spawn_urdf_model does; a plugin that refuses to load is an error of its group). Any
error: nothing is written."""
import asyncio
import io
import os
import xml.etree.ElementTree as ET

__all__ = ['OPS', 'handle', 'form', 'apply_values', 'check', 'save', 'plugin_keys']

OPS = {
    'device_params': dict(
        optional={'param': '/robot_description', 'model': 'mobile_device'},
        kinds={'param': 'str'},
        doc="the phone's plugins and their declared parameters with the description's "
            'values (the device builder\'s form): groups [{key, plugin, filename, fields: '
            '[{key, name, value, given, default, unit, must, choices}]}]'),
    'save_device': dict(
        required={'path': 'str', 'values': 'object'},
        optional={'param': '/robot_description', 'model': 'mobile_device'},
        kinds={'param': 'str'}, changes_world=False, needs_control=True,
        doc='write the description with values {field key: text} changed as a URDF file '
            'path (.urdf); each bad value is an error of its field (errors {key: line}) and '
            'nothing is written'),
}


class BuildError(ValueError):
    """The form cannot be made or saved; ``fields`` {key: error line} names bad fields,
    ``problems`` the rest."""

    def __init__(self, text, fields=None, problems=None):
        ValueError.__init__(self, text)
        self.fields = dict(fields or {})
        self.problems = list(problems or [])


def _text(v):
    """A row's default as the text a description would give."""
    import numpy as np
    if v is None:
        return ''
    if isinstance(v, bool):
        return 'true' if v else 'false'
    if isinstance(v, (list, tuple, np.ndarray)):
        return ' '.join('%g' % x for x in np.asarray(v, float).ravel())
    if isinstance(v, float):
        return '%g' % v
    return str(v)


def plugin_keys(model):
    """[(key, PluginSpec)]: the plugin's name where it is unique and not empty, else
    ``filename#N`` (N: its place among the model's plugins)."""
    names = [s.name for s in model.plugins]
    return [(s.name if s.name and names.count(s.name) == 1 and '/' not in s.name
             else '%s#%d' % (s.filename, i), s) for i, s in enumerate(model.plugins)]


def _rows(spec):
    from sim_world import plugins
    cls = plugins.lookup(spec.filename)
    return cls, (cls.param_rows() if cls is not None else [])


def _label(spec, model):
    return 'plugin %s of model %s' % (spec.filename, model.name)


def form(text, name='mobile_device'):
    """The builder's form of a description: [{key, plugin, filename, class, doc, link,
    sensor, fields: [{key, name, value, given, default, unit, must, choices, aliases, also}]}]."""
    from sim_world.plugins.params import find_texts
    from sim_world.urdf import parse_urdf
    model = parse_urdf(text, name=name)
    groups = []
    for key, spec in plugin_keys(model):
        cls, rows = _rows(spec)
        fields = []
        for row in rows:
            texts = [t.strip() for t in find_texts(spec, row)]
            fields.append({
                'key': '%s/%s' % (key, row.name), 'name': row.name,
                'value': texts[0] if texts else _text(row.default), 'given': bool(texts),
                'default': _text(row.default), 'unit': row.unit, 'must': row.what(),
                'choices': list(row.type) if isinstance(row.type, tuple) else
                (['true', 'false'] if row.type is bool else None),
                'aliases': list(row.aliases), 'doc': row.doc, 'also': texts[1:]})
        doc = ((cls.__doc__ or '').strip().split('\n')[0]) if cls is not None else \
            'not implemented by the simulator: the model loads without it'
        groups.append({'key': key, 'plugin': spec.name, 'filename': spec.filename,
                       'class': cls.__name__ if cls is not None else None, 'doc': doc,
                       'link': spec.link, 'sensor': spec.sensor_type, 'fields': fields})
    return groups


# -- saving -----------------------------------------------------------------------------------
def _is_plugin(el):
    from sim_world.model import _local
    from sim_world.urdf import _is_ns
    return isinstance(el.tag, str) and (_local(el.tag) == 'plugin' or
                                        _is_ns(el.tag, 'controller'))


def _plugin_elements(root):
    """[(plugin element, sensor element or None)] of a URDF's root in parse_urdf's order
    (``<gazebo>`` by ``<gazebo>``; a sensor's plugins where the sensor is)."""
    from sim_world.model import _local
    from sim_world.urdf import _is_ns
    out = []
    for gel in root.findall('gazebo'):
        for child in gel:
            if not isinstance(child.tag, str):
                continue
            if _local(child.tag) == 'sensor' or _is_ns(child.tag, 'sensor'):
                out += [(c, child) for c in child.iter() if c is not child and _is_plugin(c)]
            elif _is_plugin(child):
                out.append((child, None))
    return out


def _holder(spec, row):
    """The element whose text ``find_text(spec, row)`` reads (the plugin element's children,
    the sensor's, then the row's SDF paths), or None."""
    from sim_world.plugins.params import find_elements
    found = find_elements(spec, row)
    return found[0] if found else None


def _namespaces(text):
    """{prefix: uri} declared in the text (kept on writing: controller:, sensor: ...)."""
    out = {}
    for _event, (prefix, uri) in ET.iterparse(io.BytesIO(text.encode('utf-8')),
                                               events=('start-ns',)):
        if prefix:
            out[prefix] = uri
    return out


def apply_values(text, values, name='mobile_device'):
    """The description's text with ``values`` ({field key: text}) put where each plugin reads
    them ('' takes a given value out: the default applies). Unknown keys: BuildError."""
    from sim_world.model import PluginSpec
    from sim_world.urdf import parse_urdf
    model = parse_urdf(text, name=name)
    for prefix, uri in _namespaces(text).items():
        ET.register_namespace(prefix, uri)
    root = ET.fromstring(text.encode('utf-8'))
    mine = _plugin_elements(root)
    if len(mine) != len(model.plugins) or any(
            ET.tostring(s.element) != ET.tostring(el) for s, (el, _sel) in
            zip(model.plugins, mine)):
        raise BuildError('the description\'s plugin elements do not match what the loader '
                         'read (%d against %d)' % (len(mine), len(model.plugins)))
    keys = dict((k, i) for i, (k, _s) in enumerate(plugin_keys(model)))
    bad = {}
    for key, value in sorted(values.items()):
        group, _sep, pname = key.rpartition('/')
        if group not in keys:
            bad[key] = '%s: no plugin %s in the description (plugins: %s)' % (
                key, group, ', '.join(keys))
            continue
        spec = model.plugins[keys[group]]
        _cls, rows = _rows(spec)
        row = next((r for r in rows if r.name == pname), None)
        if row is None:
            bad[key] = '%s: plugin %s declares no parameter %s' % (key, spec.filename, pname)
            continue
        if not isinstance(value, str):
            value = _text(value)
        el, sel = mine[keys[group]]
        mspec = PluginSpec(spec.filename, element=el, sensor=sel)
        holder = _holder(mspec, row)
        if not value.strip():
            if holder is not None:
                _remove(root, holder)
            continue
        if holder is None:
            holder = ET.SubElement(el, row.name)
            holder.tail = '\n'
        holder.text = value.strip()
    if bad:
        raise BuildError('%d unknown field(s): %s' % (len(bad), '; '.join(
            v for _k, v in sorted(bad.items()))), fields=bad)
    return ET.tostring(root, encoding='unicode')


def _remove(root, el):
    for parent in root.iter():
        if el in list(parent):
            parent.remove(el)
            return


class _Lines(object):
    """A logger for the dry-run world: keeps its error (and warning) lines."""

    def __init__(self):
        self.errors = []
        self.warnings = []

    def _fmt(self, msg, args):
        try:
            return (msg % args) if args else str(msg)
        except (TypeError, ValueError):
            return '%s %r' % (msg, args)

    def error(self, msg, *args, **_kw):
        self.errors.append(self._fmt(msg, args))

    exception = critical = error

    def warning(self, msg, *args, **_kw):
        self.warnings.append(self._fmt(msg, args))

    warn = warning

    def info(self, *_a, **_kw):
        pass

    debug = info

    def isEnabledFor(self, _level):
        return True


def check(text, name='mobile_device', changed=None):
    """The world's checks of a description: {field key: error line} of every bad parameter
    (``parse_params`` of its row: the plugins' own check at load) and [other problems] (the
    loader's ModelError, a plugin that refused to load in a dry-run spawn into a world
    without ROS). ``changed``: only these field keys are checked for bad values (default:
    every field)."""
    from sim_world.model import ModelError
    from sim_world.plugins.params import parse_params
    from sim_world.urdf import parse_urdf
    try:
        model = parse_urdf(text, name=name)
    except ModelError as e:
        return {}, [str(e)]
    fields = {}
    for key, spec in plugin_keys(model):
        _cls, rows = _rows(spec)
        for row in rows:
            fkey = '%s/%s' % (key, row.name)
            if changed is not None and fkey not in changed:
                continue
            _vals, errors = parse_params(spec, [row], _label(spec, model))
            if errors:
                fields[fkey] = errors[0]
    problems = [ln for ln in dry_run(text, name) if ln not in fields.values()]
    return fields, problems


def dry_run(text, name='mobile_device'):
    """The error lines of spawning the description into a world without ROS, as
    /gazebo/spawn_urdf_model does (``spawn_xml``); a refused spawn is one line."""
    from sim_world.spawn import spawn_xml
    from sim_world.world import World
    lines = _Lines()
    world = World(physics='ode', step_size=0.001, seed=0, logger=lines)
    try:
        ok, msg = spawn_xml(world, 'urdf', name, text, robot_namespace=name)
    finally:
        world.shutdown()
    return lines.errors + ([] if ok else [msg])


HEADER = ('<!-- written by the studio\'s device builder (sim_studio.builder) from %s with %d '
          'changed parameter(s); load it with: roslaunch mobile_device_sim office.launch '
          'phone_model:=%s -->\n')


def save(text, values, path, name='mobile_device', source='/robot_description'):
    """Check and write; returns {path, changed, problems: [warnings]} or raises BuildError
    (nothing written)."""
    path = os.path.abspath(os.path.expanduser(path))
    if not path.endswith('.urdf'):
        raise BuildError('save_device.path: expected a file name ending in .urdf, got %s'
                         % path)
    if not os.path.isdir(os.path.dirname(path)):
        raise BuildError('save_device.path: no folder %s' % os.path.dirname(path))
    new = apply_values(text, values, name)
    keys = set(values)
    fields, problems = check(new, name, changed=None)
    # bad values the description itself had (the world used their defaults) are named too
    if fields or problems:
        raise BuildError('%d bad value(s)%s, nothing written to %s: %s' % (
            len(fields), ' and %d problem(s)' % len(problems) if problems else '', path,
            '; '.join(['%s: %s' % kv for kv in sorted(fields.items())] + problems)),
            fields=fields, problems=problems)
    body = '<?xml version="1.0"?>\n' + HEADER % (source, len(keys), path) + new + '\n'
    tmp = path + '.tmp'
    with open(tmp, 'w') as f:
        f.write(body)
    os.replace(tmp, path)
    return {'path': path, 'changed': sorted(keys)}


# -- the studio's ops -------------------------------------------------------------------------
def description(studio, param):
    """The description text at ``param`` (the world link's parameter server)."""
    get = getattr(studio.world, 'get_param', None)
    if get is None:
        get = studio.world.rospy.get_param
    text = get(param, None)
    if not text or not isinstance(text, str):
        raise BuildError('no description at the parameter %s' % param)
    return text


async def handle(studio, cmd, client):
    loop = asyncio.get_event_loop()
    f = cmd.fields
    text = await loop.run_in_executor(None, description, studio, f['param'])
    if cmd.op == 'device_params':
        groups = await loop.run_in_executor(None, form, text, f['model'])
        return {'model': f['model'], 'param': f['param'], 'groups': groups}
    try:
        out = await loop.run_in_executor(None, save, text, f['values'], f['path'],
                                         f['model'], f['param'])
    except BuildError as e:
        # the error reply carries the fields' errors (server: an exception's ``reply``)
        e.reply = {'errors': e.fields, 'problems': e.problems}
        raise
    studio.log('studio: device written to %s (%d changed)' % (out['path'],
                                                              len(out['changed'])))
    return out
