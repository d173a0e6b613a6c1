"""Pictures: figures, animations and the one drawing of the cart-pole; no physics.

Reads trajectories, histories and sweep results made elsewhere and draws them with
matplotlib (Agg) or Pillow; every file is written atomically. One module per kind
of picture: ``trajectory`` (Figure 5 of one run), ``curves`` (learning curves),
``switch`` (the soft switch), ``animation`` (GIF and MP4), ``profiles``
(performance profiles of sweeps), on the canvas and save of ``canvas``; ``render``
draws one frame, for the animation and the Gymnasium env. ``plots`` gathers the
figure functions under one name.
"""
