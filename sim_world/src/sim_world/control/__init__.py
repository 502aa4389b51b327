"""sim_world.control: joint plugins of articulated models and ros_control (issue 48).

- ``joint_state_publisher``: ``libgazebo_ros_joint_state_publisher.so``;
- ``ros_control``: ``libgazebo_ros_control.so`` (gazebo_ros_control), over ``robot_hw``
  (DefaultRobotHWSim: transmissions, kinematic position, velocity and effort interfaces);
- ``controllers``: the controller manager and ros_controllers' joint controllers, pure Python;
- ``trajectory``: ros_controllers' JointTrajectoryController, pure Python;
- ``ros_api``: the manager's ROS side (controller_manager's services, the controllers'
  topics, query_state and the follow_joint_trajectory action);
- ``spawner``: controller_manager's spawner (``rosrun mobile_device_sim spawner``).

sim_world/README.md, "Controllers", says what each does and what is not supported."""
