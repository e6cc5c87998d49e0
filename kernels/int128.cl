// int128.cl: see docs/ARCHITECTURE.md
