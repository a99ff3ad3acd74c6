"""`lockstep compare`: two sides entry by entry (compare.py, comparison.py), the pace (pace_statistics.py), sides of
several runs (replicates.py, replicated.py), the planner (planner.py), what makes files incomparable
(comparability.py), each machine's answer side by side (machine_answers.py) and the text (compare_text.py).
Imports from analysis/, read/ and common/ only, never from report/ (reports/tests/test_layering.py)."""
