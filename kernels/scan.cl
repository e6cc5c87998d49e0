// scan.cl: see docs/ARCHITECTURE.md
