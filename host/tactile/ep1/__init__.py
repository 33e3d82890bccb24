"""EP1 on the host: curvature at a point from rolling probes (thesis ch. 3)."""
