"""Schedules in and out: the schedule CSV (:mod:`.csv`), Microsoft Project XML (:mod:`.msproject`) and
IFC work schedules, the 4D model (:mod:`.ifc`). Times are seconds from the build's start unless a
calendar date is said.
"""
