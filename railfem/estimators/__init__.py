"""Model-free estimators: the same code for measured and simulated data."""
