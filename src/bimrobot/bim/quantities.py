"""Weights: where an element's mass in kg comes from, best source first.

1. An ``IfcQuantityWeight`` in one of the element's quantity sets (``NetWeight`` preferred, then
   ``GrossWeight``, then any other weight quantity), scaled by the file's mass unit. Zero is "not given".
2. A weight property in a property set, by name (see :data:`WEIGHT_PROPERTY_NAMES`), e.g. Revit's
   ``Structural/Exact Weight`` or Tekla's ``Tekla Reinforcement/Total Weight`` (``IfcMassMeasure``).
   Per-length values such as Revit's ``Nominal Weight`` (kg/m) are deliberately not on the list.
3. Mesh volume (m3) x the density (kg/m3) of the element's material *structure*
   (:class:`MaterialDensities`): a layer set is weighted by layer thickness, a constituent set by
   fraction, a profile set, a material list or a single material gives one density. A material's own
   ``MassDensity`` property (``Pset_MaterialCommon``; IFC2X3 ``IfcGeneralMaterialProperties``) is
   preferred when it is physically possible; otherwise its name is looked up in :data:`DENSITY_TABLE`.
4. Otherwise unknown (``None``): a material the table does not know, a layer of unknown material, a
   material list of different densities, or an element made only of air or a stud layer. Never a guess.

Every element keeps a short ``weight_basis`` text saying which of these gave its mass and how.
:func:`weight_check` says when a weight is not plausible (implied density outside
:data:`PLAUSIBLE_DENSITY_KG_M3`, or a model-given weight that disagrees with volume x material density by
more than :data:`DISAGREEMENT_FACTOR`).
"""

from __future__ import annotations

import re
import unicodedata
from dataclasses import dataclass
from typing import Callable, NamedTuple

from bimrobot.bim.model import WeightSource

#: Implied densities (kg/m3) that a building element can have: below, lighter than most insulation
#: boards; above, heavier than steel (7,850; stainless 7,900-8,000; Tekla writes 8,000.4 for its steel
#: meshes, whose fillets and holes it leaves out of the volume). Outside this range a weight is listed as
#: suspect, unless the element's own material is that light or heavy (:func:`plausible_density_range`).
PLAUSIBLE_DENSITY_KG_M3 = (50.0, 8100.0)
#: Margin around a material's own density in which an implied density stays plausible (x and /).
MATERIAL_DENSITY_MARGIN = 1.1
#: A weight from the model that differs from volume x material density by more than this factor is suspect.
DISAGREEMENT_FACTOR = 3.0
#: A material's own MassDensity property is used when it lies in this range (kg/m3): air to osmium.
#: ArchiCAD writes 0 for "not set".
PROPERTY_DENSITY_RANGE_KG_M3 = (1.0, 22600.0)


@dataclass(frozen=True)
class DensityEntry:
    """One row of the density table.

    ``label``: what the material is (shown in weight bases). ``density``: kg/m3. ``names``: lower-case
    words or phrases matched as whole words in a material name (a CJK name is matched as a substring,
    since Chinese and Japanese write no spaces). ``void``: the material is mostly empty (air, a cavity,
    a stud layer): it weighs (almost) nothing in a layer set and cannot be the body of an element alone.
    """

    label: str
    density: float
    names: tuple[str, ...]
    void: bool = False


def _entry(label: str, density: float, *names: str, void: bool = False) -> DensityEntry:
    return DensityEntry(label, density, (label, *names) if label not in names else names, void)


