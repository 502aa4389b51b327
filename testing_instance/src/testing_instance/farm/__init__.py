"""Many runs: the command line, warm workers, sweeps, the Ray cluster, the pytest plugin."""
