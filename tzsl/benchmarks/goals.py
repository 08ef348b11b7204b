"""The speed goals of ``make bench``, written once: :data:`GOALS` (issue 33, "The main job in one minute").

Each :class:`Goal` names the measurement it is checked on (a row of the bench table of
:mod:`tzsl.benchmarks.bench_goals`: its ``part``, ``study``, ``stage``, ``run`` and ``quantity``;
``None`` matches any value) and its upper limit. The printout and the CSV of ``make bench`` both
read this table; a goal that ``make bench`` does not time names the command that does
(:attr:`Goal.measured_by`).
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["GOALS", "PARTS", "Goal", "goal_by_name"]

#: The parts ``make bench`` can time (``--only``), in the order it runs them; ``evidence`` only when asked.
PARTS: tuple[str, ...] = ("reproduce", "template", "predict", "evidence")


@dataclass(frozen=True)
class Goal:
    """One goal: the measurement it applies to and its upper limit.

    Attributes
    ----------
    name : str
        Short identifier (the CSV's ``goal`` column).
    text : str
        What is timed, in the issue's words.
    limit : float
        The measurement must be at most this, in ``unit``.
    unit : str
        ``"s"`` (wall seconds), ``"ms"`` (milliseconds) or ``"x"`` (a ratio).
    part, study, stage, run, quantity : str or None
        The bench-table rows the goal is checked on (None: any value).
    measured_by : str
        The command that measures it: ``"make bench"`` or another one (then ``part`` is ``""``).
    """

    name: str
    text: str
    limit: float
    unit: str
    part: str
    study: str | None = "total"
    stage: str | None = "total"
    run: str | None = "cold"
    quantity: str | None = "wall"
    measured_by: str = "make bench"

    def matches(self, row: dict) -> bool:
        """Whether the goal is checked on this bench-table row (a mapping of its columns)."""
        wanted = {"part": self.part, "study": self.study, "stage": self.stage, "run": self.run,
                  "quantity": self.quantity}
        return all(value is None or row.get(key) == value for key, value in wanted.items())


#: Every speed goal of issue 33, on 2 cores. The ratio is to one PHAC-2 split's attribute fits
#: (``tzsl bench --skip-literal``) measured in the same ``make bench`` run.
GOALS: tuple[Goal, ...] = (
    Goal("reproduce-cold", "tzsl reproduce-tables, cold (empty cache)", 60.0, "s", "reproduce"),
    Goal("reproduce-cold-ratio", "tzsl reproduce-tables, cold, over one split's attribute fits", 15.0, "x",
         "reproduce", quantity="ratio_to_split_fit"),
    Goal("reproduce-warm", "tzsl reproduce-tables, a second plain run", 5.0, "s", "reproduce", run="warm"),
    Goal("template-cold", "the template (every method, calibration folds, GZSL) on a 41-object, 2,549-grasp, "
         "3-finger dataset, cold", 300.0, "s", "template"),
    Goal("predict-cold", "tzsl predict of one grasp, cold process", 1.0, "s", "predict", study=None,
         stage="predict"),
    Goal("predict-api", "one grasp through tzsl.inference.Recogniser", 10.0, "ms", "predict", study=None,
         stage=None, run="api", quantity="per_grasp"),
    Goal("evidence-cold", "tzsl evidence, cold (empty cache)", 1200.0, "s", "evidence"),
    Goal("evidence-warm", "tzsl evidence, rerun", 10.0, "s", "evidence", run="warm"),
    Goal("scale-100k", "100,000 SIMULATED trials with the default settings, cold", 300.0, "s", "",
         measured_by="make bench-scale SCALE_SIZES=100000"),
    Goal("fresh-clone", "a fresh clone's first make reproduce-tables, install included", 240.0, "s", "",
         measured_by="time make reproduce-tables in a new clone, by hand"),
)


def goal_by_name(name: str) -> Goal:
    """The goal of :data:`GOALS` called ``name`` (KeyError when there is none)."""
    for goal in GOALS:
        if goal.name == name:
            return goal
    raise KeyError(name)
