// occlude.cl: see docs/ARCHITECTURE.md
