"""The quadruped: its URDF writer and the body in a PyBullet client."""
