"""simvid: the video system of thesis chapter 4: the camera plugin (libgazebo_ros_camera.so) and
camera model, camera_move, image_sink with its V4L2 and YUV code, image conversion, the barcode
reader and the QR demo."""

#: modules with world plugins (found by sim_world.plugins' registry)
PLUGIN_MODULES = ['simvid.camera']
