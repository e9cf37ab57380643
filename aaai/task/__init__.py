"""The task on a spec: rewards and the episode's end, arena files, the reference controller."""
