"""`bimrobot --help` lists every command without importing any part; a command imports only its own part."""

from __future__ import annotations

import argparse
import importlib
import subprocess
import sys

from bimrobot.cli import COMMANDS, PART_CLIS, build_parser, command_word

HEAVY = ("numpy", "trimesh", "scipy", "ifcopenshell", "rdflib", "simpy", "torch", "mujoco", "rerun", "yaml",
         "gymnasium", "networkx", "pyoxigraph", "plotly")
"""Libraries that take a tenth of a second or more to import: none of them is needed to answer --help."""


def _loaded_after(code: str) -> list[str]:
    """The HEAVY libraries (and the parts' cli modules) in sys.modules after ``code`` runs in a fresh interpreter."""
    probe = (f"import sys\n{code}\n"
             f"print(sorted(n for n in sys.modules if n.split('.')[0] in {HEAVY!r} and '.' not in n) + "
             "sorted(n for n in sys.modules if n.startswith('bimrobot.') and n.endswith('.cli') and n != 'bimrobot.cli'))")
    result = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True)
    return eval(result.stdout.strip().splitlines()[-1])  # a list literal printed by the probe


def test_help_and_version_import_no_part_and_no_heavy_library():
    for option in ("--help", "--version"):
        loaded = _loaded_after(f"from bimrobot.cli import main\ntry:\n    main([{option!r}])\nexcept SystemExit:\n    pass")
        assert loaded == [], f"bimrobot {option} imported {loaded}"


def test_a_command_imports_its_own_part_only():
    loaded = _loaded_after("from bimrobot.cli import parser_for\nparser_for(['-v', 'rl', 'train', '--help'])")
    assert loaded == ["bimrobot.rl.cli"]


def test_the_command_table_is_what_the_parts_register():
    """COMMANDS (which --help lists without importing a part) names each command's part and its help line."""
    registered = {}
    for module_name in PART_CLIS:
        subparsers = argparse.ArgumentParser().add_subparsers()
        importlib.import_module(module_name).register(subparsers)
        registered.update({action.dest: (module_name, action.help) for action in subparsers._choices_actions})
    assert registered == COMMANDS
    assert build_parser([]).format_help() == build_parser().format_help()


def test_the_command_word_skips_bimrobot_options():
    assert command_word(["-vv", "convert", "frame.ifc", "-o", "out"]) == "convert"
    assert command_word(["--verbose", "--help"]) is None
    assert command_word([]) is None


def test_package_inits_load_no_heavy_library():
    """Importing a package (or a light module in it) does not import its heavy modules: the names of
    bimrobot.coordination, bimrobot.sco and bimrobot.bim are loaded on first use (issue 37)."""
    loaded = _loaded_after("import bimrobot.coordination, bimrobot.sco.timing, bimrobot.bim.selection, "
                           "bimrobot.coordination.inputs")
    assert loaded == []
    fleet_list = _loaded_after("from bimrobot.cli import main\nmain(['fleet', 'list'])")
    assert "simpy" not in fleet_list  # the simulation is not needed to list fleets
