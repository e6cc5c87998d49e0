// emit.cl: see docs/ARCHITECTURE.md
