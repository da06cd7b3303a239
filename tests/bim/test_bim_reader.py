"""load_model on the example buildings, the shared real files and bad input."""

from __future__ import annotations

import numpy as np
import pytest

from bimrobot.bim import load_model
from bimrobot.bim.model import WeightSource
from bimrobot.bim.model import mesh_volume
from bimrobot.bim.quantities import density_of
from bimrobot.core.errors import InputError

SHARED_FILES = [
    "ifcUnit.ifc",
    "ifcColumn.ifc",
    "AC20-FZK-Haus.ifc",
    "engine_web-ifc_example.ifc",
    "IfcOpenHouse_IFC4.ifc",
    "column-extruded-solid.ifc",
    "construction-scheduling-task.ifc",
]


def test_local_mesh_times_placement_gives_world_geometry(steel_frame_model):
    beam = next(b for b in steel_frame_model.by_class("IfcBeam") if b.name == "Beam B12")
    # local frame: x along the beam; the local box is the section and the length
    extent = beam.local_bounds[1] - beam.local_bounds[0]
    assert extent == pytest.approx([2.8134, 0.165, 0.310], abs=1e-4)
    assert beam.world_bounds[0] == pytest.approx([0.0163, -0.0825, 3.715], abs=1e-4)


def test_include_and_exclude_filter_by_class(steel_frame_ifc):
    frame = load_model(steel_frame_ifc, include="IfcColumn, IfcBeam")
    assert frame.class_counts() == {"IfcBeam": 4, "IfcColumn": 4}
    assert frame.connections == []  # every joint involves a plate or a clip angle, which were left out
    no_bolts = load_model(steel_frame_ifc, exclude=["IfcMechanicalFastener"])
    assert "IfcMechanicalFastener" not in no_bolts.class_counts()
    assert len(no_bolts.connections) == 24  # bolts are realizing ids, the joints stay
    with pytest.raises(InputError, match="IfcWobble"):
        load_model(steel_frame_ifc, include="IfcWobble")


def test_mesh_volume_and_density_table():
    cube_vertices = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], float)
    import trimesh

    cube = trimesh.Trimesh(cube_vertices * 2.0, trimesh.convex.convex_hull(cube_vertices).faces)
    assert mesh_volume(cube.vertices, cube.faces) == pytest.approx(8.0)
    assert density_of("Steel, 45-345") == 7850.0
    assert density_of("Concrete, Cast-in-Place gray") == 2400.0
    assert density_of("Reinforced concrete C30/37") == 2500.0
    assert density_of("混凝土") == 2400.0
    assert density_of("Unobtainium") is None


# ---- real data (../shared/data/ifc), skipped when absent -----------------------------------------


@pytest.fixture
def ifc_unit(ifc_unit_model):
    return ifc_unit_model


def test_ifc_unit_has_its_36_connections(ifc_unit):
    assert len(ifc_unit.connections) == 36
    assert all(c.realizing_ids for c in ifc_unit.connections)
    assert {c.connection_type for c in ifc_unit.connections} == {""}


def test_ifc_unit_beam_weight_comes_from_revit_exact_weight(ifc_unit):
    beams = [b for b in ifc_unit.by_class("IfcBeam") if abs((b.local_bounds[1] - b.local_bounds[0]).max() - 2.82) < 0.01]
    assert len(beams) == 4
    for beam in beams:
        assert beam.weight_source is WeightSource.PROPERTY
        assert beam.weight_kg == pytest.approx(109.28, rel=0.005)
        # and the mesh agrees: volume x 7850 kg/m3
        assert mesh_volume(beam.vertices, beam.faces) * 7850 == pytest.approx(beam.weight_kg, rel=0.005)


def test_ifc_unit_cleats_are_elements_and_welds_are_skipped(ifc_unit):
    cleats = [e for e in ifc_unit.by_class("IfcColumn") if e.name.startswith("Angle_Cleat")]
    assert len(cleats) == 16
    assert len(ifc_unit.by_class("IfcMechanicalFastener")) == 28
    welds = [s for s in ifc_unit.skipped if s.ifc_class == "IfcFastener"]
    assert len(welds) == 4
    assert all("curve-only" in s.reason for s in welds)
    assert ifc_unit.units["length"] == "MILLIMETRE"
    assert [(s.name, s.elevation) for s in ifc_unit.storeys] == [("Level 1", 0.0), ("Level 2", 4.0)]
    column = ifc_unit.by_class("IfcColumn")[0]
    assert column.world_bounds[1, 2] - column.world_bounds[0, 2] == pytest.approx(4.0, abs=0.01)  # metres


