"""What `python -m quadcos.bench` measures, one room per kind of measurement.

  settings      what a bench run measures and at which sizes; the env and trainer of a preset
  timing        process start-up, compiled calls timed on the carry that compiled them
  physics       raw MJX physics and env steps per second
  trainers      our trainer and stock Brax SAC, side by side
  time_to_walk  training (in the trainer's own host loop) until the policy walks or crosses
  results       the results JSON, merging, Markdown tables
  scaling       results on 1 and N devices side by side
  profile       where a profiled training chunk's time goes (jax.profiler trace summary)
"""
