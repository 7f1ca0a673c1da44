"""Turning per-tick robustness into violation episodes.

spi-reference: consecutive violating ticks (robustness < 0) form one episode; two episodes of
the same formula separated by less than `merge_gap` merge into one; an optional `min_duration`
drops shorter episodes (and counts them). An episode can only be declared closed once
`merge_gap` has passed without a new violation, so `EpisodeTracker.step` returns episodes as
they close, which is when `events.jsonl` gets them.
"""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass
class OpenEpisode:
    """An episode still being extended (or waiting out its merge window)."""

    start: float
    end: float
    ticks: int
    worst_robustness: float
    t_worst: float
    announced: bool = False  # its onset was reported (`EpisodeTracker.onset`)

    def extend(self, t: float, robustness: float) -> None:
        self.end = t
        self.ticks += 1
        if robustness < self.worst_robustness:
            self.worst_robustness = robustness
            self.t_worst = t


@dataclass
class ClosedEpisode:
    start: float
    end: float
    ticks: int
    worst_robustness: float
    t_worst: float


@dataclass
class EpisodeTracker:
    """Episodes of one formula. Feed every evaluated tick in time order."""

    merge_gap: float
    min_duration: float
    period: float
    current: OpenEpisode | None = None
    dropped: int = 0
    closed: int = field(default=0)

    def _duration(self, episode: OpenEpisode) -> float:
        # A single violating tick lasts one period: [start, end + period).
        return episode.end - episode.start + self.period

    def _close(self) -> ClosedEpisode | None:
        episode, self.current = self.current, None
        if episode is None:
            return None
        if self._duration(episode) < self.min_duration - 1e-9:
            self.dropped += 1
            return None
        self.closed += 1
        return ClosedEpisode(
            episode.start, episode.end, episode.ticks, episode.worst_robustness, episode.t_worst
        )

    def step(self, t: float, robustness: float | None) -> ClosedEpisode | None:
        """Account for tick `t`; `None` robustness is a data gap (it neither extends nor closes).

        Returns the episode that closed at this tick, if any.
        """
        done: ClosedEpisode | None = None
        episode = self.current
        violated = robustness is not None and robustness < 0
        if episode is not None:
            if violated:
                # Clean time between the two episodes: from the end of the last violating tick
                # (end + period) to this tick. Adjacent ticks (no clean time) always continue.
                separation = t - (episode.end + self.period)
                if separation > 1e-9 and separation >= self.merge_gap - 1e-9:
                    done = self._close()
                    episode = None
            elif t - episode.end >= self.merge_gap - 1e-9:
                # A violation from the next tick on would be separated by >= merge_gap:
                # nothing can join this episode any more.
                done = self._close()
                episode = None
        if violated:
            assert robustness is not None
            if episode is None:
                self.current = OpenEpisode(t, t, 1, robustness, t)
            else:
                episode.extend(t, robustness)
        return done

    def onset(self) -> OpenEpisode | None:
        """The open episode, the first time it is certain to be reported: once it lasts
        `min_duration` (then no closing can drop it). Call after `step`; a live run announces
        an episode at this tick (`episode_open`) instead of only when it closes."""
        episode = self.current
        if episode is None or episode.announced:
            return None
        if self._duration(episode) < self.min_duration - 1e-9:
            return None
        episode.announced = True
        return episode

    def finish(self) -> ClosedEpisode | None:
        """Close whatever is open at the end of the stream."""
        return self._close()