@pytest.mark.parametrize("name", SHARED_FILES)
def test_every_shared_file_loads(shared_ifc, ifc_unit_model, name):
    model = ifc_unit_model if name == "ifcUnit.ifc" else load_model(shared_ifc(name))
    assert model.schema in {"IFC2X3", "IFC4", "IFC4X3_ADD2"}
    assert model.elements
    for element in model.elements.values():
        assert element.placement.shape == (4, 4)
        assert len(element.faces) > 0
        assert np.isfinite(element.world_bounds).all()
    # no building here is bigger than a few hundred metres: a sign that every length is in metres
    assert max(np.ptp(e.world_bounds, axis=0).max() for e in model.elements.values()) < 200


def test_inch_file_gives_metres(shared_ifc):
    model = load_model(shared_ifc("construction-scheduling-task.ifc"))
    assert model.units["length"] == "INCH"
    assert model.units["length_scale_to_m"] == pytest.approx(0.0254)
    walls = model.by_class("IfcWall", "IfcWallStandardCase")
    assert len(walls) == 4
    heights = [np.ptp(w.world_bounds[:, 2]) for w in walls]
    assert all(1.0 < h < 10.0 for h in heights), heights  # a storey-high wall in metres, not inches


# ---- bad input -------------------------------------------------------------------------------------


def test_missing_file(tmp_path):
    with pytest.raises(InputError, match=r"nope\.ifc: no such file"):
        load_model(tmp_path / "nope.ifc")


def test_not_an_ifc_file(tmp_path):
    path = tmp_path / "notes.ifc"
    path.write_text("just some text\n")
    with pytest.raises(InputError, match=r"notes\.ifc is not an IFC file"):
        load_model(path)


def test_truncated_file(tmp_path, steel_frame_ifc):
    path = tmp_path / "cut.ifc"
    path.write_bytes(steel_frame_ifc.read_bytes()[:20000])
    with pytest.raises(InputError, match=r"cut\.ifc is truncated"):
        load_model(path)


def test_unsupported_schema(tmp_path, steel_frame_ifc):
    path = tmp_path / "rc2.ifc"
    path.write_text(steel_frame_ifc.read_text().replace("FILE_SCHEMA(('IFC4'))", "FILE_SCHEMA(('IFC4X3_RC2'))"))
    with pytest.raises(InputError, match=r"rc2\.ifc uses the unsupported IFC schema IFC4X3_RC2"):
        load_model(path)


def test_no_solid_geometry(tmp_path):
    import ifcopenshell.api.project
    import ifcopenshell.api.root

    ifc = ifcopenshell.api.project.create_file(version="IFC4")
    ifcopenshell.api.root.create_entity(ifc, ifc_class="IfcProject", name="empty")
    ifcopenshell.api.root.create_entity(ifc, ifc_class="IfcWall", name="ghost wall")
    path = tmp_path / "empty.ifc"
    ifc.write(str(path))
    with pytest.raises(InputError, match=r"empty\.ifc contains no element with solid geometry"):
        load_model(path)


@pytest.mark.parametrize("name", ["IfcOpenHouse_IFC4.ifc", "engine_web-ifc_example.ifc"])
def test_properties_equal_ifcopenshell_get_psets(shared_ifc, name):
    """The reader's fast one-pass property reading gives what ifcopenshell.util.element.get_psets gives."""
    import ifcopenshell
    import ifcopenshell.util.element

    path = shared_ifc(name)
    model = load_model(path)
    ifc = ifcopenshell.open(str(path))
    for element in model.elements.values():
        expected = {
            f"{pset}/{prop}": value
            for pset, values in ifcopenshell.util.element.get_psets(ifc.by_guid(element.global_id)).items()
            for prop, value in values.items()
            if prop != "id" and not isinstance(value, dict)
        }
        assert element.properties == expected, element.global_id


