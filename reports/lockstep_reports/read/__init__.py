"""Reading a result file, once: its kind's schema (schemas.py, docs/schemas/), then the reader of its kind, which
checks what a schema cannot say and gives the typed objects every tool uses (inputs.read_document is the one door).
Imports from common/ only (reports/tests/test_layering.py)."""
