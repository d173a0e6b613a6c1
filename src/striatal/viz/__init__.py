"""Pictures: figures, animations and the one drawing of the cart-pole; no physics.

Reads trajectories and histories made elsewhere and draws them with matplotlib
(Agg) or Pillow; every file is written atomically.
"""
