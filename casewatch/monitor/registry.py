"""The metric families the engine runs, in the order it runs them: the one registration a new
family needs (docs/architecture.md, "A metric").

Order matters where a family reads another's state of the same tick: motion prediction reads
the crpps inputs similarity leaves, situation reads the ego path comfort keeps.
"""

from __future__ import annotations

from casewatch.monitor.families.comfort import ComfortFamily
from casewatch.monitor.families.prediction import MotionPredictionFamily
from casewatch.monitor.families.safety import SafetyFamily
from casewatch.monitor.families.similarity import SimilarityFamily
from casewatch.monitor.families.situation import SituationFamily
from casewatch.monitor.family import MetricFamily

#: Every family, in the order the engine steps them each tick.
FAMILIES: tuple[type[MetricFamily], ...] = (
    SimilarityFamily,
    MotionPredictionFamily,
    ComfortFamily,
    SituationFamily,
    SafetyFamily,
)
