"""The one rule for elements whose weight the model does not give, shared by convert, simulate and rcan.

``--unknown-weight`` takes either a density in kg/m3 (the element's mass is then its body volume times
that density, marked :attr:`~bimrobot.bim.model.WeightSource.ASSUMED`) or ``refuse`` (the command stops
and lists, by class, the elements without a weight). The default, :data:`DEFAULT_DENSITY_KG_M3`, is
normal-weight concrete (EN 1991-1-1, 24 kN/m3): the heaviest common structural material after steel,
so a robot sized by it is not undersized for concrete, masonry or timber. Steel members nearly always
carry a weight or a steel material in the model.

Every command reports the rule and what it did in the same words (:meth:`UnknownWeights.message`) and
the same JSON (:meth:`UnknownWeights.as_dict`).
"""

from __future__ import annotations

import argparse
import math
from collections import Counter
from dataclasses import dataclass, field
from typing import Iterable

from bimrobot.bim.model import Element, WeightSource
from bimrobot.errors import InputError

DEFAULT_DENSITY_KG_M3 = 2400.0
REFUSE = "refuse"
#: Densities accepted for the assumption, kg/m3 (aerated foam to tungsten, with margin).
DENSITY_RANGE_KG_M3 = (10.0, 20000.0)


@dataclass(frozen=True)
class UnknownWeightRule:
    """``density_kg_m3`` to assume, or None to refuse elements without a weight."""

    density_kg_m3: float | None = DEFAULT_DENSITY_KG_M3

    @classmethod
    def parse(cls, text: str) -> "UnknownWeightRule":
        """``"refuse"`` or a density in kg/m3 (an argparse ``type``: bad text is one sentence)."""
        if text.strip().lower() == REFUSE:
            return cls(None)
        try:
            density = float(text)
        except ValueError:
            density = math.nan
        low, high = DENSITY_RANGE_KG_M3
        if not (low <= density <= high):
            raise argparse.ArgumentTypeError(
                f"expected 'refuse' or a density in kg/m3 between {low:g} and {high:g} (e.g. 2400), got {text!r}"
            )
        return cls(density)

    def __str__(self) -> str:
        if self.density_kg_m3 is None:
            return REFUSE
        return f"assume volume x {self.density_kg_m3:g} kg/m3"


def add_unknown_weight_option(parser: argparse.ArgumentParser) -> None:
    """Add ``--unknown-weight DENSITY|refuse`` (default 2400 kg/m3) to a sub-command."""
    parser.add_argument(
        "--unknown-weight", type=UnknownWeightRule.parse, default=UnknownWeightRule(), metavar="KG_M3|refuse",
        help=f"elements whose weight the model does not give: assume body volume x this density in kg/m3 "
        f"(default {DEFAULT_DENSITY_KG_M3:g}, concrete; 7850 for steel) or 'refuse' to stop and list them",
    )


@dataclass
class UnknownWeights:
    """What the rule did: the rule and, per element, the mass assumed (kg, None when it has no volume)."""

    rule: UnknownWeightRule
    assumed: dict[str, float | None] = field(default_factory=dict)
    classes: Counter = field(default_factory=Counter)

    def message(self) -> str | None:
        """One line for the terminal, or None when every element had a weight."""
        if not self.assumed:
            return None
        by_class = ", ".join(f"{n} {c}" for c, n in self.classes.most_common())
        no_volume = sum(1 for kg in self.assumed.values() if kg is None)
        tail = f"; {no_volume} of them have no closed volume and stay unknown" if no_volume else ""
        return (
            f"{len(self.assumed)} element(s) have no weight in the model ({by_class}): "
            f"{self.rule} (--unknown-weight){tail}"
        )

    def as_dict(self) -> dict:
        """JSON-ready: ``{"rule", "count", "by_class", "elements": {GlobalId: kg or None}}``."""
        return {
            "rule": str(self.rule),
            "count": len(self.assumed),
            "by_class": dict(self.classes.most_common()),
            "elements": {gid: (round(kg, 3) if kg is not None else None) for gid, kg in self.assumed.items()},
        }


def apply_unknown_weight_rule(elements: Iterable[Element], rule: UnknownWeightRule, source: str) -> UnknownWeights:
    """Give every element of unknown weight its assumed mass (in place), or refuse them all at once.

    Elements whose weight is already known (or already assumed) are untouched, so applying the same
    rule twice changes nothing. ``source`` names the model in the refusal. Raises InputError with the
    count by class when ``rule`` is refuse and any element has no weight.
    """
    unknown = [e for e in elements if e.weight_source is WeightSource.UNKNOWN]
    report = UnknownWeights(rule, classes=Counter(e.ifc_class for e in unknown))
    if not unknown:
        return report
    if rule.density_kg_m3 is None:
        by_class = ", ".join(f"{n} {c}" for c, n in report.classes.most_common())
        raise InputError(
            f"{source}: {len(unknown)} element(s) have no weight in the model ({by_class}, e.g. {unknown[0].global_id}) "
            "and --unknown-weight is refuse; give a density such as --unknown-weight 2400, or leave them out with --exclude"
        )
    for element in unknown:
        volume = element.volume_m3
        if volume > 0:
            element.weight_kg = volume * rule.density_kg_m3
            element.weight_source = WeightSource.ASSUMED
            element.weight_basis = f"assumed: {volume:.4g} m3 x {rule.density_kg_m3:g} kg/m3 (--unknown-weight); {element.weight_basis}"
            report.assumed[element.global_id] = element.weight_kg
        else:
            report.assumed[element.global_id] = None
    return report