#: Densities in kg/m3 by material name, in English with the Dutch, German, French and Chinese names
#: that real models use. Sources, rounded to typical values:
#:
#: - EN 1991-1-1:2002 Annex A (unit weights in kN/m3, read as 100 kg/m3 per kN/m3 as the code's own
#:   examples do): Table A.1 concrete (normal 24, reinforced +1, lightweight LC1.0-LC2.0 = 9-20) and
#:   mortars (cement 19-23, gypsum 12-18, lime 12-18); Table A.2 masonry stone (granite 27-30, basalt
#:   27-31, limestone 20-29, sandstone 21-27, marble 28, slate 28); Table A.3 timber (softwood C14-C40
#:   3.5-5.0, hardwood D30-D70 6.4-10.8, glulam 3.7-4.4, plywood 5-7, particleboard 7-8, fibreboard
#:   4-10); Table A.4 metals (steel 77-78.5, aluminium 27, copper 87-89, cast iron 71-72, wrought iron 76,
#:   lead 112-114, zinc 71-72, brass and bronze 83-85); Table A.5 glass (25), acrylic sheet (12), foam
#:   glass (1.4); Tables A.6-A.7 asphalt (24-25), mastic asphalt (18-22), sand (15-16 dry), gravel
#:   (15-20), puddle clay (18.5-19.5), hardcore (18.5-19.5).
#: - EN ISO 10456:2007 Table 3 (design densities of building materials) where EN 1991-1-1 is silent:
#:   gypsum plasterboard 900, gypsum plaster 1200, cement-sand render 1800, ceramic tile 2300, bitumen
#:   1050, PVC 1390, polyethylene 980, rubber 1200, linoleum 1200, EPS 20 (10-50), XPS 35 (20-65),
#:   PUR/PIR 30 (28-55), mineral wool 10-200 (100 taken: slabs used in walls and roofs), OSB 650,
#:   MDF 750, cork 120.
#: - Masonry units (EN 771): clay brick 1800, calcium-silicate (sand-lime) 1800, autoclaved aerated
#:   concrete 500 (300-1000).
#: - Voids: air 0; a metal stud layer is about 20 kg/m3 of the layer (0.6 mm C-studs 50/92/50 at
#:   600 mm centres: 115 mm2 of steel per 600 mm x 92 mm of layer = 0.2 % x 7850), a timber stud layer
#:   about 50 (38 x 89 mm studs at 400 mm centres: 9.5 % x 500). Generic "insulation" is taken as 50.
DENSITY_TABLE: tuple[DensityEntry, ...] = (
    # concrete and mortar
    _entry("concrete", 2400, "beton", "béton", "normal weight concrete", "cast in place concrete", "in situ concrete",
           "ortbeton", "normalbeton", "betong", "hormigón", "hormigon", "calcestruzzo", "混凝土", "砼"),
    _entry("reinforced concrete", 2500, "stahlbeton", "gewapend beton", "prestressed concrete", "spannbeton",
           "precast concrete", "prefab concrete", "prefab beton", "prefabricated concrete", "fertigteilbeton",
           "béton armé", "beton arme", "rc", "钢筋混凝土"),
    _entry("lightweight concrete", 1600, "light weight concrete", "leichtbeton", "lichtbeton", "licht beton",
           "lightweight aggregate concrete", "轻质混凝土"),
    _entry("aerated concrete", 500, "autoclaved aerated concrete", "aac", "porenbeton", "gasbeton", "cellenbeton",
           "cellular concrete", "ytong", "加气混凝土"),
    _entry("cement mortar", 2100, "mortar", "mörtel", "moertel", "mortel", "specie", "cement", "zement", "砂浆"),
    _entry("gypsum mortar", 1500, "lime mortar", "kalkmörtel", "gipsmörtel"),
    _entry("screed", 2100, "cement screed", "sand cement screed", "estrich", "zementestrich", "anhydritestrich",
           "dekvloer", "cementdekvloer", "zandcement", "chape"),
    _entry("render", 1800, "cement render", "stucco", "außenputz", "aussenputz", "buitenpleister", "crépi", "enduit"),
    _entry("plaster", 1200, "gypsum plaster", "putz", "innenputz", "gipsputz", "pleister", "pleisterwerk", "stuc",
           "plâtre", "platre"),
    # boards
    _entry("plasterboard", 900, "plaster board", "gypsum board", "gypsum wall board", "gypsum wallboard",
           "gypsum plasterboard", "gypsum plaster board", "wallboard", "wall board", "drywall", "dry wall",
           "gipskarton", "gipskartonplatte", "gipskartonplatten", "gipsplaat", "gipskartonplaat", "gyproc",
           "plaque de plâtre", "placo", "石膏板"),
    _entry("gypsum", 1000, "gips", "gypse", "石膏"),
    _entry("gypsum fibreboard", 1150, "gypsum fiberboard", "gipsfaserplatte", "fermacell"),
    _entry("cement board", 1200, "cement bonded particleboard", "fibre cement", "fiber cement", "vezelcement",
           "faserzement", "eternit"),
    # masonry
    _entry("brick", 1800, "clay brick", "bricks", "brickwork", "baksteen", "bakstenen", "metselsteen", "ziegel",
           "mauerziegel", "backstein", "brique", "砖"),
    _entry("clinker brick", 2000, "klinker", "klinkers", "engineering brick"),
    _entry("sand-lime brick", 1800, "sand lime brick", "calcium silicate", "calcium silicate brick", "kalksandstein",
           "kalkzandsteen", "kzs"),
    _entry("masonry", 1900, "metselwerk", "mauerwerk", "maçonnerie", "maconnerie", "blockwork", "block",
           "blocks", "cmu", "concrete masonry unit", "concrete block", "betonblok", "betonstein", "砌体"),
    # natural stone
    _entry("stone", 2600, "natural stone", "natuursteen", "naturstein", "pierre", "石材"),
    _entry("granite", 2800, "graniet", "granit", "花岗岩"),
    _entry("basalt", 2900, "basalte"),
    _entry("limestone", 2500, "kalksteen", "kalkstein", "hardsteen", "blue stone", "bluestone", "travertine"),
    _entry("sandstone", 2400, "zandsteen", "sandstein"),
    _entry("marble", 2800, "marmer", "marmor", "marbre", "大理石"),
    _entry("slate", 2800, "leisteen", "schiefer", "ardoise"),
    # ceramics and glass
    _entry("ceramic tile", 2300, "ceramic", "ceramics", "ceramic tiles", "porcelain", "stoneware", "keramiek",
           "keramik", "fliese", "fliesen", "tegel", "tegels", "wandtegel", "vloertegel", "céramique", "瓷砖"),
    _entry("roof tile", 1900, "roof tiles", "clay tile", "dachziegel", "dakpan", "dakpannen", "tuile"),
    _entry("ceiling tile", 300, "acoustic tile", "acoustic ceiling tile", "mineral fibre tile", "systeemplafond"),
    _entry("glass", 2500, "glas", "glazing", "verre", "float glass", "safety glass", "玻璃"),
    _entry("foam glass", 140, "cellular glass", "schaumglas", "foamglas", "cellenglas"),
    # metals
    _entry("steel", 7850, "structural steel", "stahl", "baustahl", "staal", "constructiestaal", "constructief staal",
           "acier", "acero", "metal", "metall", "metaal", "iron", "rebar", "reinforcement", "reinforcing steel",
           "betonstahl", "bewehrung", "wapening", "wapeningsstaal", "betonstaal", "armature", "钢", "钢材", "金属",
           "钢筋"),
    _entry("stainless steel", 7900, "stainless", "edelstahl", "rvs", "roestvrij staal", "inox", "不锈钢"),
    _entry("cast iron", 7200, "gusseisen", "gietijzer", "fonte", "铸铁"),
    _entry("aluminium", 2700, "aluminum", "alu", "aluminium alloy", "aluminum alloy", "铝", "铝合金"),
    _entry("copper", 8900, "koper", "kupfer", "cuivre", "铜"),
    _entry("brass", 8400, "bronze", "messing", "brons"),
    _entry("zinc", 7200, "zink", "titanium zinc", "titanzink"),
    _entry("lead", 11300, "lood", "blei", "plomb", "铅"),
    # timber
    _entry("timber", 500, "wood", "softwood", "holz", "hout", "bois", "madera", "lumber", "vurenhout", "naaldhout",
           "spruce", "pine", "fir", "木", "木材"),
    _entry("hardwood", 700, "oak", "eiken", "eiche", "beech", "beuken", "buche", "hardhout", "laubholz", "parquet",
           "parket"),
    _entry("glulam", 450, "glued laminated timber", "glue laminated timber", "brettschichtholz", "gelamineerd hout",
           "bsh"),
    _entry("cross laminated timber", 470, "clt", "brettsperrholz", "kruislaaghout", "xlam"),
    _entry("laminated veneer lumber", 500, "lvl", "furnierschichtholz"),
    _entry("plywood", 600, "multiplex", "sperrholz", "triplex", "contreplaqué", "胶合板"),
    _entry("osb", 650, "oriented strand board", "osb board"),
    _entry("particleboard", 700, "particle board", "chipboard", "spaanplaat", "spanplatte", "spanplaat"),
    _entry("mdf", 750, "medium density fibreboard", "medium density fiberboard"),
    _entry("hardboard", 1000, "fibreboard", "fiberboard", "hardfaserplatte", "hardboardplaat"),
    # plastics, membranes, bitumen
    _entry("pvc", 1390, "polyvinyl chloride", "polyvinylchloride", "upvc", "pvc u"),
    _entry("polyethylene", 980, "pe", "hdpe", "ldpe", "polyethyleen", "polyethylen", "pe foil", "pe folie"),
    _entry("acrylic", 1200, "pmma", "acrylic glass", "plexiglas", "polycarbonate", "pc sheet"),
    _entry("rubber", 1200, "hard rubber", "gummi", "caoutchouc", "neoprene", "elastomer", "epdm"),
    _entry("linoleum", 1200, "marmoleum"),
    _entry("bitumen", 1050, "bituminous", "bitumineus", "bitumineuze", "bitume"),
    _entry("bitumen membrane", 1100, "bituminous membrane", "bitumen sheet", "roofing felt", "dakbedekking",
           "bitumenbahn", "dachbahn", "roofing membrane", "waterproofing membrane", "membrane", "membraan",
           "vapour barrier", "vapor barrier", "damp proof membrane", "damp proof course", "dpc", "dampscherm",
           "dampremmende folie", "dampfsperre", "dampfbremse", "folie"),
    _entry("asphalt", 2400, "asphaltic concrete", "asfalt", "asphalte", "asfaltbeton", "gussasphalt", "gietasfalt"),
    _entry("mastic asphalt", 2000),
    # insulation
    _entry("insulation", 50, "thermal insulation", "isolatie", "thermische isolatie", "dämmung", "daemmung",
           "wärmedämmung", "waermedaemmung", "dämmstoff", "isolation", "isolant", "isolierung", "保温", "保温层"),
    _entry("mineral wool", 100, "mineralwool", "minerale wol", "mineralwolle", "rock wool", "rockwool", "stone wool",
           "steenwol", "steinwolle", "laine de roche", "岩棉"),
    _entry("glass wool", 30, "glasswool", "glaswol", "glaswolle", "laine de verre", "玻璃棉"),
    _entry("expanded polystyrene", 20, "eps", "styropor", "polystyrene", "polystyreen", "polystyrol", "eps insulation",
           "聚苯板"),
    _entry("extruded polystyrene", 35, "xps", "styrodur", "xps insulation"),
    _entry("polyurethane", 30, "pur", "pir", "polyisocyanurate", "pur pir", "polyurethaan", "polyurethan",
           "pu foam", "pur foam"),
    _entry("wood fibre insulation", 150, "wood fiber insulation", "holzfaser", "holzfaserdämmung", "houtvezel",
           "wood fibre board"),
    _entry("cellulose insulation", 50, "cellulose", "zellulose", "cellulosevlokken"),
    _entry("cork", 120, "kurk", "kork", "liège"),
    _entry("sandwich panel", 120, "insulated panel", "insulated metal panel", "sandwichpaneel", "sandwichelement",
           "sandwichplatte", "panneau sandwich"),  # 2 x 0.5 mm steel faces on 100 mm PIR: 12 kg/m2
    # earth and fill
    _entry("sand", 1600, "zand", "dry sand", "sable"),
    _entry("gravel", 1800, "grind", "kies", "schotter", "ballast", "crushed stone", "hardcore", "puin", "gravier",
           "砾石"),
    _entry("soil", 1800, "earth", "grond", "aarde", "erde", "erdreich", "terre", "topsoil", "泥土"),
    _entry("clay", 1900, "puddle clay", "klei", "leem", "lehm", "loam", "argile", "粘土"),
    # voids: weigh (almost) nothing in a layer set
    _entry("air", 0, "air gap", "air space", "air layer", "airspace", "air cavity", "cavity", "luftschicht", "luft",
           "hohlraum", "luchtspouw", "luchtlaag", "spouw", "lame d air", "void", "空气", "空气层", void=True),
    _entry("metal stud layer", 20, "stud layer", "metal stud", "metal studs", "steel stud", "steel studs",
           "metal stud framing", "ständerwerk", "metalen stijlen", "metal - stud layer", void=True),
    _entry("timber stud layer", 50, "wood stud layer", "timber stud", "wood stud", "timber studs", "wood studs",
           "timber frame", "holzständer", "houtskeletbouw", void=True),
)

