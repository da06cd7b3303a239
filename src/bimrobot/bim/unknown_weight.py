"""The one rule for elements whose weight the model does not give, applied once when the model is loaded.

``--unknown-weight`` takes ``auto`` (the default), a density in kg/m3, or ``refuse``:

- ``auto``: the density is chosen per element, by class and material (:func:`assumed_material`):
  steel (7,850 kg/m3, EN 1991-1-1 Table A.4) for fasteners, bolts, welds, plates and embedded items
  (IfcMechanicalFastener, IfcFastener, IfcPlate, IfcDiscreteAccessory) and for any element whose
  material or name says steel (a steel grade such as S355 or St52, a steel profile such as HEB220,
  W310X38.7 or an angle cleat); timber (500 kg/m3, softwood C24) where the material or name says
  wood (a timber grade such as C24 or GL24h, rafters, joists); otherwise normal-weight concrete
  (:data:`DEFAULT_DENSITY_KG_M3`, 2,400 kg/m3, EN 1991-1-1 24 kN/m3): the heaviest common structural
  material after steel, so a robot sized by it is not undersized for concrete, masonry or timber.
- a density: every such element weighs its body volume times that density.
- ``refuse``: the command stops and lists, by class, the elements without a weight.

Assumed masses are marked :attr:`~bimrobot.bim.model.WeightSource.ASSUMED`, and each element's basis
names the material assumed. The rule is applied once, by ``load_model(..., unknown_weight=rule)``
(``BuildingModel.unknown_weights`` keeps what it did); applying it again changes nothing and gives the
same report. Every command reports it in the same words (:meth:`UnknownWeights.message`) and the same
JSON (:meth:`UnknownWeights.as_dict`), with the count per assumed material.
"""

from __future__ import annotations

import argparse
import math
import re
from collections import Counter
from dataclasses import dataclass, field
from typing import Iterable, NamedTuple

from bimrobot.bim.model import Element, WeightSource
from bimrobot.core.errors import InputError

DEFAULT_DENSITY_KG_M3 = 2400.0
STEEL_DENSITY_KG_M3 = 7850.0
TIMBER_DENSITY_KG_M3 = 500.0
REFUSE = "refuse"
AUTO = "auto"
#: Densities accepted for the assumption, kg/m3 (aerated foam to tungsten, with margin).
DENSITY_RANGE_KG_M3 = (10.0, 20000.0)
#: Classes that are steel unless the model says otherwise: bolts, welds, plates, embedded items.
STEEL_CLASSES = ("IfcMechanicalFastener", "IfcFastener", "IfcPlate", "IfcDiscreteAccessory")
#: Steel in a material name or element name: grades (S235, S355J2, St52-3, Q345, ASTM A992/A36/A572,
#: Revit's "45-345" yield/tensile), profiles (HEA/HEB/HEM/IPE/UPN/UPE/UB/UC/PFC/HSS/CHS/RHS/SHS, W310X38.7,
#: L2-1/2X2-1/2X1/4), angles and cleats, and the word itself.
STEEL_WORDS = re.compile(
    r"(?<![a-z0-9])(s\d{3}[a-z0-9]*|st ?\d{2}(?:-\d)?|q\d{3}|a992|a36|a572|\d{2}-\d{3}|he[abm]\s?\d+|ipe\s?\d+|"
    r"up[ne]\s?\d+|u[bc]\s?\d+|pfc|hss|chs|rhs|shs|w\d+x\d|l\d[\d/.-]*x|angle|cleat|steel|staal|stahl|acier|metal)",
    re.IGNORECASE,
)
#: Timber in a material or element name: grades (C16, C24, GL24h, D30) and words.
TIMBER_WORDS = re.compile(
    r"(?<![a-z0-9])(c(?:14|16|18|20|22|24|27|30)(?![/\d])|gl\d{2}[hc]?|d(?:30|35|40|50|60|70)(?![/\d])|timber|wood|"
    r"holz|hout|bois|lumber|rafter|sparren|joist|balken|stud|glulam|clt)",
    re.IGNORECASE,
)


