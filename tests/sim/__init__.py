"""Tests for the SUMO reference-data generator (examples/sim)."""
