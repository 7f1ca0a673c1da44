"""SPI thresholds from nominal driving (`casewatch calibrate`): sweep each SPI's threshold and
its persistence (`for:`), count its episodes on nominal stretches, bound the false-alarm rate,
and, given injected-fault labels (`evaluator.faults`), count the faults each candidate reveals.

An SPI is `signal OP threshold` held `for:` seconds. Its candidates are the thresholds of
`evaluator.tuning.threshold_candidates` (quantiles of the observed values, the original among
them) times the persistences of `CALIBRATION_WINDOWS` (and the original). For each candidate:

- **false alarms**: its episodes on the nominal ticks (ticks farther than a margin from every
  hazard label and every injected fault), per hour of nominal driving at which the signal had a
  value (the hours of evidence this SPI has), with an exact Poisson upper bound;
- **detection**: the injected faults of a family that lists the SPI's signal
  (`faults.FAMILY_SIGNALS`) overlapped by one of its episodes on the whole log (`faults.overlaps`);
- **fires**: whether any nominal value lies on the violated side of the threshold and any on the
  other side. A threshold beyond every observed value has no evidence behind it: the data say
  only that it never fires here, not where it should be (the cliff of issue 28: `ols` drops to
  exactly 0.0 whenever one channel reports an object no pair matches, so every threshold above
  0.0 fires on those drops and `>= 0.0` can never fire at all).

`choose` then picks the operating point (see its docstring). Everything returned is plain
values (dicts, lists, floats), so `calibration.json` and its page need nothing else.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from casewatch.evaluator.faults import FAMILY_SIGNALS, FaultLabel, overlaps
from casewatch.evaluator.signal_store import SavedSignals
from casewatch.evaluator.tuning import (
    Knob,
    TuningError,
    episodes_from,
    filling,
    formula_for,
    round_sig,
    threshold_candidates,
)
from casewatch.evaluator.vector_eval import Unsupported, robustness

#: `for:` windows [s] swept besides the original one (brief drops, such as a ghost object of a
#: fraction of a second, are filtered by persistence, not by a threshold).
CALIBRATION_WINDOWS = (0.0, 0.5, 1.0, 1.5, 2.0, 3.0)
#: Nominal hours of evidence an SPI needs before calibrate sets its threshold (`--min-hours`).
#: Half an hour holds about 18,000 ticks; a budget of a few episodes an hour is then a count of
#: one or two, the least that tells a rate from an accident.
DEFAULT_MIN_HOURS = 0.5
#: One-sided confidence of the false-alarm rate's upper bound.
CONFIDENCE = 0.95


def poisson_upper(count: int, confidence: float = CONFIDENCE) -> float:
    """The exact one-sided upper confidence bound of a Poisson mean after observing `count`
    events: the mean under which `count` or fewer events are as unlikely as 1 - `confidence`
    (Garwood's interval; equals chi2.ppf(confidence, 2 * count + 2) / 2). 0 events at 95 %:
    2.996; 1: 4.744; 2: 6.296.

    Why: calibrate's rates are counts of a few episodes over a fraction of an hour; the bound
    says how high the true rate may be, which the count alone hides."""
    if count < 0 or not 0 < confidence < 1:
        raise ValueError("poisson_upper needs count >= 0 and 0 < confidence < 1")
    alpha = 1.0 - confidence

    def cdf(mean: float) -> float:  # P(N <= count) for N ~ Poisson(mean), summed in logs
        terms = [i * math.log(mean) - mean - math.lgamma(i + 1) for i in range(count + 1)]
        top = max(terms)
        return math.exp(top) * sum(math.exp(x - top) for x in terms)

    lo, hi = float(count), float(count) + 10.0 * math.sqrt(count + 1.0) + 10.0
    for _ in range(200):  # cdf falls with the mean: bisect to full double precision
        mid = 0.5 * (lo + hi)
        if cdf(mid) > alpha:
            lo = mid
        else:
            hi = mid
        if hi - lo <= 1e-12 * max(1.0, hi):
            break
    return 0.5 * (lo + hi)


@dataclass(frozen=True)
class CalibrationLog:
    """One log as calibrate reads it: its nominal ticks (everything near a hazard label or an
    injected fault turned into a data gap), the whole log (for detection) and its faults."""

    nominal: SavedSignals
    whole: SavedSignals
    faults: list[FaultLabel] = field(default_factory=list)
    name: str = ""


def _levels(knob: Knob, log: SavedSignals, duration: float) -> np.ndarray:
    """(n,) the value the threshold is compared with at each tick under `for: duration`: the
    signal's best value over the window (its maximum for `>=`/`>`, minimum for `<=`/`<`; NaN
    at data gaps). The SPI is violated at a tick exactly when this level lies beyond the
    threshold, so one pass per duration serves every threshold.

    Why exact: the evaluator's robustness of `x >= th` held `for: d` is max over the window of
    (x - th); rounding is monotonic, so that is max(x) - th to the last bit, and its sign is
    the sign of max(x) - th. The robustness at th = 0 is the level itself."""
    assert knob.kind == "spi" and not knob.raw_stl and knob.signal_left
    formula = formula_for(knob, 0.0, duration)
    try:
        rho = robustness(
            formula, {knob.signal: log.column(knob.signal)}, log.t, log.period, log.max_gap
        )
    except Unsupported as exc:
        raise TuningError(f"{knob.formula_id}: {exc}") from None
    # `for:` as `casewatch run` judges it: never violated while its window fills
    rho[filling(log, np.isfinite(log.column(knob.signal)), duration)] = np.inf
    return rho if knob.op in (">=", ">") else -rho


def violated_at(knob: Knob, level: np.ndarray, threshold: float) -> np.ndarray:
    """(n,) True where `level` (`_levels`) violates the SPI at `threshold`; never at a gap."""
    with np.errstate(invalid="ignore"):
        return level < threshold if knob.op in (">=", ">") else level > threshold


@dataclass
class CalibrationSweep:
    """Every (for, threshold) candidate of one SPI on every log, as counts."""

    knob: Knob
    thresholds: list[float]
    durations: list[float]
    episodes: np.ndarray  # (durations, thresholds): nominal episodes over all logs
    detected: np.ndarray  # (durations, thresholds, faults): the fault overlapped by an episode
    faults: list[dict]  # the faults of the SPI's families: log, fault, channel, start, end
    fires: np.ndarray  # (thresholds,): some nominal value violates it and some does not
    ticks: int  # nominal ticks at which the signal had a value
    period: float
    extreme: float | None  # the observed nominal value farthest on the violated side
    at_extreme: int  # nominal ticks at exactly that value

    @property
    def hours(self) -> float:
        """Nominal hours at which the SPI's signal had a value (its evidence)."""
        return self.ticks * self.period / 3600.0


