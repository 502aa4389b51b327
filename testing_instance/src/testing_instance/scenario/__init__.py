"""What a scenario is, pure (no ROS, no clock): the file format and its validation, parameters and sweeps,
expectations and their verdicts, the timeline (agenda, `when` conditions, slice rule), the motion maths
of the actions, the result (exit codes, JUnit). The ground floor: it imports nothing of the package."""
