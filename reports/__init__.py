"""Rendering results (from result.json alone) as HTML, Markdown and JUnit XML."""
