"""docs/plugin_parameters.md is generated from the plugins' declared rows
(tools/plugin_params): it must list every registered plugin with every parameter, as the
code declares them now."""
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def test_parameter_tables_are_up_to_date():
    out = subprocess.run([sys.executable, os.path.join(ROOT, 'tools', 'plugin_params')],
                         capture_output=True, text=True, check=True).stdout
    with open(os.path.join(ROOT, 'docs', 'plugin_parameters.md')) as f:
        committed = f.read()
    assert out == committed, ('docs/plugin_parameters.md is stale: run '
                              'tools/plugin_params > docs/plugin_parameters.md')
    for lib in ('libgazebo_ros_imu.so', 'libgazebo_ros_camera.so', 'libgazebo_ros_video.so'):
        assert '`%s`' % lib in committed
    assert '| `accelGaussianNoise` |' in committed
