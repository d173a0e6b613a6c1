"""Experiments: whole runs and many runs, their baselines and their statistics.

Owns the Python API of a training run (``training``), the sweep over seeds and arms
with its engines (processes, Ray, the lockstep batch engine), the ablation, the
baselines the learners are compared with (LQR, hand-tuned, random search, CMA-ES),
robustness tables, pass-probability estimates, performance profiles and the
interval and test statistics every table prints.
"""
