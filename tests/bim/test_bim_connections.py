"""infer_connections: joints found from touching geometry."""

from __future__ import annotations

from collections import Counter

import numpy as np

from bimrobot.bim.connections import candidate_pairs, infer_connections


def _pairs(connections):
    return {frozenset((c.relating_id, c.related_id)) for c in connections}


def test_candidate_pairs_is_the_brute_force_box_overlap():
    rng = np.random.default_rng(7)
    lower = rng.uniform(0, 10, size=(200, 3))
    boxes = np.stack([lower, lower + rng.uniform(0.1, 1.5, size=(200, 3))], axis=1)
    expected = [
        (i, j)
        for i in range(200)
        for j in range(i + 1, 200)
        if np.all(boxes[i, 0] - 0.01 <= boxes[j, 1] + 0.01) and np.all(boxes[j, 0] - 0.01 <= boxes[i, 1] + 0.01)
    ]
    assert candidate_pairs(boxes, 0.01) == expected


def test_greenhouse_joints_are_inferred(greenhouse_model):
    model = greenhouse_model
    connections = infer_connections(model)
    assert all(c.inferred and c.global_id is None and c.realizing_ids == () for c in connections)
    kinds = Counter((model.element(c.relating_id).ifc_class, model.element(c.related_id).ifc_class) for c in connections)
    # every column stands on its foundation; corner columns carry 1 eaves beam, middle ones 2
    assert kinds[("IfcFooting", "IfcColumn")] == 9
    assert kinds[("IfcColumn", "IfcBeam")] == 12
    # eaves beams meet end to end (3), gable beams rest on 2 eaves beams each (8) and meet end to end (2)
    assert kinds[("IfcBeam", "IfcBeam")] == 13
    foundation_pairs = [c for c in connections if model.element(c.relating_id).ifc_class == "IfcFooting"]
    for c in foundation_pairs:  # the supporting (lower) element is the relating one
        assert model.element(c.relating_id).world_bounds[0, 2] < model.element(c.related_id).world_bounds[0, 2]


def test_steel_frame_explicit_joints_are_all_found_by_geometry(steel_frame_model):
    inferred = _pairs(infer_connections(steel_frame_model))
    assert _pairs(steel_frame_model.connections) <= inferred
    # every bolt touches the two parts it joins
    for connection in steel_frame_model.connections:
        for bolt in connection.realizing_ids:
            assert frozenset((bolt, connection.relating_id)) in inferred
            assert frozenset((bolt, connection.related_id)) in inferred


def test_tolerance_separates_touching_from_near(greenhouse_model):
    # Members touch face to face (gap 0, found with a micrometre of tolerance for rounding);
    # foundations are 2.4 m apart: connected only with a tolerance that large.
    tight = _pairs(infer_connections(greenhouse_model, tolerance=1e-6))
    loose = _pairs(infer_connections(greenhouse_model, tolerance=3.0))
    foundations = [e.global_id for e in greenhouse_model.by_class("IfcFooting")]
    assert not any(frozenset((a, b)) in tight for a in foundations for b in foundations)
    assert any(frozenset((a, b)) in loose for a in foundations for b in foundations)
    assert len(tight) == 34


def test_ifc_unit_revit_joints_found_from_geometry(ifc_unit_model):
    model = ifc_unit_model
    inferred = _pairs(infer_connections(model))
    explicit = _pairs(model.connections)
    missed = explicit - inferred
    # the only explicit joints not touching are the cleat pairs on either side of a beam web (8)
    assert len(missed) == 8
    assert all({model.element(i).name for i in pair} == {"Angle_Cleat#1", "Angle_Cleat#2"} for pair in missed)
