"""The MuJoCo site and its RCAN backend keep their shape (issue 37, small rooms): the site's skills
are modules under about 600 lines, the physics knows nothing of RCAN, the backend calls the site's
public methods only, and the backend declares one method per activity feature. Read from the source
(ast): no MuJoCo needed, well under a second."""

import ast
from pathlib import Path

import bimrobot

SRC = Path(bimrobot.__file__).parent
SITE = SRC / "physics" / "site"
BACKEND = SRC / "rcan" / "backends" / "mujoco"


def _modules(folder: Path) -> dict[str, ast.Module]:
    return {path.name: ast.parse(path.read_text(encoding="utf-8")) for path in sorted(folder.glob("*.py"))}


def test_the_site_is_skills_each_a_module_of_at_most_600_lines_and_functions_of_at_most_60():
    skills = {"world.py", "control.py", "contacts.py", "clearance.py", "paths.py", "base.py", "stands.py", "arm.py",
              "grasp.py"}
    assert skills <= set(_modules(SITE))
    for folder in (SITE, BACKEND):
        for path in folder.glob("*.py"):
            text = path.read_text(encoding="utf-8")
            assert len(text.splitlines()) <= 600, path
            long = [(f.name, f.end_lineno - f.lineno + 1) for f in ast.walk(ast.parse(text))
                    if isinstance(f, ast.FunctionDef) and f.end_lineno - f.lineno + 1 > 60]
            assert long == [], (path, long)


def test_physics_imports_nothing_of_rcan():
    for path in (SRC / "physics").rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom):
                assert not (node.module or "").startswith("bimrobot.rcan"), path
            elif isinstance(node, ast.Import):
                assert not any(a.name.startswith("bimrobot.rcan") for a in node.names), path


def test_the_backend_uses_only_public_names_of_the_site():
    private = []
    for name, tree in _modules(BACKEND).items():
        for node in ast.walk(tree):
            # site._x or self.site._x
            if isinstance(node, ast.Attribute) and node.attr.startswith("_") and not node.attr.startswith("__"):
                owner = node.value
                if (isinstance(owner, ast.Name) and owner.id == "site") or \
                        (isinstance(owner, ast.Attribute) and owner.attr == "site"):
                    private.append(f"{name}:{node.lineno} site.{node.attr}")
    assert private == []


def test_the_backend_declares_its_six_features_one_module_each_and_what_it_needs_without_importing_them():
    import subprocess
    import sys

    from bimrobot.rcan.activities import ActivityKind
    from bimrobot.rcan.backends.features import ActivityFeature
    from bimrobot.rcan.backends.interfaces import DispatchingBackend
    from bimrobot.rcan.backends.mujoco import FEATURES, INFO, MujocoBackend

    assert set(MujocoBackend.features) == set(ActivityKind) == {feature.kind for feature in FEATURES}
    assert not issubclass(MujocoBackend, DispatchingBackend)
    assert all(issubclass(feature, ActivityFeature) for feature in FEATURES)
    # each activity's method and its physical work live in the feature class (module) that declares it
    for feature in FEATURES:
        assert {feature.kind.value, f"_{feature.kind.value}"} <= set(vars(feature)), feature
    modules = {feature.__module__.rsplit(".", 1)[1] for feature in FEATURES}
    assert modules == {"move", "pick", "transport", "position", "install"}
    assert INFO.needs == ("plan", "trajectory_path") and INFO.acts_in_turns and MujocoBackend.backend_info() is INFO
    # the declaration is read (rcan --help lists every backend's options) without numpy or MuJoCo
    code = ("import sys; from bimrobot.rcan.backends import declaration; declaration('mujoco'); "
            "print('numpy' in sys.modules, 'mujoco' in sys.modules)")
    assert subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split() == \
        ["False", "False"]
