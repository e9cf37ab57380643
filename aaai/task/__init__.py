"""The task on a spec: rewards and the episode's end, solvability, seeds, arena files, the reference controller."""
