"""EP1 simulation (thesis ch. 3): surfaces, Montana's rolling kinematics, probes (the studies
that estimate from them: ``tactile_studies.ep1``)."""
