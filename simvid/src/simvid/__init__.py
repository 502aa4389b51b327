"""simvid: the world server, physics, renderer, camera and video tools of mobile_device_sim."""