#: Grades written without their material's name: matched as one whole token (lower case).
GRADE_PATTERNS: tuple[tuple[re.Pattern, str], ...] = (
    (re.compile(r"lc\d{1,3}/\d{1,3}"), "lightweight concrete"),  # EN 206 lightweight class, e.g. LC25/28
    (re.compile(r"c\d{1,3}/\d{1,3}"), "concrete"),  # EN 206 strength class, e.g. C30/37, C45/55
    (re.compile(r"s(?:185|235|275|355|420|450|460|500|550|620|690|890|960)[a-z0-9+]*"), "steel"),  # EN 10025: S235JR
    (re.compile(r"st(?:33|37|44|52)"), "steel"),  # old DIN 17100, e.g. St37, St52-3
    (re.compile(r"fe(?:360|430|510)[a-d]?|fe[be]\d{3}[a-z]?"), "steel"),  # Fe360B, FeE355; FeB500 (rebar)
    (re.compile(r"b(?:st)?[45]\d0[a-c]?"), "steel"),  # rebar: B500B, BSt500, B450C
    (re.compile(r"q(?:195|235|275|345|355|390|420|460)[a-e]?"), "steel"),  # GB/T 700 and 1591: Q235B, Q345
    (re.compile(r"a(?:36|572|588|992)"), "steel"),  # ASTM structural steels
    (re.compile(r"gl\d{2}[hc]"), "glulam"),  # EN 14080, e.g. GL24h
)