def test_ifczip_reads_like_the_ifc_inside_and_xml_is_named(tmp_path, steel_frame_ifc, steel_frame_model):
    import zipfile

    archive = tmp_path / "model.ifczip"
    with zipfile.ZipFile(archive, "w", zipfile.ZIP_DEFLATED) as zipped:
        zipped.write(steel_frame_ifc, "export/model.ifc")
        zipped.writestr("__MACOSX/export/._model.ifc", b"\x00\x05\x16\x07")  # Finder's metadata: not a model
    zipped_model = load_model(archive)
    assert list(zipped_model.elements) == list(steel_frame_model.elements)
    assert zipped_model.source == archive
    assert len(zipped_model.connections) == len(steel_frame_model.connections)
    empty = tmp_path / "empty.ifczip"
    with zipfile.ZipFile(empty, "w") as zipped:
        zipped.writestr("readme.txt", "no model here")
    with pytest.raises(InputError, match=r"empty\.ifczip is a zip archive without an \.ifc file inside"):
        load_model(empty)
    xml = tmp_path / "model.ifcxml"
    xml.write_text('<?xml version="1.0"?>\n<ifcXML/>\n')
    with pytest.raises(InputError, match=r"model\.ifcxml is XML"):
        load_model(xml)


def test_real_ifczip_loads(shared_ifc):
    model = load_model(shared_ifc("ROOT-staal.ifczip"))
    assert model.schema == "IFC2X3"
    assert len(model.elements) > 0
    assert model.source.name == "ROOT-staal.ifczip"


def walls_sharing_a_global_id(path):
    """Three 5 m walls authored with ifcopenshell.api; the second carries the first one's GlobalId."""
    import ifcopenshell.api.aggregate
    import ifcopenshell.api.context
    import ifcopenshell.api.geometry
    import ifcopenshell.api.project
    import ifcopenshell.api.root
    import ifcopenshell.api.spatial
    import ifcopenshell.api.unit

    ifc = ifcopenshell.api.project.create_file(version="IFC4")
    project = ifcopenshell.api.root.create_entity(ifc, ifc_class="IfcProject", name="Walls")
    ifcopenshell.api.unit.assign_unit(ifc)
    context = ifcopenshell.api.context.add_context(ifc, context_type="Model")
    body = ifcopenshell.api.context.add_context(ifc, context_type="Model", context_identifier="Body",
                                                target_view="MODEL_VIEW", parent=context)
    storey = ifcopenshell.api.root.create_entity(ifc, ifc_class="IfcBuildingStorey", name="Level 0")
    ifcopenshell.api.aggregate.assign_object(ifc, products=[storey], relating_object=project)
    walls = []
    for index in range(3):
        wall = ifcopenshell.api.root.create_entity(ifc, ifc_class="IfcWall", name=f"Wall {index}")
        representation = ifcopenshell.api.geometry.add_wall_representation(ifc, context=body, length=5, height=3,
                                                                           thickness=0.2)
        ifcopenshell.api.geometry.assign_representation(ifc, product=wall, representation=representation)
        matrix = np.eye(4)
        matrix[1, 3] = 2.0 * index
        ifcopenshell.api.geometry.edit_object_placement(ifc, product=wall, matrix=matrix)
        ifcopenshell.api.spatial.assign_container(ifc, products=[wall], relating_structure=storey)
        walls.append(wall)
    walls[1].GlobalId = walls[0].GlobalId
    ifc.write(str(path))
    return path, [(w.id(), w.GlobalId) for w in walls]


def test_duplicate_global_ids_keep_every_element_and_are_reported(tmp_path, caplog):
    path, walls = walls_sharing_a_global_id(tmp_path / "walls.ifc")
    (first_id, shared), (second_id, _), (_, third) = walls
    with caplog.at_level("WARNING", logger="bimrobot.bim.reader"):
        model = load_model(path)
    assert list(model.elements) == [shared, f"{shared}#{second_id}", third]
    assert [e.name for e in model.elements.values()] == ["Wall 0", "Wall 1", "Wall 2"]
    assert all(key == e.global_id for key, e in model.elements.items())
    # the second wall is the one 2 m along y: its own body, not a copy of the first
    assert model.elements[f"{shared}#{second_id}"].position[1] == pytest.approx(2.0)
    (record,) = [r for r in caplog.records if "GlobalId" in r.getMessage()]
    message = record.getMessage()
    assert len(message.splitlines()) == 1
    assert f"'{shared}' by #{first_id} IfcWall and #{second_id} IfcWall" in message
    assert f"'{shared}#{second_id}'" in message


