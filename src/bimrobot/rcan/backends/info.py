"""What a backend declares besides its features: what a run must give it, whether it acts in turns, the
command-line options it adds, and what it reports after an activity (:class:`ActivityResult`, here so that
the features and the interface share it without importing each other). Light to import (no backend, no
numpy), so that ``bimrobot rcan --help`` lists every backend's options without importing one.

A backend's folder declares one :class:`BackendInfo` as ``INFO`` in its ``__init__`` (and its class says
``info = INFO``); :mod:`bimrobot.rcan.system` and :mod:`bimrobot.rcan.cli` read it instead of testing
backend names.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from bimrobot.core.errors import InputError

#: what a run can give a backend (a field of :class:`RunContext`) -> the constructor keyword it goes to
CONTEXT_KEYWORDS = {"state_db": "db_path", "plan": "plan", "trajectory_path": "trajectory_path"}


@dataclass(frozen=True)
class BackendOption:
    """A command-line option a backend adds to ``rcan run`` and ``rcan executor`` (``run_only``: to ``rcan
    run`` only). ``keyword``: the backend constructor's keyword it sets (None: the backend's run hooks read
    it); ``low``/``high``: the accepted range, checked before anything is read or run (``unit`` ends the
    message's range); ``type``, ``default``, ``metavar``, ``choices``, ``help`` as in argparse."""

    flags: tuple[str, ...]
    help: str
    keyword: str | None = None
    type: Any = float
    default: Any = None
    metavar: str | None = None
    choices: tuple | None = None
    low: float | None = None
    high: float | None = None
    unit: str = ""
    run_only: bool = False

    @property
    def dest(self) -> str:
        """The attribute of the parsed arguments that holds the value."""
        return self.flags[0].lstrip("-").replace("-", "_")

    def add_to(self, parser) -> None:
        """Add the option to an argparse parser."""
        extra = {key: value for key, value in (("metavar", self.metavar), ("choices", self.choices))
                 if value is not None}
        kind = {} if self.choices is not None else {"type": self.type}
        parser.add_argument(*self.flags, **kind, default=self.default, help=self.help, **extra)

    def check(self, value) -> None:
        """InputError naming the option when ``value`` lies outside ``low``..``high`` (or is not finite)."""
        if self.low is None or value is None:
            return
        if not (math.isfinite(value) and self.low <= value <= self.high):
            unit = f" {self.unit}" if self.unit else ""
            raise InputError(f"{self.flags[0]} must be between {self.low:g} and {self.high:g}{unit}, got {value}")


@dataclass(frozen=True)
class BackendInfo:
    """A backend's declaration.

    ``backend``: its class as ``module:Class`` (imported only when the backend runs); ``needs``: what it
    takes from the run (fields of :class:`RunContext`: ``state_db`` its world lives in the run's state
    database, ``plan`` it sees the whole plan at the start, ``trajectory_path`` it records a trajectory
    there); ``acts_in_turns``: its robots share one world and act one at a time, so every robot needs its
    own executor thread and the coordinator reports each of its turns (``attach_coordinator``,
    ``coordinator_settled``); ``options``: the command-line options it adds; ``commands``: sub-commands of
    ``bimrobot rcan`` it adds, each ``"module:function"`` called with the argparse sub-parsers (a light
    module: it is imported whenever ``bimrobot rcan`` builds its parser); ``simulated_time``: its results
    carry simulated times (s), not a robot's clock, so the coordinator may hold a result back until every
    robot that could finish earlier has reported and handle results in simulated-time order (the same
    allocation whatever the threads do) at no cost to any robot.
    """

    backend: str
    needs: tuple[str, ...] = ()
    acts_in_turns: bool = False
    simulated_time: bool = False
    options: tuple[BackendOption, ...] = ()
    commands: tuple[str, ...] = ()

    def __post_init__(self):
        unknown = [n for n in self.needs if n not in CONTEXT_KEYWORDS]
        if unknown:
            raise ValueError(f"backend {self.backend} needs {unknown[0]!r}, which no run gives "
                             f"(expected some of: {', '.join(CONTEXT_KEYWORDS)})")

    @property
    def writes_trajectory(self) -> bool:
        return "trajectory_path" in self.needs


@dataclass(frozen=True)
class RunContext:
    """What a run gives its backend; None: this process has none (an executor in its own process has no
    plan). ``state_db``: the SQLite file of the run (or ``:memory:``); ``plan``: the run's activities;
    ``trajectory_path``: where a backend that records a trajectory writes it (beside the state database)."""

    state_db: str | None = None
    plan: tuple | None = None
    trajectory_path: Path | None = None

    @classmethod
    def of_run(cls, state_db: str, plan) -> "RunContext":
        """The context of a whole run on ``state_db`` (its trajectory file: ``<state db>.trajectory.csv``;
        none for a state database in memory)."""
        db = Path(state_db)
        path = None if str(state_db) == ":memory:" else db.with_name(db.name + ".trajectory.csv")
        return cls(str(state_db), tuple(plan), path)

    def arguments(self, needs: tuple[str, ...]) -> dict:
        """The constructor keywords for ``needs`` that this context has."""
        values = {need: getattr(self, need) for need in needs}
        return {CONTEXT_KEYWORDS[n]: (list(v) if n == "plan" else v) for n, v in values.items() if v is not None}


@dataclass(frozen=True)
class ActivityResult:
    """What a robot reports after an activity. Times are simulated/robot seconds since the build start."""

    activity_id: str
    attempt: int
    robot: str
    success: bool
    message: str
    started_s: float = 0.0
    finished_s: float = 0.0
    #: the robot stopped answering during the activity (its node died): RCAN takes it out of service and
    #: gives the activity to another capable robot, or escalates it when there is none
    robot_lost: bool = False

    @property
    def duration_s(self) -> float:
        return self.finished_s - self.started_s

    def to_message(self) -> dict:
        # the fields one by one: dataclasses.asdict deep-copies recursively, a cost on every result
        return {"activity_id": self.activity_id, "attempt": self.attempt, "robot": self.robot, "success": self.success,
                "message": self.message, "started_s": self.started_s, "finished_s": self.finished_s,
                "robot_lost": self.robot_lost}

    @classmethod
    def from_message(cls, message: dict) -> "ActivityResult":
        return cls(
            activity_id=str(message["activity_id"]),
            attempt=int(message["attempt"]),
            robot=str(message["robot"]),
            success=bool(message["success"]) if not isinstance(message["success"], str)
            else message["success"].lower() in ("1", "true"),
            message=str(message["message"]),
            started_s=float(message.get("started_s", 0.0)),
            finished_s=float(message.get("finished_s", 0.0)),
            robot_lost=bool(message.get("robot_lost", False)),
        )