#: Property names (case-insensitive) that hold an element's total mass, best first.
WEIGHT_PROPERTY_NAMES: tuple[str, ...] = (
    "exact weight", "netweight", "net weight", "total weight", "weight", "mass", "grossweight", "gross weight",
)  # fmt: skip

#: Quantity names, best first, among an element's IfcQuantityWeight entries.
WEIGHT_QUANTITY_NAMES: tuple[str, ...] = ("netweight", "grossweight")

_BY_LABEL = {entry.label: entry for entry in DENSITY_TABLE}
_TOKEN = re.compile(r"l?c\d{1,3}/\d{1,3}|[^\W_]+")
_CJK = re.compile(r"[\u3040-\u30ff\u3400-\u4dbf\u4e00-\u9fff\uac00-\ud7af]")


def _normalise(text: str) -> str:
    """Lower-case words separated by single spaces (punctuation, '_', '-', '/' split words)."""
    return " ".join(_TOKEN.findall(unicodedata.normalize("NFC", text).lower()))


def _phrase_index() -> tuple[dict[str, DensityEntry], dict[str, DensityEntry]]:
    words: dict[str, DensityEntry] = {}
    cjk: dict[str, DensityEntry] = {}
    for entry in DENSITY_TABLE:
        for name in entry.names:
            key = _normalise(name)
            (cjk if _CJK.search(key) else words).setdefault(key, entry)
    return words, cjk


