"""The error a user sees for a key or value that is not allowed, below every module that raises it."""


class ConfigError(ValueError):
    """A configuration key or value that is not allowed."""


def needs_extra(error: ImportError, command: str) -> str:
    """The one line a user sees when ``command`` imports a package of an optional extra that is not
    installed: the extra (read from the package's own extras, as setup.cfg lists them) and how to
    install it. An import error of anything else is given as it is."""
    missing = (error.name or "").partition(".")[0]
    extra = _extras().get(missing)
    if extra is None:
        return f"{command}: {error}"
    return (
        f"{command} needs the {extra} extra ({missing} is not installed): "
        f'pip install -e ".[{extra}]" in a checkout (make install-all installs every extra)'
    )


def _extras() -> dict[str, str]:
    """The optional packages by import name, each with its extra (a package of dev and of another
    extra counts as the other's); torch, installed before the train extra, as the train extra's."""
    import importlib.metadata
    import re

    extras = {"torch": "train"}
    try:
        requirements = importlib.metadata.requires("aaai") or []
    except importlib.metadata.PackageNotFoundError:
        return extras
    for requirement in requirements:
        found = re.match(r"\s*([A-Za-z0-9_.-]+).*extra\s*==\s*['\"](\w+)['\"]", requirement)
        if found and found.group(2) != "dev":
            extras.setdefault(found.group(1).lower().replace("-", "_"), found.group(2))
    return extras
