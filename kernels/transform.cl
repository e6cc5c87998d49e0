// transform.cl: see docs/ARCHITECTURE.md
