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


def test_the_backend_declares_one_feature_module_per_activity():
    from bimrobot.rcan.activities import ActivityKind
    from bimrobot.rcan.backends.mujoco import FEATURES, MujocoBackend

    assert set(FEATURES) == set(ActivityKind) and MujocoBackend.features is FEATURES
    modules = {getattr(MujocoBackend, method).__module__.rsplit(".", 1)[1] for method in FEATURES.values()}
    assert modules == {"move", "pick", "transport", "position", "install"}
