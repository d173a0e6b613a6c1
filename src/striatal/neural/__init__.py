"""The section-4 neural reading: pathway readout of learned gains and the spiking network.

``interpret`` reads learned gains as direct and indirect pathway activity (mu_1, mu_2)
and the updates as dopamine-gated LTP and LTD. ``network`` builds the chapter's
switching controller as a spiking network in nengo (``striatal neural``), ``run`` closes
the loop on the plant (nengo, the reference, or ``brian``: the same network compiled by
Brian2 with the plant inside the program), ``learn`` is the dopamine learning stage and
``driver`` runs the project's learning loop (any rule) with its trials on the network.
nengo and Brian2 are imported only by these modules.
"""