def calibration_sweep(
    knob: Knob,
    logs: Sequence[CalibrationLog],
    count: int = 200,
    windows: Sequence[float] = CALIBRATION_WINDOWS,
) -> CalibrationSweep:
    """Episodes and detections of every candidate of `knob` (an SPI bound by signal +
    threshold) on `logs`."""
    if not logs:
        raise TuningError(f"{knob.formula_id}: no logs to calibrate on")
    if knob.kind != "spi" or knob.raw_stl:
        raise TuningError(f"{knob.formula_id}: calibrate sets SPIs bound by signal + threshold")
    nominal = [log.nominal for log in logs]
    observed = any(np.isfinite(log.column(knob.signal)).any() for log in nominal)
    # no nominal value at all: nothing to sweep; `choose` reports the SPI as not calibrated
    thresholds = threshold_candidates(knob, nominal, count) if observed else [knob.value]
    period = nominal[0].period
    durations = sorted({round(round(d / period) * period, 9) for d in windows} | {knob.duration})
    values = np.concatenate([log.column(knob.signal) for log in nominal])
    values = values[np.isfinite(values)]
    th = np.asarray(thresholds)
    up = knob.op in (">=", ">")  # violated below the threshold
    if len(values):
        low, high = float(values.min()), float(values.max())
        fires = (low < th) & (th <= high) if up else (high > th) & (th >= low)
        extreme = low if up else high
        at_extreme = int(np.count_nonzero(values == extreme))
    else:
        fires, extreme, at_extreme = np.zeros(len(th), dtype=bool), None, 0
    faults = [
        (k, f)
        for k, log in enumerate(logs)
        for f in log.faults
        if knob.signal in FAMILY_SIGNALS.get(f.fault, ())
    ]
    episodes = np.zeros((len(durations), len(th)), dtype=np.int64)
    detected = np.zeros((len(durations), len(th), len(faults)), dtype=bool)
    for a, d in enumerate(durations):
        min_duration = knob.min_duration
        for k, log in enumerate(logs):
            level = _levels(knob, log.nominal, d)
            for b, threshold in enumerate(thresholds):
                found = episodes_from(
                    log.nominal.t,
                    violated_at(knob, level, threshold),
                    period,
                    knob.merge_gap,
                    min_duration,
                )
                episodes[a, b] += len(found)
            mine = [(j, f) for j, (i, f) in enumerate(faults) if i == k]
            if not mine:
                continue
            level = _levels(knob, log.whole, d)
            for b, threshold in enumerate(thresholds):
                found = episodes_from(
                    log.whole.t,
                    violated_at(knob, level, threshold),
                    period,
                    knob.merge_gap,
                    min_duration,
                )
                for j, f in mine:
                    detected[a, b, j] = overlaps(found, f)
    plain = [
        {
            "log": logs[k].name,
            "fault": f.fault,
            "channel": f.channel,
            "start": f.start,
            "end": f.end,
        }
        for k, f in faults
    ]
    return CalibrationSweep(
        knob,
        thresholds,
        durations,
        episodes,
        detected,
        plain,
        fires,
        len(values),
        period,
        extreme,
        at_extreme,
    )