class Assumption(NamedTuple):
    """The material assumed for an element: ``label`` (steel, timber, concrete), kg/m3, and why."""

    label: str
    density_kg_m3: float
    why: str


def assumed_material(element: Element, fallback_kg_m3: float = DEFAULT_DENSITY_KG_M3) -> Assumption:
    """The material ``--unknown-weight auto`` assumes for ``element``, by class, material and name."""
    if element.ifc_class in STEEL_CLASSES:
        return Assumption("steel", STEEL_DENSITY_KG_M3, f"{element.ifc_class} is steel")
    for what, text in (("material", element.material), ("name", element.name)):
        if text and (match := STEEL_WORDS.search(text)):
            return Assumption("steel", STEEL_DENSITY_KG_M3, f"{what} '{match.group(0)}' says steel")
        if text and (match := TIMBER_WORDS.search(text)):
            return Assumption("timber", TIMBER_DENSITY_KG_M3, f"{what} '{match.group(0)}' says timber")
    label = "concrete" if fallback_kg_m3 == DEFAULT_DENSITY_KG_M3 else "default"
    return Assumption(label, fallback_kg_m3, "nothing says otherwise")


@dataclass(frozen=True)
class UnknownWeightRule:
    """``density_kg_m3`` to assume, or None to refuse elements without a weight. ``by_material``: choose
    the density per element (:func:`assumed_material`), ``density_kg_m3`` being the fallback."""

    density_kg_m3: float | None = DEFAULT_DENSITY_KG_M3
    by_material: bool = True

    @classmethod
    def parse(cls, text: str) -> "UnknownWeightRule":
        """``"auto"``, ``"refuse"`` or a density in kg/m3 (an argparse ``type``: bad text is one sentence)."""
        word = text.strip().lower()
        if word == REFUSE:
            return cls(None, False)
        if word == AUTO:
            return cls()
        try:
            density = float(text)
        except ValueError:
            density = math.nan
        low, high = DENSITY_RANGE_KG_M3
        if not (low <= density <= high):
            raise argparse.ArgumentTypeError(
                f"expected 'auto', 'refuse' or a density in kg/m3 between {low:g} and {high:g} (e.g. 2400), got {text!r}"
            )
        return cls(density, False)

    @property
    def text(self) -> str:
        """The rule as ``--unknown-weight`` text that parses back to it: auto, refuse or the density."""
        if self.density_kg_m3 is None:
            return REFUSE
        if self.by_material and self.density_kg_m3 == DEFAULT_DENSITY_KG_M3:
            return AUTO
        return repr(self.density_kg_m3)

    def assumption(self, element: Element) -> Assumption | None:
        """The material assumed for ``element`` under this rule (None when the rule refuses)."""
        if self.density_kg_m3 is None:
            return None
        if self.by_material:
            return assumed_material(element, self.density_kg_m3)
        return Assumption("given", self.density_kg_m3, "--unknown-weight")

    def __str__(self) -> str:
        if self.density_kg_m3 is None:
            return REFUSE
        if self.by_material:
            return (f"assume volume x {self.density_kg_m3:g} kg/m3, or by class and material steel "
                    f"{STEEL_DENSITY_KG_M3:g} (fasteners, plates, steel names) and timber {TIMBER_DENSITY_KG_M3:g}")
        return f"assume volume x {self.density_kg_m3:g} kg/m3"


def add_unknown_weight_option(parser: argparse.ArgumentParser) -> None:
    """Add ``--unknown-weight auto|DENSITY|refuse`` (default auto) to a sub-command."""
    parser.add_argument(
        "--unknown-weight", type=UnknownWeightRule.parse, default=UnknownWeightRule(), metavar="auto|KG_M3|refuse",
        help=f"elements whose weight the model does not give: 'auto' (default) assumes body volume x a density "
        f"by class and material (steel {STEEL_DENSITY_KG_M3:g} kg/m3 for bolts, welds, plates and steel names, "
        f"timber {TIMBER_DENSITY_KG_M3:g} for timber names, else concrete {DEFAULT_DENSITY_KG_M3:g}); a density "
        "in kg/m3 for all of them; or 'refuse' to stop and list them",
    )


