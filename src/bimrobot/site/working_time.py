"""Working time of the site: the :class:`WorkCalendar` (working days and daily hours, local wall-clock
time) and the arithmetic that lays seconds of work onto it (:func:`working_datetime`).
"""

from __future__ import annotations

import datetime as dt
from dataclasses import dataclass

from bimrobot.core.errors import InputError

WEEKDAY_NAMES = ("Monday", "Tuesday", "Wednesday", "Thursday", "Friday", "Saturday", "Sunday")


@dataclass(frozen=True)
class WorkCalendar:
    """When the site works: ``days`` (weekday names, Monday first) and one daily period ``hours`` =
    (start, end) as "HH:MM" (local wall-clock time, no time zone, start < end on the same day).

    The fields are the site file's ``work_calendar`` keys, in text, so that the calendar written into a
    report (``dataclasses.asdict``, JSON) reads back as a site file's. The default is Monday-Friday
    07:00-16:00 (9 h a day, 45 h a week)."""

    days: tuple[str, ...] = WEEKDAY_NAMES[:5]
    hours: tuple[str, str] = ("07:00", "16:00")

    @property
    def weekdays(self) -> tuple[int, ...]:
        """ISO weekday numbers of the working days (1 = Monday ... 7 = Sunday)."""
        return tuple(WEEKDAY_NAMES.index(day) + 1 for day in self.days)

    @property
    def start_time(self) -> dt.time:
        return dt.time.fromisoformat(self.hours[0])

    @property
    def end_time(self) -> dt.time:
        return dt.time.fromisoformat(self.hours[1])

    @property
    def day_s(self) -> float:
        """Working seconds of one working day."""
        return _seconds_of_day(self.end_time) - _seconds_of_day(self.start_time)

    @property
    def week_s(self) -> float:
        """Working seconds of one week."""
        return self.day_s * len(self.weekdays)

    def __str__(self) -> str:
        """E.g. ``Monday-Friday 07:00-16:00``: runs of consecutive days joined by a dash."""
        runs: list[list[int]] = []
        for day in sorted(self.weekdays):
            if runs and runs[-1][-1] == day - 1:
                runs[-1].append(day)
            else:
                runs.append([day])
        days = ", ".join(WEEKDAY_NAMES[r[0] - 1] + (f"-{WEEKDAY_NAMES[r[-1] - 1]}" if len(r) > 1 else "") for r in runs)
        return f"{days} {self.start_time:%H:%M}-{self.end_time:%H:%M}"


def _seconds_of_day(time: dt.time) -> float:
    return time.hour * 3600 + time.minute * 60 + time.second


def working_datetime(calendar: WorkCalendar, origin: dt.datetime, seconds: float, *, finish: bool = False) -> dt.datetime:
    """The date-time at which ``seconds`` of working time have passed since ``origin``.

    Work only runs in the calendar's working periods: the simulated seconds of a robot's work are laid
    onto working hours, so an hour of work that starts at 15:30 on a Friday ends at 07:30 on Monday
    (default calendar). An instant at the end of a working day is the end of that day when it is a
    ``finish`` and the start of the next working day otherwise. ``origin`` outside working time counts
    from the next working period. Pure arithmetic, no time zone (wall-clock time of the site).
    """
    monday = dt.datetime.combine(origin.date() - dt.timedelta(days=origin.weekday()), dt.time())
    worked = _worked_in_week(calendar, monday, origin) + seconds
    weeks, rest = divmod(worked, calendar.week_s)
    if finish and rest == 0 and weeks > 0:  # the end of the last working day of the week before
        weeks, rest = weeks - 1, calendar.week_s
    start_s = _seconds_of_day(calendar.start_time)
    for day in range(7):
        if day + 1 not in calendar.weekdays:
            continue
        if rest < calendar.day_s or (finish and rest <= calendar.day_s):
            return monday + dt.timedelta(weeks=weeks, days=day, seconds=start_s + rest)
        rest -= calendar.day_s
    return monday + dt.timedelta(weeks=weeks + 1)  # not reached: rest < week_s


