"""vnc_image_client: a VNC framebuffer as a ROS image topic (ctypes binding of libvncclient)."""