_PHRASES, _CJK_PHRASES = _phrase_index()


class NameMatch(NamedTuple):
    """A material name's table entry and the words of the name that matched it."""

    entry: DensityEntry
    matched: str


def match_material(name: str | None) -> NameMatch | None:
    """The density-table entry for a material name, or None when no entry matches.

    Names are matched by whole words (``"metallic paint"`` is not ``metal``), grades by pattern
    (``C45/55`` is concrete, ``S235JR`` steel). When several entries match:

    1. an entry whose words lie inside a longer match loses to it (``"reinforced concrete"`` before
       ``"concrete"``, ``"metal stud layer"`` before ``"metal"``);
    2. a solid material beats a void (air, cavity, stud layer) named beside it
       (``"Plasterboard, Metal - Stud Layer"`` is plasterboard: the boards carry the mass);
    3. then the longest entry, then the one named first.
    """
    if not name:
        return None
    text = _normalise(name)
    if not text:
        return None
    tokens = text.split(" ")
    found: list[tuple[int, int, int, DensityEntry]] = []  # (start, end, words, entry) as character spans
    starts = []
    position = 0
    for token in tokens:
        starts.append(position)
        position += len(token) + 1
    for i in range(len(tokens)):
        for j in range(len(tokens), i, -1):  # every run of whole words
            entry = _PHRASES.get(" ".join(tokens[i:j]))
            if entry is not None:
                found.append((starts[i], starts[j - 1] + len(tokens[j - 1]), j - i, entry))
        for pattern, label in GRADE_PATTERNS:
            if pattern.fullmatch(tokens[i]):
                found.append((starts[i], starts[i] + len(tokens[i]), 1, _BY_LABEL[label]))
                break
    for phrase, entry in _CJK_PHRASES.items():  # no spaces between CJK words: substrings
        for hit in re.finditer(re.escape(phrase), text):
            found.append((hit.start(), hit.end(), len(phrase), entry))
    if not found:
        return None

    def inside_longer(span) -> bool:
        return any(o[0] <= span[0] and span[1] <= o[1] and (o[1] - o[0]) > (span[1] - span[0]) for o in found)

    kept = [span for span in found if not inside_longer(span)]
    solid = [span for span in kept if not span[3].void]
    start, end, _, entry = max(solid or kept, key=lambda s: (s[2], -s[0]))
    return NameMatch(entry, text[start:end])


def density_of(material: str | None) -> float | None:
    """Density in kg/m3 for a material name by :func:`match_material`, or None when the table has no entry."""
    match = match_material(material)
    return match.entry.density if match else None


# ---- material structure ---------------------------------------------------------------------------


