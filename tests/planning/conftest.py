"""Buildings the planning tests share."""

import pytest


@pytest.fixture
def freestanding_frame():
    """The chapter-4 frame (per joint, fleet2; a DispatchProblem) with one more column on the ground
    floor, 6 m away, that touches nothing: a robot-built part without connection nodes, whose positioning
    the floor gate waits for in the simulation (ROOT-staal has 13 such parts below its top floor)."""
    from bimrobot.coordination.generate import COLUMN_KG_PER_M, box_element, generated_frame
    from bimrobot.planning.dispatch_problem import DispatchProblem
    from bimrobot.sco.build import build_smart_model
    from bimrobot.site.fleet import load_fleet
    from bimrobot.site.site import site_for

    model = generated_frame(2, 2, 1)
    model.elements["column-free"] = box_element("column-free", "IfcColumn", "W250x73", "storey-0", (1.625, 6.0, 0.0),
                                                (1.875, 6.25, 4.0), COLUMN_KG_PER_M * 4.0)
    return DispatchProblem(build_smart_model(model), load_fleet("fleet2"), site_for(None, model.elements.values()),
                           [s.elevation for s in model.storeys], False)
