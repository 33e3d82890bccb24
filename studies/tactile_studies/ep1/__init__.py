"""EP1 studies (thesis ch. 3): simulated probes through the host's estimator, and figures."""
