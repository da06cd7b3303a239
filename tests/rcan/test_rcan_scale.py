"""Scale: a site of 20,000 robots runs on a bounded pool of executor threads, not one thread per robot."""

from __future__ import annotations

import threading

from bimrobot.schedule.csv import load_schedule_csv
from bimrobot.rcan.generation import parse_capabilities
from bimrobot.rcan.plans import plan_from_schedule
from bimrobot.rcan.system import run_plan

from rcan_helpers import TABLE_5_2


class ThreadCounter:
    """Observer: the most threads alive while the run goes on."""

    def __init__(self):
        self.most = 0

    def set_activity_state(self, activity_id, state):
        self.most = max(self.most, threading.active_count())


def test_twenty_thousand_robots_in_a_capability_table_run_on_a_bounded_pool(schedule_csv):
    # the table as parsed YAML (reading 20,000 robots from a file with line numbers is the config
    # reader's time, not the run's)
    robot = {"types": ["mobile_base", "manipulator", "gripper"], "payload_kg": 1000, "reach_m": 5.0,
             "handling_s": {"pick_up": 10, "install": 20}}
    capabilities = parse_capabilities({"robot_types": TABLE_5_2, "robots": {
        f"crane_{i:05d}": {**robot, "home": [float(i % 100), float(i // 100), 0.0]} for i in range(20_000)}}, "site")
    assert len(capabilities.robots) == 20_000
    plan = plan_from_schedule(load_schedule_csv(schedule_csv))
    before, counter = threading.active_count(), ThreadCounter()
    report = run_plan(plan, capabilities, observers=[counter], timeout_s=300)
    assert report.status == "completed" and len(report.done) == len(plan)
    assert counter.most - before <= 20  # the executor's pool and the coordinator, whatever the robot count