@dataclass
class UnknownWeights:
    """What the rule did: the rule and, per element, the mass assumed (kg, None when it has no volume),
    the count per class and per material assumed (e.g. ``{"steel 7850 kg/m3": 28}``)."""

    rule: UnknownWeightRule
    assumed: dict[str, float | None] = field(default_factory=dict)
    classes: Counter = field(default_factory=Counter)
    materials: Counter = field(default_factory=Counter)

    def message(self) -> str | None:
        """One line for the terminal, or None when every element had a weight."""
        if not self.assumed:
            return None
        by_class = ", ".join(f"{n} {c}" for c, n in self.classes.most_common())
        no_volume = sum(1 for kg in self.assumed.values() if kg is None)
        tail = f"; {no_volume} of them have no closed volume and stay unknown" if no_volume else ""
        if self.rule.by_material and self.materials:
            how = "assumed volume x " + ", ".join(f"{m} for {n}" for m, n in self.materials.most_common())
        else:
            how = str(self.rule)
        return f"{len(self.assumed)} element(s) have no weight in the model ({by_class}): {how} (--unknown-weight){tail}"

    def as_dict(self) -> dict:
        """JSON-ready: ``{"rule", "count", "by_class", "by_material", "elements": {GlobalId: kg or None}}``."""
        return {
            "rule": str(self.rule),
            "count": len(self.assumed),
            "by_class": dict(self.classes.most_common()),
            "by_material": dict(self.materials.most_common()),
            "elements": {gid: (round(kg, 3) if kg is not None else None) for gid, kg in self.assumed.items()},
        }


def apply_unknown_weight_rule(elements: Iterable[Element], rule: UnknownWeightRule, source: str) -> UnknownWeights:
    """Give every element of unknown weight its assumed mass (in place), or refuse them all at once.

    Elements whose weight the model gives are untouched; those assumed before (by this rule, when the
    model was loaded) are reported again as they are, so applying the rule twice changes nothing and
    gives the same report. ``source`` names the model in the refusal. Raises InputError with the count by
    class when ``rule`` is refuse and any element has no weight.
    """
    elements = list(elements)
    unknown = [e for e in elements if e.weight_source is WeightSource.UNKNOWN]
    if unknown and rule.density_kg_m3 is None:
        by_class = ", ".join(f"{n} {c}" for c, n in Counter(e.ifc_class for e in unknown).most_common())
        raise InputError(
            f"{source}: {len(unknown)} element(s) have no weight in the model ({by_class}, e.g. {unknown[0].global_id}) "
            "and --unknown-weight is refuse; give a density such as --unknown-weight 2400, or leave them out with --exclude"
        )
    report = UnknownWeights(rule)
    for element in elements:
        if element.weight_source is WeightSource.ASSUMED:
            report.assumed[element.global_id] = element.weight_kg
            report.classes[element.ifc_class] += 1
            report.materials[element.weight_assumed_as or "assumed"] += 1
            continue
        if element.weight_source is not WeightSource.UNKNOWN:
            continue
        report.classes[element.ifc_class] += 1
        assumption = rule.assumption(element)
        volume = element.volume_m3
        if volume > 0 and assumption is not None:
            label = f"{assumption.label} {assumption.density_kg_m3:g} kg/m3"
            element.weight_kg = volume * assumption.density_kg_m3
            element.weight_source = WeightSource.ASSUMED
            element.weight_assumed_as = label
            element.weight_basis = (f"assumed: {volume:.4g} m3 x {assumption.density_kg_m3:g} kg/m3, {assumption.label} "
                                    f"({assumption.why}; --unknown-weight); {element.weight_basis}")
            report.assumed[element.global_id] = element.weight_kg
            report.materials[label] += 1
        else:
            report.assumed[element.global_id] = None
    return report
