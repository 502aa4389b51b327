"""simsensors: the virtual sensors and output devices of thesis chapter 3, one module per
unit, each a plugin on the shared sensor layer (``sim_world.plugins.sensor.Sensor``).

Every module of this package whose name does not start with ``_`` is imported by the plugin
registry (``PLUGIN_PACKAGE``): a new sensor is one module plus its tests.
"""

PLUGIN_PACKAGE = True
