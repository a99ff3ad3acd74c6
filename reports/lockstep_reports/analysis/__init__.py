"""What one run file gives both tools: samples and medians, calibrations, the layouts' traits, each primitive
against the best other (run_analysis.py), each machine by its own measure (normalisation.py). Imports from read/
and common/ only (reports/tests/test_layering.py)."""
