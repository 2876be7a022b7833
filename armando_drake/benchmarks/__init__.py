"""The benchmark suite behind ``python -m armando_drake.bench``: speed and memory
targets, measured, never asserted in timed unit tests."""
