"""emulator_bridge: feeds the simulated phone's sensors, location and battery into a running
Android emulator through its console port (thesis chapter 5's Android edge; a consumer of the
world's topics, like tinyros_android)."""
