"""EP1 simulation (thesis ch. 3): surfaces, Montana's rolling kinematics, probes, studies."""
