// clip.cl: see docs/ARCHITECTURE.md
