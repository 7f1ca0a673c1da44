"""Judging: rtamt online monitors, episodes, hazard events, data gaps, node status and scores."""
