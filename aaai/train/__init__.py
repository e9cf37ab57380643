"""Training: the vector of workers, the curriculum samplers, PPO (stable-baselines3, RLlib), DAgger, experiments."""
