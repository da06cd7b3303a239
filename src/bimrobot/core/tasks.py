"""The construction tasks, said once: transport, position, assemble (thesis chapter 4, fig. 4.2).

Every part names a task with a :class:`Task` member. It is a ``str`` enum, so it compares equal to
its value, keys dictionaries like it, and prints, formats and serialises (CSV, JSON) as that value:
``Task.TRANSPORT == "transport"``, ``f"{Task.POSITION}" == "position"``.

========= ================== ============== ================= ======================= ===============
task      requirement        IfcTaskType    robot kind        ready states            log word
========= ================== ============== ================= ======================= ===============
transport NeedToTransfer     LOGISTIC       transport         OnYard                  transport
position  NeedToPosition     INSTALLATION   positioning       Arrived, InLocation     positioning
assemble  NeedToAssemble     CONSTRUCTION   assembly          PositionFixed,          assembly
                                                              WaitForAssembly,
                                                              WorkingInAssembly
========= ================== ============== ================= ======================= ===============

*requirement*: what the component (or node) publishes while it waits for the task (:mod:`bimrobot.sco`);
*IfcTaskType*: the IFC4 ``IfcTaskTypeEnum`` value of the task in a schedule (CSV ``PredefinedType``,
``IfcTask.PredefinedType``); *robot kind*: the kind of fleet robot that does it (a
``mobile_manipulator`` does all three); *ready states*: the states of the component or node in which
the task can be given to a robot; *log word*: the noun of the chapter-4 log ("Publish positioning
requirements to robot").

The names of the states a component or node goes through (:class:`State`), of what it publishes
(:class:`Requirement`) and of the six robot activities of chapter 5 (:class:`ActivityKind`) are said
here too, below every part that names them; their state machine is :mod:`bimrobot.sco.states`.

One row of a schedule, whoever makes or reads it (the simulation, the schedule CSV and IFC work
schedules of :mod:`bimrobot.schedule.csv`, RCAN's plans), is an :class:`Activity`.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass


# ------------------------------------- the states of a smart construction object (thesis fig. 4.2)
# Said here, below every part, because every part names them (the schedule, the graph, RCAN); their
# state machine (events, transitions) is bimrobot.sco.states.
class State(str, enum.Enum):
    """The thesis' construction states (same names as in fig. 4.2 and Listing 4.2)."""

    ON_YARD = "OnYard"
    IN_TRANSIT = "InTransit"
    ARRIVED = "Arrived"
    IN_LOCATION = "InLocation"
    WORKING_IN_POSITIONING = "WorkingInPositioning"
    POSITION_FIXED = "PositionFixed"
    WAIT_FOR_ASSEMBLY = "WaitForAssembly"
    WORKING_IN_ASSEMBLY = "WorkingInAssembly"
    ASSEMBLED = "Assembled"

    def __str__(self) -> str:
        return self.value


class Requirement(str, enum.Enum):
    """What a component or node needs from a robot in its current state."""

    NEED_TO_TRANSFER = "NeedToTransfer"
    NEED_TO_POSITION = "NeedToPosition"
    NEED_TO_ASSEMBLE = "NeedToAssemble"
    NONE = "None"

    def __str__(self) -> str:
        return self.value


class Task(enum.StrEnum):
    """One of the thesis' three construction tasks (table in the module docstring)."""

    TRANSPORT = "transport"
    POSITION = "position"
    ASSEMBLE = "assemble"

    @property
    def requirement(self) -> Requirement:
        """What a component or node publishes while it waits for this task."""
        return _REQUIREMENT[self]

    @property
    def ifc_task_type(self) -> str:
        """The IFC4 IfcTaskTypeEnum value this task is written with."""
        return _IFC_TASK_TYPE[self]

    @property
    def robot_kind(self) -> str:
        """The fleet robot kind that does this task (besides a mobile manipulator)."""
        return _ROBOT_KIND[self]

    @property
    def word(self) -> str:
        """The noun of the chapter-4 log and of messages: transport, positioning, assembly."""
        return _ROBOT_KIND[self]

    @property
    def title(self) -> str:
        """The start of an activity's schedule Name: ``Transport``, ``Position``, ``Assemble``."""
        return self.value.capitalize()

    @property
    def ready_states(self) -> tuple[State, ...]:
        """The states of a component or node in which this task can be given to a robot."""
        return _READY[self]

    @property
    def rank(self) -> int:
        """Dispatch order: the task nearest to completing the building first (assemble 0, transport 2)."""
        return _RANK[self]

    @classmethod
    def parse(cls, text: str) -> Task:
        """The task called ``text`` (its value); ValueError listing the three otherwise."""
        try:
            return cls(text)
        except ValueError:
            raise ValueError(f"{text!r} is not a construction task (transport, position or assemble)") from None

    @classmethod
    def from_ifc_task_type(cls, task_type: str) -> Task | None:
        """The task written with IfcTaskTypeEnum ``task_type``, or None for any other type."""
        return _BY_IFC_TASK_TYPE.get(task_type)


