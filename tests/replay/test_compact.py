"""A large model drawn compact (bimrobot.replay.compact): each component its box, grouped by state, so
that the web viewer has a few entities to take in instead of one per element (MULTICOM-Prefab: 7
instead of 118, docs/evidence/replay.md), and the same building where the build ends."""

from __future__ import annotations

import numpy as np
import pytest

rr = pytest.importorskip("rerun")


def last_rows(rrd) -> dict[str, dict[str, list]]:
    """Entity path -> {component: its last logged value} of the /building entities, read with Rerun's
    chunk reader (the rows on sim_time, in time order)."""
    from rerun.chunk import RrdReader

    out: dict[str, dict[str, list]] = {}
    for chunk in RrdReader(rrd).stream():
        if not chunk.entity_path.startswith("/building/"):
            continue
        batch = chunk.to_record_batch()
        order = np.argsort(batch.column("sim_time").to_numpy(), kind="stable") if "sim_time" in batch.schema.names else [0]
        for name in batch.schema.names:
            if ":" in name:
                values = batch.column(name).to_pylist()
                out.setdefault(chunk.entity_path, {})[name.split(":")[1]] = values[int(order[-1])]
    return out


def box_corners(centre, half, quaternion) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])
    return (signs * half) @ Rotation.from_quat(quaternion).as_matrix().T + centre


def test_a_large_model_is_few_entities_of_boxes_by_state_and_ends_as_the_same_building(frame_build, tmp_path):
    """The steel frame written compact: its 88 pieces (12 components, their bolts and plates) are at
    most one entity per state, no mesh; at the end of the build every piece is an assembled (green) box
    labelled with its GlobalId, but the bolts of no scheduled joint (standing as the model has them from
    the start, as in the full replay), and the boxes span the building's bounding box (its meshes at their
    installed places) to within 2 cm."""
    from bimrobot.replay.compact import COMPACT_FROM, UNSCHEDULED, is_large
    from bimrobot.replay.elements import drawn_record, entity
    from bimrobot.replay.inputs import STATES, load_build
    from bimrobot.replay.layout import building_bounds
    from bimrobot.replay.record import write_rrd

    record = load_build([frame_build])
    drawn, _ = drawn_record(record)
    assert len(drawn.pieces) == 88 <= COMPACT_FROM and not is_large(drawn)  # the frame keeps its meshes by default
    rrd = tmp_path / "boxes.rrd"
    summary = write_rrd(record, rrd, compact=True)
    assert summary["drawn"] == "boxes by state"
    rows = last_rows(rrd)
    assert set(rows) <= {entity("building", s) for s in (*STATES, UNSCHEDULED)}
    assert summary["entities"] == len(rows) <= 10
    assert not any("vertex_positions" in row for row in rows.values())  # boxes, not meshes
    standing = [rows[entity("building", "Assembled")], rows[entity("building", UNSCHEDULED)]]
    gids = [[label.rsplit("(", 1)[1].rstrip(")") for label in row["labels"]] for row in standing]
    assert len(gids[0]) == 76 and len(gids[1]) == 12  # 12 bolts of no scheduled joint stand as the model has them
    assert set(gids[0]) | set(gids[1]) == set(drawn.pieces)
    assert all(not row.get("labels") for row in rows.values() if not any(row is s for s in standing))
    corners = np.concatenate([box_corners(c, h, q) for row in standing
                              for c, h, q in zip(row["centers"], row["half_sizes"], row["quaternions"])])
    low, high = building_bounds(drawn)
    assert np.allclose(corners.min(axis=0), low, atol=0.02) and np.allclose(corners.max(axis=0), high, atol=0.02)
