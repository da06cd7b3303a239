"""Where the tests find the project's shared real data: ../shared/data beside the repository, never
inside it (tests read it in place and skip with the reason when it is absent).

Importable from every test module as ``shared_data`` (pytest puts tests/ on the path for its root
conftest); the fixtures of tests/conftest.py use it too.
"""

from __future__ import annotations

from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parents[1]
SHARED = REPO_ROOT.parent / "shared"
SHARED_IFC = SHARED / "data" / "ifc"
SHARED_ONTOLOGIES = SHARED / "data" / "ontologies"


def shared_file(*parts: str) -> Path:
    """Path to a file under ../shared/data, or skip the test with the reason when it is absent."""
    path = SHARED.joinpath("data", *parts)
    if not path.exists():
        pytest.skip(f"{path} is absent: the shared test data lives beside the repository, not in it")
    return path


def shared_models(pattern: str = "*.ifc*") -> list[Path]:
    """The shared IFC models matching ``pattern``, sorted (empty when ../shared is absent)."""
    return sorted(SHARED_IFC.glob(pattern)) if SHARED_IFC.is_dir() else []