def _stricter(knob: Knob, a: float, b: float) -> bool:
    """Whether threshold `a` is stricter than `b` (flags more) for this SPI."""
    return a > b if knob.op in (">=", ">") else a < b


def _point(sw: CalibrationSweep, a: int, b: int, confidence: float) -> dict:
    """One candidate as plain values: threshold, for, episodes, rate and its upper bound,
    detections."""
    n = int(sw.episodes[a, b])
    hours = sw.hours
    detected = int(sw.detected[a, b].sum())
    return {
        "threshold": sw.thresholds[b],
        "for": sw.durations[a],
        "episodes": n,
        "per_hour": n / hours if hours > 0 else None,
        "per_hour_upper": poisson_upper(n, confidence) / hours if hours > 0 else None,
        "detected": detected if sw.faults else None,
        "detection": detected / len(sw.faults) if sw.faults else None,
    }


def choose(
    sw: CalibrationSweep,
    per_hour: float,
    min_hours: float = DEFAULT_MIN_HOURS,
    tighten: bool = False,
    confidence: float = CONFIDENCE,
) -> dict:
    """The operating point of one SPI, and why.

    - Fewer than `min_hours` of nominal driving with a value of the signal: not calibrated
      (the original stays).
    - The original within `per_hour` on these logs, and not `tighten`: kept as it is.
    - Otherwise, among the candidates within the budget whose threshold can fire (`fires`) and,
      unless `tighten`, no stricter than the original in either threshold or `for:` (calibrate
      loosens what raises too many alarms; it does not spend a budget nobody asked it to
      spend): the strictest threshold, and at it the shortest `for:`. So persistence goes
      first: a longer `for:` blinds the SPI only to drops shorter than it (the ghosts and
      misses of a fraction of a second that break the budget), a looser threshold to every
      drop not as deep, however long; and the threshold is the claim the case makes.
    - No such candidate: not calibratable on these logs, with the reason (the original stays).

    The detection rate at every candidate is reported, never chosen on, so that fault labels
    change what calibrate shows, not what it writes."""
    k = sw.knob
    d0, th0 = sw.durations.index(k.duration), sw.thresholds.index(k.value)
    hours = sw.hours
    original = _point(sw, d0, th0, confidence)
    row = {
        "formula": k.formula_id,
        "node": k.node_id,
        "signal": k.signal,
        "op": k.op,
        "parameter": k.parameter,
        "hours": round(hours, 6),
        "nominal_ticks": sw.ticks,
        "faults": len(sw.faults),
        "original": original,
        "chosen": original,
        "status": "kept",
        "reason": "",
        "margin": 0.0,
        "curve": [
            _point(sw, a, b, confidence) | {"fires": bool(sw.fires[b])}
            for a in range(len(sw.durations))
            for b in range(len(sw.thresholds))
        ],
    }
    row["original_over_budget"] = bool(hours > 0 and original["per_hour"] > per_hour + 1e-12)
    if hours <= 0 or hours < min_hours - 1e-12:
        row["status"] = "not calibrated"
        row["reason"] = (
            f"{hours:.2f} h of nominal driving with a value of {k.signal}, fewer "
            f"than the {min_hours:g} h asked (--min-hours)"
            if hours > 0
            else f"no nominal tick with a value of {k.signal}"
        )
        return row
    if not tighten and not row["original_over_budget"]:
        row["reason"] = "the original keeps the budget"
        return row
    rate = sw.episodes / hours
    allowed = (rate <= per_hour + 1e-12) & sw.fires[None, :]
    if not tighten:
        for a, d in enumerate(sw.durations):
            for b, th in enumerate(sw.thresholds):
                if d < k.duration or _stricter(k, th, k.value):
                    allowed[a, b] = False
    if not allowed.any():
        row["status"] = "not calibratable"
        row["reason"] = _why_not(sw, per_hour, rate, tighten)
        return row
    # thresholds ascend: for `>=` the strictest is the largest
    columns = np.flatnonzero(allowed.any(axis=0))
    b = int(columns[-1] if k.op in (">=", ">") else columns[0])
    a = int(np.flatnonzero(allowed[:, b])[0])
    row["chosen"] = _point(sw, a, b, confidence)
    row["status"] = "calibrated" if (a, b) != (d0, th0) else "kept"
    th = sw.thresholds[b]
    row["margin"] = round_sig(th - k.value if k.op in (">=", ">") else k.value - th, 6)
    return row


