"""Command lines and benchmarks: the applications on top of every layer (scripts/ are their entry points)."""
