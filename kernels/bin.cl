// bin.cl: see docs/ARCHITECTURE.md
