"""Examples shipped with casewatch: the SUMO data generator and the bundled reference data."""
