"""The interface every executor backend implements (in compas_fab's style of backend features).

A backend drives robots. Its *features* are the construction activities of thesis chapter 5 it
implements, each a small mixin class of :mod:`bimrobot.rcan.backends.features` with one method named
after its activity (``move_to_component``, ...); what it needs from a run and the command-line options it
adds are its :class:`~bimrobot.rcan.backends.info.BackendInfo`. Adding a backend means adding one folder
in :mod:`bimrobot.rcan.backends` and one line in :data:`bimrobot.rcan.backends.BACKENDS` (docs/rcan.md,
"Adding a backend").

Idempotency contract: ``execute`` is keyed on ``(activity_id, attempt)``. A backend that already
completed that goal returns the recorded result instead of executing it again, so a resumed run can
re-send a goal whose result it never received without the robot doing the work twice.
"""

from __future__ import annotations

import abc
import contextlib
import inspect
from typing import Callable, ClassVar, Collection

from bimrobot.core.tasks import ActivityKind
from bimrobot.rcan.backends.features import ALL_FEATURES, features_of
from bimrobot.rcan.backends.info import CONTEXT_KEYWORDS, ActivityResult, BackendInfo, RunContext
from bimrobot.rcan.node import RcanNode

#: Feedback callback: (progress 0..1, phase text).
FeedbackCallback = Callable[[float, str], None]


class ExecutorBackend(abc.ABC):
    """Drives robots for RCAN nodes. A subclass mixes in the features it implements
    (:mod:`bimrobot.rcan.backends.features`) and declares :attr:`info`."""

    name: str = "abstract"
    #: what the backend needs from a run and the options it adds; None: read off a backend written
    #: before BackendInfo (:meth:`backend_info`)
    info: ClassVar[BackendInfo | None] = None
    #: the activities it implements: its feature classes (set for each subclass unless it says itself)
    features: ClassVar[Collection[ActivityKind]] = frozenset()

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        if "features" not in vars(cls):
            cls.features = features_of(cls)

    # --- what the backend declares ----------------------------------------------------------------
    @classmethod
    def backend_info(cls) -> BackendInfo:
        """The backend's declaration: :attr:`info`, or for a backend that declares none yet (written
        before BackendInfo), what its old hooks said: the run items its constructor takes (``db_path``,
        ``plan``, ``trajectory_path``) and whether it has ``attach_coordinator`` (it acts in turns)."""
        if cls.info is not None:
            return cls.info
        parameters = inspect.signature(cls.__init__).parameters
        needs = tuple(need for need, keyword in CONTEXT_KEYWORDS.items() if keyword in parameters)
        if "trajectory_path" in needs:  # its db_path only placed the trajectory, which the run now gives
            needs = tuple(need for need in needs if need != "state_db")
        in_turns = cls.attach_coordinator is not ExecutorBackend.attach_coordinator
        return BackendInfo(f"{cls.__module__}:{cls.__qualname__}", needs, in_turns)

    @classmethod
    def create(cls, capabilities, context: RunContext, **options) -> "ExecutorBackend":
        """The backend for a run: what it needs from ``context`` (:meth:`backend_info`), then
        ``options`` (which win)."""
        return cls(capabilities, **{**context.arguments(cls.backend_info().needs), **options})

    @classmethod
    def options_from(cls, args) -> dict:
        """The constructor's options from the parsed command line: each declared option with a keyword."""
        return {option.keyword: getattr(args, option.dest) for option in cls.backend_info().options
                if option.keyword and hasattr(args, option.dest)}

    @classmethod
    def around_run(cls, args, model_offset: tuple[float, float]):
        """A context manager around ``rcan run``'s run (``model_offset``: model -> site, m), for what the
        backend starts and stops with it (the ``ros2`` backend's robot node); the default does nothing."""
        return contextlib.nullcontext()

    # --- executing ---------------------------------------------------------------------------------
    def execute(
        self, node: RcanNode, attempt: int = 1, ready_at_s: float = 0.0, feedback: FeedbackCallback | None = None
    ) -> ActivityResult:
        """Run ``node``'s activity on its robot, not before ``ready_at_s``, with the feature of its kind;
        idempotent per (activity, attempt). An activity the backend does not implement fails."""
        if node.kind not in self.features:
            return ActivityResult(node.activity_id, attempt, node.robot, False,
                                  f"the {self.name} backend does not implement '{node.kind.label}'")
        return getattr(self, node.kind.value)(node, attempt, ready_at_s, feedback)

    def attach_coordinator(self) -> None:
        """The coordinator runs in this process and reports :meth:`coordinator_settled` after each of its
        turns (a backend that ``acts_in_turns``); the default needs nothing."""

    def coordinator_settled(self, results_handled: int, in_flight: int) -> None:
        """The coordinator has handled ``results_handled`` results in all and waits for ``in_flight``
        nodes; the default does nothing."""

    def summary(self) -> dict:
        """What the backend measured in the run, for the run report (``backend_summary``); default none."""
        return {}

    def stop(self) -> None:
        """The run is ending (finished or interrupted): give up waiting for robots, so that no thread
        outlives the run. The default waits for nothing."""

    def close(self) -> None:
        """Release connections; the default has none."""


class DispatchingBackend(*ALL_FEATURES, ExecutorBackend):
    """A backend that executes all six features through one method, :meth:`_run`, which looks at
    ``node.kind`` itself: the compatibility path of a backend written before the features (it declares
    no :attr:`info` either: :meth:`ExecutorBackend.backend_info` reads its old hooks)."""

    @abc.abstractmethod
    def _run(self, node: RcanNode, attempt: int, ready_at_s: float, feedback) -> ActivityResult:
        """Execute ``node``'s activity, whatever its kind."""

    def move_to_component(self, node, attempt, ready_at_s, feedback) -> ActivityResult:
        return self._run(node, attempt, ready_at_s, feedback)

    def position_for_picking_up(self, node, attempt, ready_at_s, feedback) -> ActivityResult:
        return self._run(node, attempt, ready_at_s, feedback)

    def pick_up(self, node, attempt, ready_at_s, feedback) -> ActivityResult:
        return self._run(node, attempt, ready_at_s, feedback)

    def transport(self, node, attempt, ready_at_s, feedback) -> ActivityResult:
        return self._run(node, attempt, ready_at_s, feedback)

    def position_for_installing(self, node, attempt, ready_at_s, feedback) -> ActivityResult:
        return self._run(node, attempt, ready_at_s, feedback)

    def install(self, node, attempt, ready_at_s, feedback) -> ActivityResult:
        return self._run(node, attempt, ready_at_s, feedback)


FEATURES = tuple(kind.value for kind in ActivityKind)
