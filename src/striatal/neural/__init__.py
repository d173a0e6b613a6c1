"""The section-4 neural reading: pathway readout of learned gains and the spiking network.

``interpret`` reads learned gains as direct and indirect pathway activity (mu_1, mu_2)
and the updates as dopamine-gated LTP and LTD. The other modules build the chapter's
switching controller as a spiking network in nengo (``striatal neural``) with its
dopamine learning stage; nengo is imported only by them.
"""