def _same_element(a, b) -> bool:
    return (a.ifc_class == b.ifc_class and a.name == b.name and a.storey_id == b.storey_id
            and a.material == b.material and a.weight_kg == b.weight_kg and a.weight_source == b.weight_source
            and np.array_equal(a.placement, b.placement) and np.array_equal(a.vertices, b.vertices)
            and np.array_equal(a.faces, b.faces))


def test_geometry_read_by_two_processes_gives_the_same_model(shared_ifc):
    # Tekla's precast stairs: 150 elements, 9 outermost assemblies, 36 realizing-element connections
    import multiprocessing

    from bimrobot.bim import reader
    from bimrobot.core.cores import can_fork

    path = shared_ifc("MULTICOM-trappen_bordessen.ifc")
    alone = load_model(path, processes=1, properties=False)
    # the caller's own work (convert imports trimesh and SciPy) runs once, while the two processes compute
    during: list[int] = []
    shared = reader.load_model(path, processes=2, properties=False,
                               meanwhile=lambda: during.append(len(multiprocessing.active_children())))
    assert during == ([2] if can_fork() else [0])
    assert list(shared.elements) == list(alone.elements)  # every element, in the file's order
    assert all(_same_element(shared.elements[key], alone.elements[key]) for key in alone.elements)
    assert shared.connections == alone.connections and len(shared.connections) == 36
    assert shared.assemblies == alone.assemblies and len(shared.assemblies) == 9
    assert shared.skipped == alone.skipped
    # a mesh that several elements share is still one array (the package writes it once), and read-only
    assert len({id(e.vertices) for e in shared.elements.values()}) == len({id(e.vertices) for e in alone.elements.values()})
    assert not any(e.vertices.flags.writeable or e.faces.flags.writeable for e in shared.elements.values())


def _shares_of(path):
    from bimrobot.bim.reader import open_ifc
    from bimrobot.bim.selection import select_products
    from bimrobot.bim.shares import balanced_shares, geometry_costs

    ifc = open_ifc(path)
    products = select_products(ifc, None, None, path)
    shares = balanced_shares(products, 2, geometry_costs(ifc, products))
    # every product in exactly one share, each share in the file's order
    assert sorted(p.id() for share in shares for p in share) == sorted(p.id() for p in products)
    assert all([products.index(p) for p in share] == sorted(products.index(p) for p in share) for share in shares)
    return products, [{p.id() for p in share} for share in shares]


def test_the_two_geometry_processes_get_the_costly_products_in_equal_parts(shared_ifc):
    # The kernel's time goes to Boolean operations. MULTICOM-Prefab: 38 beams whose bodies are Boolean
    # results (0.15-0.29 s of geometry each, the other products 0.3-7 ms), 28 of them at odd positions in
    # the file: two processes reading every other product got 10 and 28 (2.3 against 1.2 s of geometry).
    products, shares = _shares_of(shared_ifc("MULTICOM-Prefab.ifc"))
    clipped = {p.id() for p in products if p.Representation is not None
               and any(i.is_a("IfcBooleanResult") for r in p.Representation.Representations for i in r.Items)}
    assert len(clipped) == 38
    assert [len(clipped & share) for share in shares] == [19, 19]
    # AC20-FZK-Haus: the two upper walls clipped by the roof and cut by a window take 1.5 s each of 4.1 s
    products, shares = _shares_of(shared_ifc("AC20-FZK-Haus.ifc"))
    walls = {p.id() for p in products if p.Name in ("Wand-Ext-OG-1", "Wand-Ext-OG-3")}
    assert len(walls) == 2 and [len(walls & share) for share in shares] == [1, 1]


def test_an_error_in_a_geometry_process_is_raised_in_the_caller(steel_frame_ifc, monkeypatch):
    import os

    from bimrobot.bim import reader

    caller, read = os.getpid(), reader._ShareReader.__call__

    def failing_in_child(self, products, threads, bar=None):
        if os.getpid() != caller:
            raise InputError("a product the child could not read")
        return read(self, products, threads, bar)

    monkeypatch.setattr(reader._ShareReader, "__call__", failing_in_child)
    with pytest.raises(InputError, match="a product the child could not read"):
        load_model(steel_frame_ifc, processes=2)


