"""The paper's equations as pure functions of arrays (jax.numpy; NumPy where a host needs them):
`oscillator` (Eqs. 1–4, the §3.3 trot and action map), `slope` (Eq. 5, the attitude from the IMU),
`reward` (Eqs. 8–13, Fig. 9's r_xy). Written for one robot; batch with `jax.vmap`."""
