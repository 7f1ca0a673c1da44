"""Opening a stream so that its bytes are hashed as they are read: moved to
`casewatch.monitor.source` (the one place a run's input is opened); these names stay for the
modules that still import them from here."""

from __future__ import annotations

from casewatch.monitor.source import HashingReader, file_digest, open_hashed, path_digest

__all__ = ["HashingReader", "file_digest", "open_hashed", "path_digest"]
