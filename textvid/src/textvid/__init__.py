"""textvid: the video texture (virtual display) plugin, libgazebo_ros_video.so."""
