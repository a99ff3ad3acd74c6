"""`lockstep report`: the sections and pages (report.py), the answer box (answer.py), the sync x layout matrix
(matrix.py), core-to-core analysis, the paper's values, the figures and the page templates (templates/). Imports
from analysis/, read/ and common/ only, never from compare/ (reports/tests/test_layering.py)."""
