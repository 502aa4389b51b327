"""textvid: the video texture (virtual display) plugin, libgazebo_ros_video.so."""

#: modules with world plugins (found by sim_world.plugins' registry)
PLUGIN_MODULES = ['textvid.video']