def _worked_in_week(calendar: WorkCalendar, monday: dt.datetime, when: dt.datetime) -> float:
    """Working seconds from ``monday`` 00:00 to ``when`` (a date-time of that week)."""
    day = (when.date() - monday.date()).days
    worked = calendar.day_s * sum(1 for d in calendar.weekdays if d <= day)
    if day + 1 in calendar.weekdays:
        into = (when - dt.datetime.combine(when.date(), calendar.start_time)).total_seconds()
        worked += min(max(into, 0.0), calendar.day_s)
    return worked


def working_seconds(calendar: WorkCalendar, start: dt.datetime, finish: dt.datetime) -> float:
    """Working seconds of the calendar from ``start`` to ``finish`` (the inverse of :func:`working_datetime`;
    0 when ``finish`` is not after ``start``)."""
    if finish <= start:
        return 0.0
    monday = dt.datetime.combine(start.date() - dt.timedelta(days=start.weekday()), dt.time())
    later = dt.datetime.combine(finish.date() - dt.timedelta(days=finish.weekday()), dt.time())
    weeks = (later - monday).days // 7
    return weeks * calendar.week_s + _worked_in_week(calendar, later, finish) - _worked_in_week(calendar, monday, start)


def working_days(calendar: WorkCalendar, first: dt.date, last: dt.date) -> int:
    """Working days of the calendar from ``first`` to ``last``, both included."""
    weeks, extra = divmod((last - first).days + 1, 7)
    return weeks * len(calendar.weekdays) + sum(
        1 for d in range(extra) if (first + dt.timedelta(days=d)).isoweekday() in calendar.weekdays)


def work_calendar_from(value, source: str, line: str = "") -> WorkCalendar:
    """The site file's ``work_calendar`` value, e.g. ``{days: [Monday, ..., Friday], hours: ["07:00", "16:00"]}``.

    ``days``: weekday names (or their first three letters, any case); ``hours``: [start, end] as
    ``"HH:MM"`` (an unquoted 7:00 reads as YAML's 420 minutes and is taken so). Both keys are optional
    (default Monday-Friday, 07:00-16:00). ``source`` (the file) and ``line`` (`` line N`` of the key)
    name where in a refusal."""
    from bimrobot.core.config import check_keys, line_of

    if not isinstance(value, dict):
        raise InputError(f"{source}{line}: key 'work_calendar' must be a mapping with days and hours, "
                         "e.g. {days: [Monday, Tuesday, Wednesday, Thursday, Friday], hours: ['07:00', '16:00']}")
    check_keys(value, ("days", "hours"), source, "work_calendar")
    default = WorkCalendar()
    weekdays, (start, end) = default.weekdays, (default.start_time, default.end_time)
    if "days" in value:
        where = f"{source}{line_of(value, 'days')}: work_calendar: key 'days'"
        days = value["days"]
        if not isinstance(days, list) or not days:
            raise InputError(f"{where} must be a non-empty list of weekday names, e.g. [Monday, Tuesday]")
        weekdays = tuple(sorted({_weekday(day, where) for day in days}))
    if "hours" in value:
        where = f"{source}{line_of(value, 'hours')}: work_calendar: key 'hours'"
        hours = value["hours"]
        if not isinstance(hours, list) or len(hours) != 2:
            raise InputError(f"{where} must be [start, end], e.g. ['07:00', '16:00'], got {hours!r}")
        start, end = (_clock(h, where) for h in hours)
        if not start < end:
            raise InputError(f"{where}: the start {start:%H:%M} must be before the end {end:%H:%M} on the same day")
    return WorkCalendar(tuple(WEEKDAY_NAMES[d - 1] for d in weekdays), (f"{start:%H:%M}", f"{end:%H:%M}"))


def _weekday(name, where: str) -> int:
    text = str(name).strip().lower()
    for number, day in enumerate(WEEKDAY_NAMES, start=1):
        if len(text) >= 3 and day.lower().startswith(text):
            return number
    raise InputError(f"{where}: {name!r} is not a weekday (Monday ... Sunday, or Mon ... Sun)")


def _clock(value, where: str) -> dt.time:
    if isinstance(value, int) and not isinstance(value, bool) and 0 <= value < 24 * 60:  # YAML 1.1 read 7:00 as 420
        return dt.time(value // 60, value % 60)
    try:
        return dt.time.fromisoformat(str(value))
    except ValueError:
        raise InputError(f"{where}: {value!r} is not a time of day such as '07:00'") from None
