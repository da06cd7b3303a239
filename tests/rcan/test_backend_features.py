"""Adding a backend is one module and one registry line (docs/rcan.md, "Adding a backend").

This test module is itself a backend, ``tiny``: five feature classes (no *transport*), a declaration
(:data:`INFO`: it needs the plan and a trajectory path, acts in turns, adds ``--tiny-step``), and the
tests add the one line ``BACKENDS["tiny"] = __name__`` and run RCAN plans through it, by the Python API
and by the command line.
"""

from __future__ import annotations

import pytest

from bimrobot.cli import main
from bimrobot.core.errors import InputError
from bimrobot.rcan.backends import BACKENDS, backend_class, declaration
from bimrobot.rcan.backends import features
from bimrobot.rcan.backends.info import BackendInfo, BackendOption
from bimrobot.rcan.backends.info import ActivityResult
from bimrobot.rcan.backends.interfaces import DispatchingBackend, ExecutorBackend
from bimrobot.rcan.generation import load_capabilities
from bimrobot.rcan.plans import experiment
from bimrobot.rcan.system import run_plan

INFO = BackendInfo(
    backend=f"{__name__}:TinyBackend",
    needs=("plan", "trajectory_path"),
    acts_in_turns=True,
    options=(BackendOption(("--tiny-step",), "tiny: robot seconds each activity takes (default 1)", keyword="step_s",
                           default=1.0, low=0.1, high=60.0, unit="s"),),
)


class _Robots:
    """What the tiny features share: every activity takes ``step_s`` robot seconds; a goal runs once."""

    def act(self, node, attempt: int, ready_at_s: float) -> ActivityResult:
        key = (node.activity_id, attempt)
        if key not in self.results:
            start = max(self.clock.get(node.robot, 0.0), ready_at_s)
            self.clock[node.robot] = start + self.step_s
            self.rows.append(f"{start + self.step_s:g},{node.robot},{node.kind.value}")
            self.results[key] = ActivityResult(node.activity_id, attempt, node.robot, True,
                                               f"{node.kind.label} done", start, start + self.step_s)
        return self.results[key]


class Move(features.MoveToComponent):
    def move_to_component(self, node, attempt, ready_at_s, feedback):
        return self.act(node, attempt, ready_at_s)


class Reach(features.PositionForPickingUp):
    def position_for_picking_up(self, node, attempt, ready_at_s, feedback):
        return self.act(node, attempt, ready_at_s)


class Grip(features.PickUp):
    def pick_up(self, node, attempt, ready_at_s, feedback):
        return self.act(node, attempt, ready_at_s)


class Place(features.PositionForInstalling):
    def position_for_installing(self, node, attempt, ready_at_s, feedback):
        return self.act(node, attempt, ready_at_s)


class Fix(features.Install):
    def install(self, node, attempt, ready_at_s, feedback):
        return self.act(node, attempt, ready_at_s)


class TinyBackend(Move, Reach, Grip, Place, Fix, _Robots, ExecutorBackend):
    """Robots that take ``step_s`` per activity and write the activities' ends to ``trajectory_path``."""

    name = "tiny"
    info = INFO
    last = None  # the latest instance, for the tests to look at

    def __init__(self, capabilities, plan=None, trajectory_path=None, step_s: float = 1.0):
        self.plan, self.trajectory_path, self.step_s = plan, trajectory_path, step_s
        self.results, self.clock, self.rows, self.turns = {}, {}, [], 0
        TinyBackend.last = self

    def coordinator_settled(self, results_handled: int, in_flight: int) -> None:
        self.turns += 1

    def summary(self) -> dict:
        return {"activities": len(self.rows)}

    def close(self) -> None:
        if self.trajectory_path is not None:
            self.trajectory_path.write_text("\n".join(self.rows) + "\n")


@pytest.fixture
def tiny(monkeypatch):
    """The one registry line of the tiny backend."""
    monkeypatch.setitem(BACKENDS, "tiny", __name__)
    return "tiny"


