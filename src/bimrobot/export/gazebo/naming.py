"""Names of what a package holds: the world (from the IfcSite, unless a tool default), the storeys' maps,
and paths as they read once a resumable command's partial folder is renamed into place."""

from __future__ import annotations

import re

from bimrobot.bim.model import BuildingModel
from bimrobot.core.names import slug

def final_path(text: str) -> str:
    """``text`` with a resumable command's partial folder (``.NAME.partial``, :func:`bimrobot.core.io.partial_folder`)
    replaced by the folder it becomes when the command finishes (``NAME``): e.g. ``build``'s
    ``out/.b.partial/site.yaml`` is ``out/b/site.yaml`` once the build is renamed into place. Other text
    is returned unchanged."""
    return re.sub(r"(^|/)\.([^/]+)\.partial(?=/|$)", r"\1\2", text)


GENERIC_SITE_NAMES = {"", "site", "default", "default_site", "surface", "topography", "topography_surface",
                      "unnamed", "my_site", "undefined", "none", "null", "unknown", "untitled", "project",
                      "default_project", "building", "default_building", "world"}
"""Slugs of names authoring tools write by default (Revit: "Topography : Surface", "Default"; Tekla:
"Undefined"; IfcOpenShell: "My Site"); they do not name a world, a map or a file."""

GENERIC_STOREY_NAMES = {"", "undefined", "default", "storey", "building_storey", "level", "unnamed", "none",
                        "null", "unknown", "untitled"}
"""Slugs of storey names that say nothing (Tekla exports one storey named "Undefined")."""


def is_generic(name: str, generic: set[str]) -> bool:
    # "Site #1", "Level 2" keep a number: "site_1" is generic, "level_2" is not (a storey needs its number);
    # "表面:335313" slugs to "335313": a number alone names nothing.
    return name in generic or name.replace("_", "").isdigit() or bool(re.fullmatch(r"(site|default)_\d+", name))


def world_name_of(model: BuildingModel) -> str:
    """The world's name and file stem: the IfcSite's name, unless it is a tool default ("Undefined",
    "Default", "Topography : Surface", ...); then the IFC file's name, then the project's, then "building"."""
    candidates = [model.site_name or "", model.source.stem if model.source else "", model.project_name or ""]
    for candidate in candidates:
        name = slug(candidate, "")
        if not is_generic(name, GENERIC_SITE_NAMES):
            return name
    return "building"


def map_name(storey_name: str, index: int) -> str:
    """File stem of a storey's map: its name (``storey_2`` for a storey named "2"), or ``storey_<n>``
    (n from 1, lowest first) for a name that says nothing ("Undefined", "Default", empty)."""
    name = slug(storey_name, "")
    if name.isdigit():
        return f"storey_{name}"
    return f"storey_{index}" if is_generic(name, GENERIC_STOREY_NAMES) else name
