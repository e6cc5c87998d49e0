// silhouette.cl: see docs/ARCHITECTURE.md
