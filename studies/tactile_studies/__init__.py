"""tactile studies: the application layer's replicas of the thesis's experiments.

Each study runs the simulator (``tactile_sim``) and the host's estimators (``tactile.ep1``,
``tactile.ep2``, ``tactile.localize``) together and compares them with the truth or the
thesis: the EP1 studies of ch. 3 (figs. 13-18), the EP2 studies of §4.9 (figs. 30-34) and
tables 5-7, their test cases and truth, and the chapter 5 replica (``replica``).  Nothing
below this layer (library, simulator) imports it (tests/test_layers.py).
"""