@dataclass(frozen=True)
class MaterialDensity:
    """The density of an element's material definition.

    ``density_kg_m3``: None when unknown. ``basis``: how it was found, or why it is unknown, in words
    (e.g. ``"layers: Plasterboard 25 mm 900 + Metal Stud Layer 92 mm 20 = 221 kg/m3"``). ``names``: the
    material names, in the order of the definition (``Element.material`` joins them). ``solid``: some
    part of it is a solid material (not only air or a stud layer).
    """

    density_kg_m3: float | None
    basis: str
    names: tuple[str, ...] = ()
    solid: bool = True

    @property
    def body_density_kg_m3(self) -> float | None:
        """The density of an element body made of this (None when unknown, or only air or a stud layer)."""
        if self.density_kg_m3 is None or not self.solid or self.density_kg_m3 <= 0:
            return None
        return self.density_kg_m3


NO_MATERIAL = MaterialDensity(None, "no material")


def _fmt(value: float) -> str:
    return f"{value:.4g}" if value < 100 else f"{value:.0f}"


class MaterialDensities:
    """Densities (kg/m3) of an IFC file's material definitions, each walked once (cached by step id).

    ``of(product)`` reads the product's material as :func:`ifcopenshell.util.element.get_material` gives
    it (the occurrence's, else its type's; usages kept so a layer set usage is seen as such).
    ``MassDensity`` properties are read in kg/m3, the IFC default unit of ``IfcMassDensityMeasure``.
    """

    def __init__(self, ifc) -> None:
        import ifcopenshell.util.unit

        self.ifc = ifc
        metres_per_unit = ifcopenshell.util.unit.calculate_unit_scale(ifc)
        self.mm_per_unit = ifcopenshell.util.unit.convert(metres_per_unit, None, "METRE", "MILLI", "METRE")
        self._cache: dict[int, MaterialDensity] = {}

    def of(self, product) -> MaterialDensity:
        """The density of the product's material definition (NO_MATERIAL when it has none)."""
        import ifcopenshell.util.element

        try:
            definition = ifcopenshell.util.element.get_material(product, should_skip_usage=False, should_inherit=True)
        except Exception:  # a malformed material association must not stop the import
            return MaterialDensity(None, "its material association cannot be read")
        return NO_MATERIAL if definition is None else self.definition(definition)

    def definition(self, definition) -> MaterialDensity:
        """The density of any material definition (material, layer/profile/constituent set, usage, list)."""
        key = definition.id()
        if key not in self._cache:
            self._cache[key] = self._walk(definition)
        return self._cache[key]

    def _walk(self, definition) -> MaterialDensity:
        kind = definition.is_a()
        if kind == "IfcMaterial":
            return self._material(definition)
        if definition.is_a("IfcMaterialLayerSetUsage"):
            return self.definition(definition.ForLayerSet)
        if definition.is_a("IfcMaterialProfileSetUsage"):
            return self.definition(definition.ForProfileSet)
        if kind == "IfcMaterialLayerSet":
            return self._layers(definition.MaterialLayers or ())
        if definition.is_a("IfcMaterialLayer"):
            return self._layers((definition,))
        if kind == "IfcMaterialConstituentSet":
            return self._constituents(definition.MaterialConstituents or ())
        if kind == "IfcMaterialProfileSet":
            parts = [self._part(p.Material) for p in definition.MaterialProfiles or ()]
            return self._same("profiles", parts)
        if definition.is_a("IfcMaterialProfile") or definition.is_a("IfcMaterialConstituent"):
            return self._part(definition.Material)
        if kind == "IfcMaterialList":
            return self._same("material list", [self._part(m) for m in definition.Materials or ()])
        return MaterialDensity(None, f"its material is an {kind}, which bimrobot does not read")

    def _part(self, material) -> MaterialDensity:
        return NO_MATERIAL if material is None else self.definition(material)

    def _material(self, material) -> MaterialDensity:
        name = material.Name or ""
        names = (name,) if name else ()
        shown = f"'{name}'" if name else f"material #{material.id()} without a name"
        stated = self._stated_density(material)
        if stated is not None:
            return MaterialDensity(stated[1], f"{shown}: {stated[0]} {_fmt(stated[1])} kg/m3", names)
        match = match_material(name)
        if match is None:
            return MaterialDensity(None, f"{shown} is not in the density table", names)
        entry = match.entry
        basis = f"{shown} = {entry.label} {_fmt(entry.density)} kg/m3"
        return MaterialDensity(float(entry.density), basis, names, solid=not entry.void)

    def _stated_density(self, material) -> tuple[str, float] | None:
        """(where, kg/m3) of a MassDensity the file gives for the material, when physically possible."""
        low, high = PROPERTY_DENSITY_RANGE_KG_M3
        for holder in self.ifc.get_inverse(material):
            if holder.is_a("IfcGeneralMaterialProperties"):  # IFC2X3
                candidates = [("IfcGeneralMaterialProperties.MassDensity", holder.MassDensity)]
            elif holder.is_a("IfcMaterialProperties") or holder.is_a("IfcExtendedMaterialProperties"):
                props = getattr(holder, "Properties", None) or getattr(holder, "ExtendedProperties", None) or ()
                candidates = [
                    (f"{holder.Name}.{p.Name}", p.NominalValue.wrappedValue if p.NominalValue is not None else None)
                    for p in props
                    if p.is_a("IfcPropertySingleValue") and (p.Name or "").replace(" ", "").lower() == "massdensity"
                ]
            else:
                continue
            for where, value in candidates:
                if isinstance(value, (int, float)) and low <= float(value) <= high:
                    return where, float(value)
        return None

    def _layers(self, layers) -> MaterialDensity:
        """Thickness-weighted mean density of a layer set: sum(t_i x rho_i) / sum(t_i)."""
        total_t = total_mass = 0.0
        terms, names, solid = [], [], False
        for layer in layers:
            thickness = float(layer.LayerThickness or 0.0)
            if layer.Material is None:
                # IFC: IsVentilated TRUE marks an air gap; a layer without material is otherwise unspecified
                # (ArchiCAD writes UNKNOWN for solid layers, so only TRUE counts as air)
                if getattr(layer, "IsVentilated", None) is True:
                    part = MaterialDensity(0.0, "ventilated air gap", (), solid=False)
                else:
                    part = MaterialDensity(None, "a layer without material", ())
            else:
                part = self.definition(layer.Material)
            names.extend(part.names)
            label = part.names[0] if part.names else "(no material)"
            if thickness <= 0:
                continue
            if part.density_kg_m3 is None:
                return MaterialDensity(
                    None, f"layer {label} {_fmt(thickness * self.mm_per_unit)} mm: {part.basis}", tuple(names)
                )
            solid = solid or (part.solid and part.density_kg_m3 > 0)
            total_t += thickness
            total_mass += thickness * part.density_kg_m3
            terms.append(f"{label} {_fmt(thickness * self.mm_per_unit)} mm {_fmt(part.density_kg_m3)}")
        names_t = tuple(dict.fromkeys(names))
        if total_t <= 0:
            return MaterialDensity(None, "a layer set without thickness", names_t)
        density = total_mass / total_t
        return MaterialDensity(density, f"layers: {' + '.join(terms)} = {_fmt(density)} kg/m3", names_t, solid)

    def _constituents(self, constituents) -> MaterialDensity:
        """Fraction-weighted mean density of a constituent set (fractions read as volume fractions)."""
        parts = [(c, self._part(c.Material)) for c in constituents]
        names = tuple(dict.fromkeys(n for _, p in parts for n in p.names))
        fractions = [c.Fraction for c, _ in parts]
        if parts and all(f is not None for f in fractions) and sum(fractions) > 0:
            unknown = [(c, p) for c, p in parts if p.density_kg_m3 is None and c.Fraction > 0]
            if unknown:
                c, p = unknown[0]
                return MaterialDensity(None, f"constituent {c.Name or '(unnamed)'}: {p.basis}", names)
            density = sum(c.Fraction * p.density_kg_m3 for c, p in parts) / sum(fractions)
            terms = " + ".join(f"{(p.names or ('?',))[0]} {c.Fraction:.3g} x {_fmt(p.density_kg_m3)}" for c, p in parts)
            solid = any(p.solid and p.density_kg_m3 for c, p in parts if c.Fraction > 0)
            return MaterialDensity(density, f"constituents: {terms} = {_fmt(density)} kg/m3", names, solid)
        return self._same("constituents without fractions", [p for _, p in parts])

    def _same(self, what: str, parts: list[MaterialDensity]) -> MaterialDensity:
        """One density for parts whose shares are not known: known only when all parts agree."""
        names = tuple(dict.fromkeys(n for p in parts for n in p.names))
        if not parts:
            return MaterialDensity(None, f"empty {what}", names)
        unknown = [p for p in parts if p.density_kg_m3 is None]
        if unknown:
            return MaterialDensity(None, f"{what}: {unknown[0].basis}", names)
        densities = {round(p.density_kg_m3, 6) for p in parts}
        if len(densities) > 1:
            listed = ", ".join(f"{(p.names or ('?',))[0]} {_fmt(p.density_kg_m3)}" for p in parts[:4])
            return MaterialDensity(None, f"{what} of different densities ({listed} kg/m3) without their shares", names)
        if len(parts) == 1:
            return parts[0]
        return MaterialDensity(parts[0].density_kg_m3, f"{what}: {parts[0].basis}", names, parts[0].solid)


