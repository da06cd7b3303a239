"""The six activity features a backend may implement (thesis Table 5.2), in compas_fab's style of backend
features: each is a small mixin class with one method named after its activity, and a backend class
is made of the features it implements (``class SimBackend(MoveToComponent, PickUp, ..., ExecutorBackend)``).

Each feature method takes the RCAN node, the attempt number, the robot time (s since the build start)
the activity may start at, and a feedback callback ``(progress 0..1, phase)``, and returns an
:class:`~bimrobot.rcan.backends.info.ActivityResult`. A backend's module implements a feature by
subclassing its class here and overriding the method.
"""

from __future__ import annotations

import abc
from typing import TYPE_CHECKING, ClassVar

from bimrobot.rcan.activities import ActivityKind

if TYPE_CHECKING:  # pragma: no cover
    from bimrobot.rcan.backends.info import ActivityResult
    from bimrobot.rcan.node import RcanNode


class ActivityFeature:
    """One activity feature: ``kind`` is its activity, the method of the same name executes it."""

    kind: ClassVar[ActivityKind]


class MoveToComponent(ActivityFeature):
    kind = ActivityKind.MOVE_TO_COMPONENT

    @abc.abstractmethod
    def move_to_component(self, node: RcanNode, attempt: int, ready_at_s: float, feedback) -> ActivityResult:
        """Drive the mobile base to the component (target: base pose next to it)."""


class PositionForPickingUp(ActivityFeature):
    kind = ActivityKind.POSITION_FOR_PICKING_UP

    @abc.abstractmethod
    def position_for_picking_up(self, node: RcanNode, attempt: int, ready_at_s: float, feedback) -> ActivityResult:
        """Bring the gripper to the grasp pose on the component with the manipulator."""


class PickUp(ActivityFeature):
    kind = ActivityKind.PICK_UP

    @abc.abstractmethod
    def pick_up(self, node: RcanNode, attempt: int, ready_at_s: float, feedback) -> ActivityResult:
        """Close the gripper on the component and lift it."""


class Transport(ActivityFeature):
    kind = ActivityKind.TRANSPORT

    @abc.abstractmethod
    def transport(self, node: RcanNode, attempt: int, ready_at_s: float, feedback) -> ActivityResult:
        """Drive the mobile base, carrying the component, to the installation stand pose."""


class PositionForInstalling(ActivityFeature):
    kind = ActivityKind.POSITION_FOR_INSTALLING

    @abc.abstractmethod
    def position_for_installing(self, node: RcanNode, attempt: int, ready_at_s: float, feedback) -> ActivityResult:
        """Bring the held component to its installed pose with the manipulator."""


class Install(ActivityFeature):
    kind = ActivityKind.INSTALL

    @abc.abstractmethod
    def install(self, node: RcanNode, attempt: int, ready_at_s: float, feedback) -> ActivityResult:
        """Fix the component in place, open the gripper and return the arm to its initial pose."""


#: every feature, in the order of the activities
ALL_FEATURES = (MoveToComponent, PositionForPickingUp, PickUp, Transport, PositionForInstalling, Install)


def features_of(cls: type) -> frozenset[ActivityKind]:
    """The activities a backend class implements: the features among its base classes."""
    return frozenset(base.kind for base in cls.__mro__ if "kind" in vars(base) and issubclass(base, ActivityFeature))
