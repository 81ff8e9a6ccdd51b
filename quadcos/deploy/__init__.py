"""Out of JAX: the policy as NumPy (`numpy_policy`, `export`), NumPy twins of the env's equations
(`twins`), the robot stepped in C MuJoCo (`host_robot`: sim-to-sim and `play`), and `engines`:
the one `evaluate(policy, engine="mjx" | "mujoco")` over both engines."""
