"""Recordings on disk: rosbag and MCAP (ROS 1) writers and readers, storage faults kept to one line each."""
