"""The built-in metric families, one module each (registered in `casewatch.monitor.registry`)."""
