"""sim_world.control: joint plugins of articulated models (issue 48). Today the
joint state publisher (``libgazebo_ros_joint_state_publisher.so``); ros_control-style
controllers are not written yet (sim_world/README.md, Joints)."""