def test_a_backend_of_one_module_and_one_registry_line_runs_a_plan(tiny, tmp_path):
    state_db = tmp_path / "run.sqlite"
    plan = experiment(1).activities
    report = run_plan(plan, load_capabilities(), backend=tiny, state_db=str(state_db), backend_options={"step_s": 2.0})
    assert report.status == "completed" and report.done == [a.activity_id for a in plan]
    assert report.makespan_s == pytest.approx(5 * 2.0)  # five activities in a chain, 2 robot seconds each
    backend = TinyBackend.last
    assert [a.activity_id for a in backend.plan] == report.done  # the run gave it the plan ...
    assert backend.turns >= len(plan)  # ... and reported every turn of the coordinator
    assert report.backend_summary == {"activities": 5}
    rows = (tmp_path / "run.sqlite.trajectory.csv").read_text().splitlines()  # ... and its trajectory path
    assert rows[0] == "2,husky_ur5,move_to_component" and rows[-1] == "10,husky_ur5,install"


def test_a_plan_with_an_activity_the_backend_lacks_is_refused_before_the_run(tiny, tmp_path):
    assert TinyBackend.features == frozenset(feature.kind for feature in (Move, Reach, Grip, Place, Fix))
    with pytest.raises(InputError, match=r"the tiny backend does not implement 'Transport' \(activity E2\.4\)"):
        run_plan(experiment(2).activities, load_capabilities(), backend=tiny, state_db=str(tmp_path / "run.sqlite"))
    assert not (tmp_path / "run.sqlite").exists()


def test_the_backend_s_command_line_option_reaches_it(tiny, capsys):
    assert main(["rcan", "run", "--experiment", "1", "--backend", "tiny", "--tiny-step", "0.5", "-q"]) == 0
    assert "== completed: 5/5 activities done; components: 1 Assembled; makespan 2.5 s" in capsys.readouterr().out
    assert main(["rcan", "run", "--experiment", "1", "--backend", "tiny", "--tiny-step", "0"]) == 2
    assert "--tiny-step must be between 0.1 and 60 s, got 0.0" in capsys.readouterr().err


class OldStyle(DispatchingBackend):
    """A backend written before the features: one ``_run`` for every activity, no declaration."""

    def __init__(self, capabilities, db_path=":memory:", trajectory_path=None, plan=None):
        self.given = {"db_path": db_path, "trajectory_path": trajectory_path, "plan": plan}
        self.attached = False
        OldStyle.last = self

    def attach_coordinator(self) -> None:
        self.attached = True

    def _run(self, node, attempt, ready_at_s, feedback) -> ActivityResult:
        return ActivityResult(node.activity_id, attempt, node.robot, True, "done", ready_at_s, ready_at_s + 1.0)


def test_a_backend_without_features_runs_through_the_compatibility_path(monkeypatch, tmp_path):
    info = OldStyle.backend_info()  # read off its constructor and its attach_coordinator
    assert info.needs == ("plan", "trajectory_path") and info.acts_in_turns
    monkeypatch.setitem(BACKENDS, "old", f"{__name__}:OldStyle")  # a registry line naming its class
    report = run_plan(experiment(2).activities, load_capabilities(), backend="old", state_db=str(tmp_path / "s.sqlite"))
    assert report.status == "completed" and len(report.done) == 6 and OldStyle.last.attached
    assert OldStyle.last.given["trajectory_path"] == tmp_path / "s.sqlite.trajectory.csv"
    assert OldStyle.last.given["db_path"] == ":memory:"  # its db_path only placed the trajectory


def test_the_built_in_backends_declare_what_they_need():
    assert backend_class("sim").backend_info().needs == ("state_db",)  # its world lives in the state database
    assert [o.flags[0] for o in declaration("ros2").options] == ["--deadline-factor", "--deadline-min", "--liveness",
                                                                  "--robot-node"]
    mujoco = backend_class("mujoco")  # physical robots: the plan at the start, a trajectory, turns
    assert set(mujoco.features) == set(features.ActivityKind)
    assert mujoco.backend_info().needs == ("plan", "trajectory_path") and mujoco.backend_info().acts_in_turns
    assert issubclass(backend_class("sim"), ExecutorBackend)
