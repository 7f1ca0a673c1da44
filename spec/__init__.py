"""Compiling SPI and hazard bindings into STL formulas that rtamt evaluates correctly."""