@pytest.mark.parametrize("processes", [1, 2])  # 1: the kernel runs in a child all the same (issue 35)
def test_a_crashed_geometry_process_names_the_file(steel_frame_ifc, monkeypatch, processes):
    import faulthandler
    import os
    import signal

    from bimrobot.bim import reader

    caller, read = os.getpid(), reader._ShareReader.__call__

    def crashing_in_child(self, products, threads, bar=None):
        if os.getpid() != caller:
            faulthandler.disable()  # pytest's handler would print a crash report for this intended crash
            os.kill(os.getpid(), signal.SIGSEGV)  # as a geometry kernel crash ends a process
        return read(self, products, threads, bar)

    monkeypatch.setattr(reader._ShareReader, "__call__", crashing_in_child)
    with pytest.raises(InputError, match=r"steel_frame\.ifc: IfcOpenShell's geometry kernel crashed \(exit code -11\)"):
        load_model(steel_frame_ifc, processes=processes)


def _stop_and_check_gone(process, signum: int, pids: list[int]) -> None:
    """Send ``signum`` to ``process``, wait for it, and check that every one of ``pids`` ended with it."""
    import time

    process.send_signal(signum)
    process.wait(timeout=60)
    for _ in range(100):  # the kernel kills them with their parent: at once, but allow 10 s under load
        if not any(_alive(pid) for pid in pids):
            break
        time.sleep(0.1)
    assert not any(_alive(pid) for pid in pids)


def _alive(pid: int) -> bool:
    """Whether process ``pid`` still runs (a zombie, dead but not yet reaped, does not)."""
    try:
        with open(f"/proc/{pid}/stat", encoding="ascii") as stat:
            return stat.read().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


_HANGING_READ = """
import multiprocessing, os, sys, threading, time
from bimrobot.bim import reader
def hanging(self, products, threads, bar=None):
    time.sleep(600)  # the geometry processes: only a kill ends them
reader._ShareReader.__call__ = hanging
def name_them():  # the reader names its geometry processes once they all run
    while len(multiprocessing.active_children()) < 3:
        time.sleep(0.01)
    print(" ".join(str(child.pid) for child in multiprocessing.active_children()), flush=True)
threading.Thread(target=name_them, daemon=True).start()
reader.load_model(sys.argv[1], processes=3)
"""


@pytest.mark.skipif(not __import__("bimrobot.core.cores", fromlist=["can_fork"]).can_fork(), reason="geometry processes are forked on Linux only")
@pytest.mark.parametrize("signum", ["SIGKILL", "SIGTERM"])
def test_geometry_processes_die_with_the_reader(steel_frame_ifc, signum):
    # issue 35: `convert ... & kill $!` left a geometry process with parent 1, blocked for ever
    import signal
    import subprocess
    import sys

    reader = subprocess.Popen([sys.executable, "-c", _HANGING_READ, str(steel_frame_ifc)], stdout=subprocess.PIPE, text=True)
    try:
        children = [int(pid) for pid in reader.stdout.readline().split()]
        assert len(children) == 3 and all(_alive(pid) for pid in children)
        _stop_and_check_gone(reader, getattr(signal, signum), children)
    finally:
        reader.kill()
        reader.wait()
        reader.stdout.close()


def test_an_entity_id_defined_twice_is_refused_with_its_lines(tmp_path, steel_frame_ifc):
    # issue 35: IfcOpenShell keeps the last definition while inverses mix both (an AttributeError later)
    lines = steel_frame_ifc.read_text(encoding="utf-8").splitlines(keepends=True)
    relation = next(i for i, line in enumerate(lines) if "IFCRELCONTAINEDINSPATIALSTRUCTURE" in line)
    point = next(i for i, line in enumerate(lines) if "IFCCARTESIANPOINT" in line)
    entity_id = lines[relation].split("=", 1)[0].strip()
    lines.insert(point + 1, entity_id + "=" + lines[point].split("=", 1)[1])  # a point, under the relation's id
    path = tmp_path / "twice.ifc"
    path.write_text("".join(lines), encoding="utf-8")
    with pytest.raises(InputError) as refused:
        load_model(path)
    message = str(refused.value)
    assert message.startswith(f"{path} defines 1 entity id(s) more than once ({entity_id} on lines ")
    assert str(point + 2) in message and str(relation + 2) in message and "IFC-SPF forbids" in message