# ---- an element's weight --------------------------------------------------------------------------


class Weight(NamedTuple):
    """An element's mass (kg, None when unknown), where it came from, and how, in words."""

    kg: float | None
    source: WeightSource
    basis: str


def pick_weight_quantity(quantities: dict[str, float]) -> tuple[str, float] | None:
    """The best of an element's weight quantities (name -> kg) as (name, kg), or None when there is none."""
    if not quantities:
        return None
    by_lower = {name.lower(): (name, value) for name, value in quantities.items()}
    for name in WEIGHT_QUANTITY_NAMES:
        if name in by_lower:
            return by_lower[name]
    return next(iter(quantities.items()))


def pick_weight_property(properties: dict[str, float]) -> tuple[str, float] | None:
    """The best weight property (``"Pset/Name"`` -> kg) by :data:`WEIGHT_PROPERTY_NAMES`, or None."""
    for wanted in WEIGHT_PROPERTY_NAMES:
        for key, value in properties.items():
            if key.rsplit("/", 1)[-1].lower() == wanted and value > 0:
                return key, value
    return None


def resolve_weight(
    weight_quantities: dict[str, float],
    weight_properties: dict[str, float],
    material: MaterialDensity,
    volume_m3: float | Callable[[], float],
) -> Weight:
    """Choose an element's mass (kg), its source and basis, following the order in the module docstring.

    ``volume_m3`` may be a function, called only when the volume is needed (step 3).
    """
    quantity = pick_weight_quantity({k: v for k, v in weight_quantities.items() if v > 0})
    if quantity is not None:
        return Weight(quantity[1], WeightSource.QUANTITY, f"IfcQuantityWeight {quantity[0]} {quantity[1]:.4g} kg")
    prop = pick_weight_property(weight_properties)
    if prop is not None:
        return Weight(prop[1], WeightSource.PROPERTY, f"property {prop[0]} {prop[1]:.4g} kg")
    density = material.body_density_kg_m3
    if density is None:
        why = material.basis
        if material.density_kg_m3 is not None:
            why += ": only air or a stud layer, not the material of a solid element"
        return Weight(None, WeightSource.UNKNOWN, f"no weight in the model; {why}")
    volume = volume_m3() if callable(volume_m3) else volume_m3
    if volume <= 0:
        return Weight(None, WeightSource.UNKNOWN, f"no weight in the model and no enclosed volume; {material.basis}")
    return Weight(volume * density, WeightSource.DENSITY, f"{volume:.4g} m3 x {_fmt(density)} kg/m3 ({material.basis})")


