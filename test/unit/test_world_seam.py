"""The world seam (issue 17): plugins use the World only through the public interface listed
once in ``sim_world.plugins`` (``WORLD_SEAM``, the SDK's doc and sim_world/README.md): every
name of it exists on a real World, and no plugin module uses any other attribute of the
world, a private one, or probes it with getattr/hasattr."""
import importlib
import inspect
import os
import re

import pytest

from sim_world import plugins
from sim_world.plugins import WORLD_SEAM
from sim_world.world import World

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
USE = re.compile(r'(?<![A-Za-z0-9_])world\.([a-z_]\w*)')
PROBE = re.compile(r'(?:getattr|hasattr)\(\s*(?:self\.)?world\b')
SDK = ['sim_world.plugins', 'sim_world.plugins.device', 'sim_world.plugins.sensor']


def _modules():
    return sorted(set(SDK + plugins.plugin_modules()))


def test_every_seam_name_is_on_the_world():
    w = World(physics='ode', seed=1)
    try:
        missing = [n for n in WORLD_SEAM if not hasattr(w, n)]
        assert missing == []
    finally:
        w.shutdown()


def test_the_seam_is_listed_in_the_sdk_doc_and_the_readme():
    doc = plugins.__doc__
    with open(os.path.join(ROOT, 'sim_world', 'README.md')) as f:
        readme = f.read()
    for n in WORLD_SEAM:
        assert '``%s' % n in doc, n
        assert '`%s' % n in readme, n


@pytest.mark.parametrize('name', _modules())
def test_plugin_modules_use_only_the_seam(name):
    src = inspect.getsource(importlib.import_module(name))
    used = set(USE.findall(src))
    assert used - set(WORLD_SEAM) == set(), 'uses of the World outside the seam'
    assert not PROBE.findall(src), 'probes the World with getattr/hasattr'
    assert not re.findall(r'world\._\w+', src), 'reads a private attribute of the World'


def test_the_seam_check_can_fail():
    assert USE.findall('self.world._renderer; world.physics.x; sim_world.world') == \
        ['_renderer', 'physics']
    assert PROBE.findall("getattr(self.world, 'log', None)")
