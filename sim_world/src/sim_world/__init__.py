"""sim_world: the world server of mobile_device_sim, the Gazebo analogue (thesis chapter 2's
virtual environment): World, environment, ray casting, transforms, model loaders (model, urdf,
sdf, mesh), physics (ODE, Bullet), the offscreen renderer, the plugin SDK (``sim_world.plugins``)
and the world's ROS layer (``node``, ``gazebo_api``, ``world_services``, ``spawn``)."""

#: plugin modules of this package (sim_world.plugins finds them here); the SDK holds none
PLUGIN_MODULES = ['sim_world.control.joint_state_publisher', 'sim_world.control.ros_control']
