"""The entry point of the pytest plugin (setup.py and tools/setup name this module): the plugin
itself is testing_instance.farm.pytest_plugin."""
from .farm.pytest_plugin import *  # noqa: F401,F403 - its hooks and names
