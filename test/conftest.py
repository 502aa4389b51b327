"""Shared pytest set-up: makes the stack libraries importable straight from the
source tree, so unit tests run without a catkin build or roscore."""
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
for stack in ('sim_world', 'simvid', 'textvid', 'kinect4skype', 'vnc_image_client',
              'simsensors', 'emulator_bridge', 'testing_instance', 'sim_studio'):
    src = os.path.join(ROOT, stack, 'src')
    if src not in sys.path:
        sys.path.insert(0, src)
os.environ.setdefault('PYOPENGL_PLATFORM', 'osmesa')
os.environ.setdefault('ROS_HOSTNAME', 'localhost')

# rostest node scripts and helper programs are run by rostest / the suites' wrappers, not
# collected by pytest (they would wait for a ROS master forever).
collect_ignore_glob = ['rostest/*', 'tinyros/*', 'data/*']


# the exit watch: a thread left running after the last test is named, with the test that
# started it, and the run exits 1 instead of hanging (fixtures/exit_watch.py)
from fixtures.exit_watch import pytest_runtest_protocol, pytest_unconfigure  # noqa: E402,F401

# MDS_SHUFFLE_SEED=N: the test files in an order drawn from N (fixtures/shuffle.py)
from fixtures.shuffle import pytest_collection_modifyitems, pytest_report_header  # noqa: E402,F401,E501


# a test that removes or changes an environment variable and does not give it back errors,
# named, and the variable is given back (fixtures/env_kept.py)
from fixtures.env_kept import _environment_kept  # noqa: E402,F401


# runs several integration test files compare against, done once per session: the farm over
# every example, compass_declination's sweep, auto_rotate's recording
# (fixtures/example_farm.py)
from fixtures.example_farm import (auto_rotate_recording, declination_sweep,  # noqa: E402,F401
                                   example_farm)


# the suite's two lanes under `pytest -n 2 --dist loadgroup` (tools/test with no arguments):
# the integration tests one after another on one worker, the unit tests and the qemu test on
# the other (fixtures/lanes.py)
def pytest_configure(config):
    from fixtures import lanes
    if not config.pluginmanager.has_plugin('mds_lanes'):
        config.pluginmanager.register(lanes, 'mds_lanes')


# one studio and one Chromium page on it, shared by the studio extensions' browser tests
# (test/test_studio_*.py; fixtures/studio.py)
from fixtures.studio import shared_page, shared_studio  # noqa: E402,F401
