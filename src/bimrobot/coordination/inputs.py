"""What ``simulate``, ``allocators``, ``plan export`` and the planners read: the building (an IFC file or
``generated:NXxNYxF``), the fleet, the site, and a function building the SmartModel.

No argparse here: :func:`prepare` takes any object with the attributes of ``simulate``'s options
(``model``, ``fleet``, ``site``, ``output``, ``prebuilt``, ``include``, ``exclude``, ``unknown_weight``,
``tolerance``, ``by_element``, optionally ``breakdown``), so the CLI (:mod:`bimrobot.coordination.cli`)
and the planners (:mod:`bimrobot.planning`) share one reader without importing each other.
Lengths in metres, z up.
"""

from __future__ import annotations

import re
from pathlib import Path

from bimrobot.core.errors import InputError

GENERATED = re.compile(r"^generated:(\d+)x(\d+)x(\d+)$")


def load_building(spec: str, include: str | None = None, exclude: str | None = None, prebuilt: str | None = None,
                  unknown_weight=None):
    """(BuildingModel, storey elevations in metres) from an IFC path or ``generated:NXxNYxF``.

    ``include`` / ``exclude`` / ``prebuilt``: IfcOpenShell selectors (:mod:`bimrobot.bim.selection`), for
    IFC files. ``unknown_weight``: the :class:`~bimrobot.bim.unknown_weight.UnknownWeightRule`, applied once
    when the model is read (``model.unknown_weights``; a generated frame gives every element its weight).
    """
    match = GENERATED.match(spec)
    if match:
        from bimrobot.coordination.generate import generated_frame

        nx, ny, floors = (int(v) for v in match.groups())
        if min(nx, ny, floors) < 1:
            raise InputError(f"{spec}: NX, NY and FLOORS must be at least 1")
        if nx * ny * floors > 1_000_000:
            raise InputError(f"{spec}: at most 1,000,000 columns (NX x NY x FLOORS), got {nx * ny * floors:,}")
        model = generated_frame(nx, ny, floors)
        if unknown_weight is not None:
            from bimrobot.bim.unknown_weight import UnknownWeights

            model.unknown_weights = UnknownWeights(unknown_weight)  # every generated element has its weight
    else:
        # issue 38: generated:KIND:... is a generated IFC file (bimrobot.site.generated), read as a user's
        if spec.startswith("generated:"):
            from bimrobot.site.generated import model_path

            spec = str(model_path(spec))
        path = Path(spec)
        if not path.is_file():
            raise InputError(f"model file {spec!r} does not exist")
        from bimrobot.bim import load_model

        model = load_model(path, include=include, exclude=exclude, prebuilt=prebuilt, unknown_weight=unknown_weight)
    return model, [s.elevation for s in model.storeys]


def input_files(args) -> list[str]:
    """The files the command reads (for the output policy): the model, a fleet file, a site file."""
    from bimrobot.site.fleet import BUILTIN_FLEETS

    files = [] if GENERATED.match(args.model) else [args.model]
    if args.fleet not in BUILTIN_FLEETS:
        files.append(args.fleet)
    if args.site:
        files.append(args.site)
    return files


def prepare(args, kind: str | None, model=None, folder: bool = True):
    """Check the output path, read fleet, site and model (the unknown-weight rule applied as it is read).

    Returns (model, elevations, fleet, site, unknown-weight report, a function building a fresh
    SmartModel). Everything a user can get wrong is refused here, before the long work starts, an output
    folder another kind of command wrote included (``kind``: ``simulate`` or ``allocators``). ``model``:
    the BuildingModel of ``args.model`` already read with the same selection, prebuilt selector and
    unknown-weight rule (``bimrobot build`` reads it once for every stage); None reads it here.
    ``folder``: the output is a folder (simulate, allocators), else one file (``plan export``, kind None).
    """
    from bimrobot.site.fleet import load_fleet
    from bimrobot.site.site import load_site
    from bimrobot.core.io import check_output
    from bimrobot.sco.build import build_smart_model, prebuilt_rule, prebuilt_selector
    from bimrobot.site.site import site_for

    check_output(args.output, folder=folder, inputs=input_files(args), kind=kind)  # an output of another kind: refused now
    fleet = load_fleet(args.fleet)
    site = load_site(args.site)
    names = {r.name for r in fleet.robots}
    for robot, *_ in getattr(args, "breakdown", []):
        if robot not in names:
            raise InputError(f"--breakdown names robot {robot!r}, which is not in fleet {fleet.name} ({', '.join(sorted(names))})")
    prebuilt = args.prebuilt  # a selector; the old comma list of classes is one too
    if model is None:
        model, elevations = load_building(args.model, args.include, args.exclude, prebuilt_selector(prebuilt),
                                          args.unknown_weight)
    else:
        elevations = [s.elevation for s in model.storeys]
    prebuilt_rule(model, prebuilt)  # an unknown class name is refused now, with the model's classes
    weights = model.unknown_weights  # the rule, applied once when the model was read
    site = site_for(args.site, model.elements.values())  # given, fig. 4.11 or derived; placed on the building
    points = {"assembly_points_per_joint": site.assembly_points_per_joint} if site.assembly_points_per_joint else {}
    return model, elevations, fleet, site, weights, lambda: build_smart_model(
        model, prebuilt_classes=prebuilt, inferred_tolerance_m=args.tolerance, by_element=args.by_element, **points
    )
