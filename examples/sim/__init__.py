"""SUMO-based generator of two-channel reference streams with ground-truth labels.

This package is an optional extra (`pip install -e .[sim]`): it needs Eclipse SUMO (`libsumo`,
`sumolib`, the `netconvert`/`netgenerate` binaries). Nothing in casewatch's core imports it; the
demo reads the bundled output under `examples/data/` without a simulator.

Pipeline: `networks` builds the road network, `scenarios` holds the seeded scenario definitions,
`simulate` runs SUMO and records the ground truth, `channels` turns the ground truth into what two
imperfect driving channels would report, `labels` derives the hazard intervals, `frames` writes
the casewatch frame format, and `build_data` regenerates the bundled set.
"""
