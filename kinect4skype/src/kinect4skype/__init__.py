"""kinect4skype: pcl2image, point clouds rendered into an image topic."""
