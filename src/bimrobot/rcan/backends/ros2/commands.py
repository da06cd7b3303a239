"""The ``ros2`` backend's command, ``bimrobot rcan robot-node``: the shipped ROS 2 robot node (the
``sim`` backend's kinematic robots behind one ConstructionActivity action server per robot and activity).
Registered by :mod:`bimrobot.rcan.cli` from the backend's declaration (``INFO.commands``); light to import.
"""

from __future__ import annotations

import argparse


def register(commands) -> None:
    """Add ``robot-node`` to the ``bimrobot rcan`` sub-commands."""
    from bimrobot.rcan import cli  # the rcan part's fleet and site options

    node = commands.add_parser("robot-node", help="run the shipped ROS 2 robot node (kinematic robots)",
                               description="A ROS 2 node serving the ConstructionActivity action for every robot "
                                           "of the fleet (--fleet), executing activities on kinematic robots.",
                               epilog="example:\n  bimrobot rcan robot-node --time-scale 0.01",
                               formatter_class=argparse.RawDescriptionHelpFormatter)
    cli._fleet_option(node)
    cli._site_options(node)
    node.add_argument("--time-scale", type=float, default=0.0, help="real seconds per simulated second (default 0)")
    node.add_argument("--failure-probability", type=float, default=0.0, help="chance an activity fails (default 0)")
    node.add_argument("--seed", type=int, default=0, help="seed of the failure draws (default 0)")
    node.add_argument("--state-db", default=":memory:",
                      help="SQLite file for the robots' world, new or bimrobot's (default in memory)")
    node.add_argument("--robot", action="append", help="serve only this robot (repeatable; default: all)")
    node.set_defaults(func=robot_node)


def robot_node(args) -> int:
    """Serve the fleet's robots (or ``--robot``'s) until SIGINT/SIGTERM; bad input is one sentence."""
    from bimrobot.core.errors import InputError
    from bimrobot.rcan import cli
    from bimrobot.rcan.backends.ros2.robot_node import serve_robot_node

    cli._check_backend_options(args)
    if args.state_db != ":memory:":
        from bimrobot.core.io import check_output
        from bimrobot.rcan.state_db import is_state_db

        check_output(args.state_db, folder=False, inputs=cli._inputs(args), option="--state-db", recognise=is_state_db)
    capabilities, _ = cli._fleet_capabilities(args)
    unknown = [r for r in args.robot or () if r not in capabilities.by_name]
    if unknown:
        raise InputError(f"--robot {unknown[0]!r} is not a robot of {capabilities.source} "
                         f"(its robots: {', '.join(capabilities.names[:10])})")
    return serve_robot_node(capabilities, time_scale=args.time_scale, failure_probability=args.failure_probability,
                            seed=args.seed, db_path=args.state_db, robots=args.robot)
