"""Physics backends behind one interface: ODE (pyode) and Bullet (pybullet)."""
