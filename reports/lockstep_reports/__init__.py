"""lockstep's result tools: `lockstep compare` and `lockstep report` (reports/README.md)."""
