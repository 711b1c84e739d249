"""Model files: sources, URDF validation, loading, reduction, physical consistency, summaries."""
