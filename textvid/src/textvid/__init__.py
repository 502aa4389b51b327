"""textvid: the video texture (virtual display) plugin, libgazebo_ros_video.so."""

#: modules with world plugins (found by simvid.plugins' registry)
PLUGIN_MODULES = ['textvid.video']