def _why_not(sw: CalibrationSweep, per_hour: float, rate: np.ndarray, tighten: bool) -> str:
    """Why no candidate both fires and keeps the budget, in the data's own numbers."""
    k = sw.knob
    side = "above" if k.op in (">=", ">") else "below"
    text = f"no threshold that can fire keeps {per_hour:g}/h"
    if sw.extreme is not None and sw.at_extreme >= 2:
        share = sw.at_extreme / max(sw.ticks, 1)
        text += (
            f": {k.signal} is exactly {sw.extreme:g} on {sw.at_extreme} nominal ticks "
            f"({share:.1%}), and every threshold {side} {sw.extreme:g} fires there"
        )
    usable = [
        (a, b)
        for a, d in enumerate(sw.durations)
        for b in range(len(sw.thresholds))
        if sw.fires[b]
        and (tighten or (d >= k.duration and not _stricter(k, sw.thresholds[b], k.value)))
    ]
    if usable:
        a, b = min(usable, key=lambda ab: (rate[ab], -sw.durations[ab[0]]))
        text += (
            f"; quietest that can fire: {k.op} {sw.thresholds[b]:g} for "
            f"{sw.durations[a]:g} s at {rate[a, b]:.1f}/h"
        )
    else:
        text += "; no threshold looser than the original fires on these values"
    return text
