"""Out of JAX: the policy as NumPy (`numpy_policy`, `export`), NumPy twins of the env's equations
(`twins`), and the robot stepped in C MuJoCo (`host_robot`: sim-to-sim and `play`)."""
