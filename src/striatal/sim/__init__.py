"""The simulator: the cart-pole plant, the chapter's controllers and the compiled trial.

Owns the physics and everything one trial needs: the plant and its partial feedback
linearisation (eqs 7-14), the swing-up and balancing controllers with their switch
(eqs 15-23), the Gaussian policy and its eligibility traces (eqs 1-5), the compiled
trial loops (Numba), their plain-NumPy reference, trial noise, the robustness cases a
controller is checked on, and the timing primitives of ``striatal bench``. Nothing
here knows about learning rules, experiments, files or the command line.
"""