def plausible_density_range(density_kg_m3: float | None) -> tuple[float, float]:
    """Implied densities (kg/m3) plausible for an element of a material of ``density_kg_m3`` (None:
    unknown): :data:`PLAUSIBLE_DENSITY_KG_M3`, widened to the material's own density within
    :data:`MATERIAL_DENSITY_MARGIN` (copper 8,900 and lead 11,300 are real; so is a 30 kg/m3 foam)."""
    low, high = PLAUSIBLE_DENSITY_KG_M3
    if density_kg_m3:
        low = min(low, density_kg_m3 / MATERIAL_DENSITY_MARGIN)
        high = max(high, density_kg_m3 * MATERIAL_DENSITY_MARGIN)
    return low, high


def weight_check(weight_kg: float | None, source: WeightSource, volume_m3: float, density_kg_m3: float | None) -> str | None:
    """Why an element's weight is not plausible, in words, or None when it is (or cannot be checked).

    Suspect: an implied density (weight / mesh volume) outside :func:`plausible_density_range` (real
    steel's 7,850-8,000.4 is inside), or a weight the model gives (quantity or property) that differs
    from volume x material density by more than :data:`DISAGREEMENT_FACTOR`.
    """
    if weight_kg is None or volume_m3 <= 0:
        return None
    implied = weight_kg / volume_m3
    low, high = plausible_density_range(density_kg_m3)
    if not low <= implied <= high:
        return (
            f"implied density {_fmt(implied)} kg/m3 ({weight_kg:.4g} kg / {volume_m3:.4g} m3) is outside "
            f"{low:,.0f}-{high:,.0f} kg/m3"
        )
    if source in (WeightSource.QUANTITY, WeightSource.PROPERTY) and density_kg_m3:
        ratio = weight_kg / (volume_m3 * density_kg_m3)
        if not 1.0 / DISAGREEMENT_FACTOR <= ratio <= DISAGREEMENT_FACTOR:
            return (
                f"{source.value} {weight_kg:.4g} kg is {ratio:.2g} x volume x material density "
                f"({volume_m3:.4g} m3 x {_fmt(density_kg_m3)} kg/m3)"
            )
    return None
