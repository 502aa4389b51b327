# Installed by catkin_python_setup(); do not run directly.
from setuptools import setup
from catkin_pkg.python_setup import generate_distutils_setup

# One catkin package, one importable library per stack (<stack>/src/<package>/).
STACKS = {
    'sim_world': ['sim_world', 'sim_world.physics', 'sim_world.render', 'sim_world.plugins',
                  'sim_world.transport'],
    'simvid': ['simvid'],
    'textvid': ['textvid'],
    'simsensors': ['simsensors'],
    'kinect4skype': ['kinect4skype'],
    'vnc_image_client': ['vnc_image_client'],
    'emulator_bridge': ['emulator_bridge'],
    'testing_instance': ['testing_instance', 'testing_instance.scenario', 'testing_instance.io',
                         'testing_instance.world', 'testing_instance.run', 'testing_instance.farm'],
    'sim_studio': ['sim_studio'],
}
packages = [p for pkgs in STACKS.values() for p in pkgs]
package_dir = {p: '%s/src/%s' % (stack, p.replace('.', '/'))
               for stack, pkgs in STACKS.items() for p in pkgs}

# pytest collects scenario files (testing_instance.pytest_plugin; tools/setup writes the
# same entry point into the devel space)
setup(**generate_distutils_setup(
    packages=packages, package_dir=package_dir,
    entry_points={'pytest11': ['scenarios = testing_instance.pytest_plugin']}))