#: The three tasks in the order a component goes through them.
TASKS = tuple(Task)

_REQUIREMENT = {
    Task.TRANSPORT: Requirement.NEED_TO_TRANSFER,
    Task.POSITION: Requirement.NEED_TO_POSITION,
    Task.ASSEMBLE: Requirement.NEED_TO_ASSEMBLE,
}
_IFC_TASK_TYPE = {Task.TRANSPORT: "LOGISTIC", Task.POSITION: "INSTALLATION", Task.ASSEMBLE: "CONSTRUCTION"}
_BY_IFC_TASK_TYPE = {task_type: task for task, task_type in _IFC_TASK_TYPE.items()}
_ROBOT_KIND = {Task.TRANSPORT: "transport", Task.POSITION: "positioning", Task.ASSEMBLE: "assembly"}
_READY = {
    Task.TRANSPORT: (State.ON_YARD,),
    Task.POSITION: (State.ARRIVED, State.IN_LOCATION),
    Task.ASSEMBLE: (State.POSITION_FIXED, State.WAIT_FOR_ASSEMBLY, State.WORKING_IN_ASSEMBLY),
}
_RANK = {Task.ASSEMBLE: 0, Task.POSITION: 1, Task.TRANSPORT: 2}

#: Robot kind of a fleet file -> the tasks its robots bid for.
KIND_TASKS: dict[str, tuple[Task, ...]] = {
    **{task.robot_kind: (task,) for task in TASKS},
    "mobile_manipulator": TASKS,
}



@dataclass(frozen=True)
class Activity:
    """One schedule row: a construction activity done by one robot.

    ``id``: unique id (the CSV's Identification, the IfcTask's GlobalId, or the simulation's A0001...).
    ``name``: what the row says (``Transport <GlobalId>``...). ``activity``: a :class:`Task`, or ``""``
    for an IfcTask of another type that outputs nothing. ``global_id``: the component it acts on (None
    for a task without one). ``robot``: the robot (fleet name) that performs it, or None.
    ``start``/``finish``: seconds from the start of the build. ``predecessors``: ids that must finish
    first (FINISH_START). ``target``: installed position (x, y, z) of the component's origin, metres,
    model (world) frame, z up, or None. ``storey``: storey GlobalId, or None or ``""`` when there is
    none. ``predefined_type``: the IfcTaskTypeEnum value it is written with (``""``: the task's own,
    :attr:`Task.ifc_task_type`). ``node_id``: for ``assemble`` on a connection node, the node id
    ``<relating GlobalId>:<related GlobalId>``. ``parent``: id of the summary task it belongs to (IFC
    work schedules only). ``work_from``: where the robot begins the work (x, y, z metres, model frame:
    the yard pick-up of a transport, the node, joint or component otherwise), ``work_to``: where it
    ends it (the drop-off of a transport); ``nodes``: connection nodes positioned, ``points``: assembly
    points made; each None when the schedule does not say. ``aborted``: the simulation's robot broke
    down during it (never written to a schedule file).
    """

    id: str
    name: str
    activity: Task | str
    global_id: str | None
    robot: str | None
    start: float
    finish: float
    predecessors: tuple[str, ...] = ()
    target: tuple[float, float, float] | None = None
    storey: str | None = None
    predefined_type: str = ""
    node_id: str | None = None
    parent: str | None = None
    work_from: tuple[float, float, float] | None = None
    work_to: tuple[float, float, float] | None = None
    nodes: int | None = None
    points: int | None = None
    aborted: bool = False

    @property
    def duration(self) -> float:
        """``finish - start`` in seconds."""
        return self.finish - self.start


# ------------------------------------------------ the six robot activities of thesis chapter 5 (RCAN)
class ActivityKind(str, enum.Enum):
    """A robot construction activity (thesis section 5.3.3), value = its snake_case name. Said here, below
    every part, because fleet files name them (``rcan_activities``); RCAN breaks tasks into them
    (:mod:`bimrobot.rcan.activities`)."""

    MOVE_TO_COMPONENT = "move_to_component"
    POSITION_FOR_PICKING_UP = "position_for_picking_up"
    PICK_UP = "pick_up"
    TRANSPORT = "transport"
    POSITION_FOR_INSTALLING = "position_for_installing"
    INSTALL = "install"

    @property
    def label(self) -> str:
        """The thesis' name, e.g. "Position for picking up"."""
        return self.value.replace("_", " ").capitalize()

    @classmethod
    def parse(cls, text: str) -> "ActivityKind":
        """Accept ``pick_up``, ``Pick up`` or ``pick-up``; ValueError naming the valid kinds otherwise."""
        key = text.strip().lower().replace(" ", "_").replace("-", "_")
        try:
            return cls(key)
        except ValueError:
            valid = ", ".join(kind.value for kind in cls)
            raise ValueError(f"unknown construction activity {text!r} (expected one of: {valid})") from None


__all__ = ["KIND_TASKS", "TASKS", "Activity", "ActivityKind", "Requirement", "State", "Task"]
