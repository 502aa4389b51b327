"""World plugins (sensors, displays) created by the Gazebo/thesis library name."""
