"""What every job of the tools shares and nothing of theirs: the statistics vocabulary (statistics.py), the fields
of the result files and their ranges (fields.py), entry names and the typed entry (names.py), the words for
primitives, layouts and placements (words.py), number formatting, text tables and the atomic writer. Imports
from no other package of lockstep_reports (reports/tests/test_layering.py)."""
