"""The studio's extensions: the parts of the page beyond the core (server.py, studio.js)
each in a module of their own, registered here.

An extension is a module ``sim_studio.<name>`` (its name in ``NAMES``) with:

- ``OPS``: ``{op: dict(required={field: kind}, optional={field: default}, kinds={field:
  kind}, changes_world=bool, doc='one line', needs_control=None, takes_model=False,
  field_check=None)}``: its commands, added to the protocol (``protocol.register``), so
  they are checked, documented and refused like the core's;
- ``async def handle(studio, cmd, client)``: carries out one of its ops, returns the reply's
  fields (a dict) or raises an exception whose text is the error sent back;
- optionally ``routes(app, studio)``: extra HTTP routes (under ``/api/<name>/`` by
  convention), and ``attach(studio)``: called once when the server is made.

Its page script is ``static/ext/<name>.js`` (with ``static/ext/<name>.css`` if any):
``server.index_html`` adds every script and style sheet there to the page, sorted by name,
after studio.js, so an extension needs no edit of index.html. It uses ``window.studio``
(studio.js: ``send``, ``on``, ``onFrame``, ``scene3d``, ``panel``...)."""
import asyncio
import importlib

from . import protocol

__all__ = ['NAMES', 'load', 'handler', 'periodic']

#: the extension modules, in the order they are loaded
NAMES = ('moves', 'overlay', 'builder', 'study', 'editor', 'timetravel', 'barcode', 'spawned',
         'physics', 'images')

_HANDLERS = {}
_LOADED = {}                # name -> module


def load(names=None):
    """Import the extensions ``names`` (default: NAMES) that are not yet loaded and
    register their ops; their modules, in order."""
    names = NAMES if names is None else names
    for name in names:
        if name in _LOADED:
            continue
        mod = importlib.import_module('sim_studio.' + name)
        for op, spec in getattr(mod, 'OPS', {}).items():
            spec = dict(spec)
            protocol.register(op, spec.pop('required', {}), spec.pop('optional', {}),
                              spec.pop('changes_world', False), spec.pop('doc'), **spec)
            _HANDLERS[op] = mod.handle
        _LOADED[name] = mod
    return [_LOADED[n] for n in names]


def handler(op):
    """The coroutine function that carries out ``op``, if an extension has it."""
    return _HANDLERS.get(op)


def periodic(app, studio, name, period, tick):
    """An extension's task while the server runs: ``await tick()`` every ``period`` s of wall
    time (started with the app, cancelled at its shutdown). An exception of one tick is one
    log line ``studio: NAME: Type: message`` and the next tick comes as usual."""
    async def run():
        while True:
            await asyncio.sleep(period)
            try:
                await tick()
            except asyncio.CancelledError:
                raise
            except Exception as e:  # noqa: BLE001 - the task must outlive a bad tick
                studio.log('studio: %s: %s: %s' % (name, type(e).__name__, e))

    async def start(_app):
        app['periodic:' + name] = asyncio.ensure_future(run())

    async def stop(_app):
        app['periodic:' + name].cancel()
    app.on_startup.append(start)
    app.on_shutdown.append(stop)
