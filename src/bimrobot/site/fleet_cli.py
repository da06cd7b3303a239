"""``bimrobot fleet list``, ``fleet keys`` and ``fleet convert``: the built-in fleets, the keys of a robot
(from the declaration that validates fleet files), and older fleet files rewritten in the one fleet format
(:mod:`bimrobot.site.fleet`)."""

from __future__ import annotations

import argparse

EXAMPLES = """examples:
  bimrobot fleet list                            # the built-in fleets and their robots
  bimrobot fleet keys                            # every key of a robot: unit, range, the kinds that need it
  bimrobot fleet convert old.yaml -o fleet.yaml  # a version-1 fleet or RCAN capability table, as version 2
"""


def register(subparsers) -> None:
    """Add ``fleet list`` and ``fleet convert`` to the bimrobot parser."""
    fleet = subparsers.add_parser("fleet", help="list the built-in fleets; convert an older fleet file",
                                  epilog=EXAMPLES, formatter_class=argparse.RawDescriptionHelpFormatter)
    commands = fleet.add_subparsers(dest="fleet_command", metavar="COMMAND", required=True)
    listing = commands.add_parser("list", help="the built-in fleets (`--fleet NAME`) and their robots",
                                  epilog="example:\n  bimrobot fleet list",
                                  formatter_class=argparse.RawDescriptionHelpFormatter)
    listing.set_defaults(func=_list)
    keys = commands.add_parser("keys", help="the keys of a version-2 robot entry: unit, range, the kinds that need it",
                               epilog="example:\n  bimrobot fleet keys",
                               formatter_class=argparse.RawDescriptionHelpFormatter)
    keys.set_defaults(func=_keys)
    convert = commands.add_parser("convert", help="rewrite a fleet file of any version in the version-2 keys",
                                  epilog="example:\n  bimrobot fleet convert capabilities.yaml -o fleet.yaml",
                                  formatter_class=argparse.RawDescriptionHelpFormatter)
    convert.add_argument("fleet", help="a fleet YAML file (version 1, 2, or an RCAN capability table) or a built-in name")
    convert.add_argument("-o", "--output", required=True, help="the version-2 fleet file to write (never a user's file)")
    convert.set_defaults(func=_convert)


def _list(args) -> int:
    from bimrobot.site.fleet import BUILTIN_FLEETS, load_fleet

    for name in BUILTIN_FLEETS:
        fleet = load_fleet(name)
        kinds: dict[str, int] = {}
        for robot in fleet.robots:
            kinds[robot.kind] = kinds.get(robot.kind, 0) + 1
        shown = ", ".join(f"{count} {kind}" for kind, count in kinds.items())
        print(f"{name:12s} {len(fleet.robots)} robots ({shown}): {', '.join(fleet.names)}")
    return 0


def _keys(args) -> int:
    """One line per key of a robot entry, read from the same declaration that validates fleet files."""
    from bimrobot.site.fleet import ACTIVITY_KEYS, KIND_ACTIVITIES, RobotSpec
    from bimrobot.core.schema import rules_of

    for key, rule in rules_of(RobotSpec).items():
        kinds = [kind for kind, tasks in KIND_ACTIVITIES.items()
                 if key in ("name", "kind") or any(key in ACTIVITY_KEYS[task] for task in tasks)]
        if key == "platform_m":  # a mobile manipulator may leave it out (it carries in its gripper)
            kinds.remove("mobile_manipulator")
        need = f"needed by {', '.join(kinds)}" if kinds else "optional"
        print(f"{key:18s} {rule.describe():66s} {need}")
    return 0


def _convert(args) -> int:
    import yaml

    from bimrobot.core.config import parse_yaml
    from bimrobot.site.fleet import BUILTIN_FLEETS, fleet_from_dict, fleet_to_dict, load_fleet
    from bimrobot.core.errors import InputError
    from bimrobot.core.io import atomic_output_file, signature

    fleet = load_fleet(args.fleet)
    inputs = [] if args.fleet in BUILTIN_FLEETS else [args.fleet]
    text = f"# {signature('fleet convert')}, from {fleet.source}\n"
    text += yaml.safe_dump(fleet_to_dict(fleet), sort_keys=False, default_flow_style=None)
    try:  # what it writes must read back: an older file's value outside version 2's ranges is named
        fleet_from_dict(parse_yaml(text, args.output), args.output)
    except InputError as exc:
        raise InputError(f"{args.fleet} cannot be written in the version-2 keys: {exc}") from None
    with atomic_output_file(args.output, inputs=inputs) as tmp:
        tmp.write_text(text)
    print(f"{args.output}: fleet {fleet.name}, {len(fleet.robots)} robots, version 2")
    return 0
