"""Starting or joining Ray for one job: a local instance of its own, or an existing cluster."""

from __future__ import annotations

import os

from aaai.config import ConfigError


def ray_environment() -> None:
    """Environment variables Ray must see before it starts: no auth token written to the home folder."""
    os.environ.setdefault("RAY_AUTH_MODE", "disabled")


def check_reachable(address: str, seconds: float = 5.0) -> None:
    """Refuses a "host:port" nobody listens on (ray.init would retry for minutes before it gives up)."""
    import socket

    host, _, port = address.rpartition(":")
    if not host or not port.isdigit() or "://" in address:
        return  # "auto" and the like: Ray finds the cluster itself
    try:
        socket.create_connection((host, int(port)), timeout=seconds).close()
    except OSError as error:
        raise ConfigError(
            f"--address: got {address!r}; no Ray cluster answers there ({error}); allowed: the "
            "address of a running cluster's head, as `ray start --head` prints it"
        ) from None


class RaySession:
    """``ray.init`` on entry (a new local instance of ``workers`` CPUs, or joining ``address``) and
    ``ray.shutdown`` on exit. If Ray is already initialised in this process it is used as it is, and
    left running."""

    def __init__(self, address: str | None = None, workers: int = 2):
        self.address, self.workers, self.owned = address, workers, False

    def __enter__(self):
        ray_environment()
        import ray

        if ray.is_initialized():
            return self
        if self.address is None:
            # "local": always a new instance; never one found in RAY_ADDRESS or /tmp/ray/ray_current_cluster.
            ray.init(
                address="local",
                num_cpus=self.workers,
                include_dashboard=False,
                log_to_driver=False,
                configure_logging=False,
            )
        else:
            check_reachable(self.address)
            ray.init(address=self.address, log_to_driver=False, configure_logging=False)  # no dashboard: not ours
        self.owned = True
        return self

    def __exit__(self, *exc):
        import ray

        if self.owned:
            ray.shutdown()
        return False
