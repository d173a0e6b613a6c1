"""The chapter's switching controller as a spiking network (nengo): ``striatal neural``."""
