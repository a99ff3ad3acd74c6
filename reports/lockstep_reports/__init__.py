"""lockstep's result tools: `lockstep compare` and `lockstep report` (DESIGN.md, Reports)."""
