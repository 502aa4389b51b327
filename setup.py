# Installed by catkin_python_setup(); do not run directly.
from setuptools import setup
from catkin_pkg.python_setup import generate_distutils_setup

setup(**generate_distutils_setup(
    packages=['simvid', 'simvid.physics', 'simvid.render', 'simvid.plugins',
              'textvid', 'kinect4skype', 'vnc_image_client',
              'simsensors', 'testing_instance'],
    package_dir={
        'simvid': 'simvid/src/simvid',
        'simvid.physics': 'simvid/src/simvid/physics',
        'simvid.render': 'simvid/src/simvid/render',
        'simvid.plugins': 'simvid/src/simvid/plugins',
        'textvid': 'textvid/src/textvid',
        'kinect4skype': 'kinect4skype/src/kinect4skype',
        'vnc_image_client': 'vnc_image_client/src/vnc_image_client',
        'simsensors': 'simsensors/src/simsensors',
        'testing_instance': 'testing_instance/src/testing_instance',
    },
))
