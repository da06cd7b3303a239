"""Sub-commands of the lbd part (registered by bimrobot.cli)."""


def register(subparsers) -> None:
    """Add this part's sub-commands to the ``bimrobot`` parser."""
