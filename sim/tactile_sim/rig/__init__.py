"""The chapter 5 rig as a forward model: SCARA + wheel probe geometry, objects with signed
distance and normal, the contact wrench, the §5.1 probing schedule, and the spherical
fingertip (EP1) through the F/T path.  Lengths in metres, forces in newtons.
"""
