// geometry.cl: see docs/ARCHITECTURE.md