def test_a_model_read_in_a_forked_process_is_the_one_read_here(shared_ifc):
    # `bimrobot convert` reads the model in a forked process while it imports its writer (bim.forked_read)
    import multiprocessing

    from bimrobot.bim.forked_read import load_model_meanwhile
    from bimrobot.core.cores import can_fork

    path = shared_ifc("MULTICOM-trappen_bordessen.ifc")
    here = load_model(path, processes=2, properties=False)
    during: list[int] = []
    forked = load_model_meanwhile(path, lambda: during.append(len(multiprocessing.active_children())),
                                  processes=2, properties=False)
    assert during == ([1] if can_fork() else [0])  # the reading process runs while the caller works
    assert list(forked.elements) == list(here.elements)
    assert all(_same_element(forked.elements[key], here.elements[key]) for key in here.elements)
    assert all(forked.elements[key].volume_m3 == here.elements[key].volume_m3 for key in here.elements)
    assert forked.connections == here.connections and forked.assemblies == here.assemblies
    assert forked.skipped == here.skipped and forked.storeys == here.storeys
    # meshes shared by several elements stay shared after the trip, and read-only
    assert len({id(e.vertices) for e in forked.elements.values()}) == len({id(e.vertices) for e in here.elements.values()})
    assert not any(e.vertices.flags.writeable or e.faces.flags.writeable for e in forked.elements.values())


def test_bad_input_read_in_a_forked_process_gives_the_same_error(tmp_path):
    from bimrobot.bim.forked_read import load_model_meanwhile

    bad = tmp_path / "notes.ifc"
    bad.write_text("not a model\n", encoding="utf-8")
    with pytest.raises(InputError) as here:
        load_model(bad)
    with pytest.raises(InputError) as forked:
        load_model_meanwhile(bad, lambda: None)
    assert str(forked.value) == str(here.value) and "notes.ifc" in str(forked.value)


_HANGING_FORKED_READ = """
import sys, time
from bimrobot.bim import reader
from bimrobot.bim.forked_read import load_model_meanwhile
def hanging(self, products, threads, bar=None):
    time.sleep(600)  # the geometry processes: only a kill ends them
reader._ShareReader.__call__ = hanging
load_model_meanwhile(sys.argv[1], lambda: print("reading", flush=True), processes=2)
"""


def _descendants(pid: int) -> list[int]:
    """The live processes under ``pid`` (children, grandchildren, ...)."""
    import os

    parents = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit() and _alive(int(entry)):
            try:
                with open(f"/proc/{entry}/stat", encoding="ascii") as stat:
                    parents[int(entry)] = int(stat.read().rsplit(")", 1)[1].split()[1])
            except OSError:
                pass
    found, frontier = [], [pid]
    while frontier:
        children = [p for p, parent in parents.items() if parent in frontier]
        found += children
        frontier = children
    return found


@pytest.mark.skipif(not __import__("bimrobot.core.cores", fromlist=["can_fork"]).can_fork(), reason="processes are forked on Linux only")
@pytest.mark.parametrize("signum", ["SIGKILL", "SIGTERM"])
def test_the_forked_read_and_its_geometry_processes_die_with_the_caller(steel_frame_ifc, signum):
    import signal
    import subprocess
    import sys
    import time

    caller = subprocess.Popen([sys.executable, "-c", _HANGING_FORKED_READ, str(steel_frame_ifc)], stdout=subprocess.PIPE, text=True)
    try:
        assert caller.stdout.readline().strip() == "reading"
        for _ in range(600):  # the reading process, then its two geometry processes (60 s under load)
            under = _descendants(caller.pid)
            if len(under) == 3:
                break
            time.sleep(0.1)
        assert len(under) == 3
        _stop_and_check_gone(caller, getattr(signal, signum), under)
    finally:
        caller.kill()
        caller.wait()
        caller.stdout.close()
