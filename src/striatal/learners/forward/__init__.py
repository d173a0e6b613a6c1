"""A cerebellar forward model learned from real trials, and the basal-ganglia learner that
learns on it in imagination."""
