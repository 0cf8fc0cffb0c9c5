"""Online friction compensation: the outlier gate, the sliding-regime estimator and the friction feedforward components."""
