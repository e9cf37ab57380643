"""The simulation: a PyBullet client, the world built from a spec, its moving parts, the senses and the gait."""
