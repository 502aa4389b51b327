"""The run's world and its processes: the master, the world (embedded, launched, warm, attached),
the launch file's other nodes, the scenario's apps and the watch that tells when they answered."""
