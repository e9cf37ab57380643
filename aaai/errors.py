"""The error a user sees for a key or value that is not allowed, below every module that raises it."""


class ConfigError(ValueError):
    """A configuration key or value that is not allowed."""
